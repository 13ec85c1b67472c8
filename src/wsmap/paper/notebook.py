"""One notebook as one DVC stage: `python -m wsmap.paper.notebook NAME`.

`dvc.yaml` runs every notebook stage through this module rather than the `wsmap` command line,
so that what a stage depends on is what it runs: this module, the papermill runner
(`wsmap.paper.pipeline`) and the modules the notebook imports, and nothing that the rest of
the command line could load (`tools/stage_deps.py` writes each stage's deps from that closure).
`wsmap paper run NAME` does the same for a person, with `--params` and `--root`.

Exit status: 0 when the notebook ran, 2 for an unknown notebook, a parameters file without its
section, or a notebook that raised (one line naming the cell and the executed copy that holds the
traceback), 130 when interrupted.
"""

from __future__ import annotations

import os
import sys

from . import run_stage
from .pipeline import NotebookError, check_notebook, run_notebook


def _run(names: list[str]) -> None:
    for name in names:  # every name checked before anything runs
        check_notebook(name)
    for name in names:
        run_notebook(name)


def main(argv=None) -> int:
    """Run the notebooks named in `argv` with `params.yaml` into the project root."""
    names = sys.argv[1:] if argv is None else list(argv)
    if not names or any(n.startswith("-") for n in names):
        print("usage: python -m wsmap.paper.notebook NAME [NAME ...]  (wsmap paper run --help for options)",
              file=sys.stderr)
        return 2
    # one process, two cores: keep torch and BLAS from oversubscribing inside the kernel
    os.environ.setdefault("OMP_NUM_THREADS", "2")
    os.environ.setdefault("MPLBACKEND", "Agg")
    return run_stage(lambda: _run(names), (ValueError, NotebookError), "wsmap: interrupted")


if __name__ == "__main__":
    sys.exit(main())

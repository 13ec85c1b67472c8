"""The paper's reproduction, apart from the library: what regenerates the article's tables and figures.

* `.specs` — the paper's datasets (`PAPER_SPECS`) and their files;
* `.published` — the paper's published numbers, in one place;
* `.fitting` — train the paper's subspace models on a dataset and score them;
* `.tables` — the experiments behind Tables 1–3;
* `.runtime` — the run-time comparison (classical against the network);
* `.report` — `results/REPORT.md`, every reproduced number beside the paper's;
* `.parts` — one module per part of the paper (per notebook and DVC stage): its `run`,
  `save`, `figures` and `Metrics` schema, registered with its priority (its place in the run
  order), the parts it reads and, where it runs at the paper's scale, its `Scale`; the
  notebooks call them;
* `.pipeline` — the papermill runner of the notebooks (`wsmap paper run`), in the parts' order;
* `.scale` — what a part declares to run at the paper's scale (`Scale`: its units, steps and
  summary) and what those entry points receive;
* `.full` — the paper's scale, part by part and resumable (`wsmap paper full`): the parts'
  `Scale` records run, resumed and listed;
* `.dataset`, `.notebook` — one dataset, one notebook as one DVC stage (both end in
  `run_stage`).
"""

from __future__ import annotations

import signal
import sys
from collections.abc import Callable


def _terminate(signum, frame):
    # dvc stops a stage with SIGTERM: unwind as for Ctrl-C, so that the stage cleans up as it does
    # then (no temporary file left in place, the last good executed notebook restored)
    raise KeyboardInterrupt


def run_stage(work: Callable[[], object], errors: tuple[type[BaseException], ...], interrupted: str) -> int:
    """Run `work()` as a DVC stage's command and return its exit status: 0 when it returns, 2 with
    one line `wsmap: error: ...` on stderr for one of `errors` (bad input: no traceback), 130
    with the line `interrupted` on Ctrl-C or SIGTERM."""
    signal.signal(signal.SIGTERM, _terminate)
    try:
        work()
    except errors as e:
        print(f"wsmap: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(interrupted, file=sys.stderr)
        return 130
    return 0

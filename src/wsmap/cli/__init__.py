"""The one command line: `wsmap map`, `wsmap place`, `wsmap robots`, `wsmap data`, `wsmap paper`
(also `python -m wsmap`).

Examples::

    wsmap map --robot puma560 --out puma560.npz --png puma560_slices.png
    wsmap map --robot panda --kind index --orientations 50 --step 0.05 --out panda_index.npz --html panda.html
    wsmap map --robot ur5e --kind index --step 0.05 --h5 ur5e_reachability.h5   # Reuleaux (ROS)
    wsmap map --robot panda --rpy pi 0 0 --png panda_tooldown.png -q              # a picture alone
    wsmap place --robot ur5e --targets poses.csv --x -1 1 --y -1 1 --out ranking.csv
    wsmap map --d 0 0 0.15 0.43 0 0 --a 0 0.43 0.02 0 0 0 \\
              --alpha pi/2 0 -pi/2 pi/2 -pi/2 0 --method numerical --out mine.npz
    wsmap map --robot puma560 --method model --model models/improved_model.pt --out nn.npz
    wsmap data build sec61 --samples 10000 --test-samples 1000 --out data/sec61.npz
    wsmap data build panda7_tooldown --samples 2000 --test-samples 200 --out data/panda7.npz --workers 2
    wsmap data build panda7_tooldown --samples 100000 --out data/panda7.npz --scheduler tcp://head:8786
    wsmap paper run sec61_subspace            # one notebook (a DVC stage) with params.yaml
    wsmap paper run --all --params params.full.yaml --root full --timeout 0

Every input is checked before any work and before any file is written; the outputs of a run are
written to temporary files and put in place together when the whole run has succeeded. A bad
input ends with exit code 2 and one line naming the problem, never a traceback.

Each subcommand is one module of this package (`map`, `place`, `data`, `paper`): its options and
a `run(args)` that parses them into a job of the library (`wsmap.jobs`) or calls the library, and
prints; `arguments` holds the shared argument types and option groups.
"""

from __future__ import annotations

import signal
import sys
import threading

from ..paper.pipeline import NotebookError
from . import data, map, paper, place, study
from .arguments import Parser, number

__all__ = ["main", "number"]


def _parser():
    from .._version import __version__

    p = Parser(prog="wsmap", description="Manipulator workspace maps, classical and learned.")
    p.add_argument("--version", action="version", version=f"wsmap {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="{map,place,study,robots,data,paper}",
                           parser_class=Parser)
    for module in (map, place, study):
        module.add_parser(sub)
    data.add_robots_parser(sub)
    data.add_parser(sub)
    paper.add_parser(sub)
    return p


def _protect_negative_expressions(argv):
    # argparse takes '-pi/2' for an option; a leading space makes it a value (number() strips it)
    out = []
    for tok in argv:
        if tok.startswith("-") and not tok.startswith("--") and len(tok) > 1 and not tok[1].isalpha() or tok.startswith("-pi"):
            tok = " " + tok
        out.append(tok)
    return out


def main(argv=None) -> int:
    """Run the command line; returns the exit code (0 success, 2 bad input or failure, 130 interrupted)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    args = _parser().parse_args(_protect_negative_expressions(argv))
    # SIGTERM (dvc, a job scheduler, kill) and SIGHUP (the terminal closed) unwind like Ctrl-C, so
    # temporary files are removed (SIGHUP's default ended the process with its temporary file left)
    caught = [signal.SIGTERM] + ([signal.SIGHUP] if hasattr(signal, "SIGHUP") else [])
    previous = ({sig: signal.signal(sig, _terminate) for sig in caught}
                if threading.current_thread() is threading.main_thread() else None)
    try:
        return args.run(args)
    except KeyboardInterrupt:
        print("wsmap: interrupted; no output was written", file=sys.stderr)
        return 130
    except NotebookError as e:  # a notebook's own error, its traceback kept in the executed copy
        print(f"wsmap: error: {e}", file=sys.stderr)
        return 2
    except (ValueError, TypeError, KeyError, MemoryError, OSError) as e:
        # bad input or an OS refusal: one line, no traceback (outputs are only put in place on success)
        msg = e.args[0] if isinstance(e, KeyError) and e.args else e
        if isinstance(e, OSError) and e.filename and str(e.filename) not in str(e):
            msg = f"{e.filename}: {e.strerror or e}"
        print(f"wsmap: error: {msg}", file=sys.stderr)
        return 2
    finally:
        for sig, handler in (previous or {}).items():
            signal.signal(sig, handler)


def _terminate(signum, frame):
    raise KeyboardInterrupt


if __name__ == "__main__":
    sys.exit(main())


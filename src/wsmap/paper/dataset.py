"""One dataset of the catalogue as one DVC stage:
`python -m wsmap.paper.dataset NAME --samples N --test-samples M --out data/NAME.npz`.

`dvc.yaml`'s `datasets` stages run this module rather than `wsmap data build` so that what a
stage depends on is what it runs: the dataset code, the catalogue (`wsmap.paper.specs`) and
the kinematics the labels need (`tools/stage_deps.py` writes the deps from that closure). The
file is the one `wsmap data build NAME --samples N --test-samples M --out FILE --quiet` writes
(byte-identical; both call `wsmap.datasets.build_dataset_files`).
"""

from __future__ import annotations

import argparse
import sys

from ..datasets import build_dataset_files
from . import run_stage
from .specs import dataset_spec


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a number of arms of at least 1, got {value}")
    return value


def main(argv=None) -> int:
    """Build the training file and its test file; 0 on success, 2 for bad input, 130 interrupted."""
    ap = argparse.ArgumentParser(prog="python -m wsmap.paper.dataset", description=__doc__.splitlines()[0])
    ap.add_argument("name", help="a dataset of the catalogue (wsmap data list)")
    ap.add_argument("--samples", type=_count, required=True, help="arms of the training file")
    ap.add_argument("--test-samples", type=_count, required=True, help="arms of the test file (NAME.test.npz)")
    ap.add_argument("--out", required=True, help="the training file (.npz)")
    args = ap.parse_args(argv)
    return run_stage(lambda: build_dataset_files(dataset_spec(args.name), args.out, samples=args.samples,
                                                 test_samples=args.test_samples, progress=False),
                     (ValueError, OSError), "wsmap: interrupted; no output was written")


if __name__ == "__main__":
    sys.exit(main())

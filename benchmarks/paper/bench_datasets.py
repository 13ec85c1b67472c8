"""Benchmark: build the largest dataset of the paper (section 6.2: 1e5 arms x 9261 nodes, exact labels).

Prints the wall time, the peak resident memory of the process (``ru_maxrss``) and the file size.
Goal: under 2 minutes on a 2-core machine.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/paper/bench_datasets.py                 # full size
    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/paper/bench_datasets.py --samples 10000 # scaled, extrapolated
"""

from __future__ import annotations

import resource
import sys
import tempfile
from pathlib import Path

from wsmap import datasets
from wsmap.paper.specs import PAPER_SPECS

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def main(argv=None) -> int:
    p = harness.parser(__doc__)
    p.add_argument("--spec", default="sec62", choices=sorted(PAPER_SPECS), help="paper spec (default sec62)")
    p.add_argument("--samples", type=int, help="scale the sample count (default: the spec's, 1e5 for sec62)")
    p.add_argument("--chunk", type=int, help="arms per chunk (default: the builder's)")
    p.add_argument("--load", action="store_true", help="also time load_dataset and unpacking the labels")
    p.add_argument("--progress", action="store_true")
    args = p.parse_args(argv)

    full = PAPER_SPECS[args.spec]
    spec = datasets.scaled(full, args.samples) if args.samples else full
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"{spec.name}.npz"
        build_s, _ = harness.timed(lambda: datasets.build_dataset(spec, path, chunk=args.chunk,
                                                                  progress=args.progress))
        size = path.stat().st_size
        rss_build = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        if args.load:
            load_s, ds = harness.timed(lambda: datasets.load_dataset(path, expect_spec=spec))
            unpack_s, pos = harness.timed(lambda: float(ds.labels.mean()))
    pairs = spec.samples * spec.n_nodes
    print(f"spec {spec.name}: {spec.samples} arms x {spec.n_nodes} nodes = {pairs:.3e} labels ({spec.method})")
    print(f"build: {build_s:.2f} s wall, {pairs / build_s:.3e} labels/s")
    if spec.samples != full.samples:
        print(f"extrapolated to {full.samples} arms: {build_s * full.samples / spec.samples:.1f} s (linear)")
    print(f"file: {size / 2**20:.1f} MiB ({8 * size / pairs:.3f} bits per label)")
    # ru_maxrss is KiB on Linux
    print(f"peak RSS: {rss_build / 1024:.0f} MiB after build (at start {rss0 / 1024:.0f} MiB)")
    if args.load:
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        print(f"load + checksum: {load_s:.2f} s; unpack labels: {unpack_s:.2f} s (positives {pos:.4f}); "
              f"peak RSS {rss / 1024:.0f} MiB")
    harness.write_json(args, {
        "spec": spec.name, "samples": spec.samples, "nodes": spec.n_nodes, "method": spec.method,
        "build_seconds": build_s, "labels_per_second": pairs / build_s, "file_bytes": size,
        "peak_rss_mib_after_build": rss_build / 1024, "rss_mib_at_start": rss0 / 1024,
        "load_seconds": load_s if args.load else None, "unpack_seconds": unpack_s if args.load else None})
    return 0


if __name__ == "__main__":
    sys.exit(main())

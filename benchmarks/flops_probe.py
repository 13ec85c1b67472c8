"""This core's double-precision throughput, scalar and SIMD: numba loops of independent fused
multiply-adds (8 chains per lane group, so latency is hidden), best of 5, one thread.

    NUMBA_NUM_THREADS=1 python benchmarks/flops_probe.py [--json out.json]

Scalar: 8 independent chains of ``x = x * a + b`` on float64 locals (one FMA, 2 flops, per step);
SIMD: the same on 8 chains of ``W`` lanes (W = 4: AVX2 ymm, W = 8: AVX-512 zmm), written as loops
over a constant lane count that LLVM vectorises (the assembly is checked for ymm/zmm FMAs and
printed). The bound in docs/performance.md ("The limit") divides these rates by an LM iteration's
flop count.
"""
from __future__ import annotations

import argparse
import json
import re
import time

import numpy as np
from numba import njit

STEPS = 20_000_000


@njit(fastmath={"contract"})
def scalar_fma(steps, a, b):
    x0 = x1 = x2 = x3 = x4 = x5 = x6 = x7 = 1.0
    for _ in range(steps):
        x0 = x0 * a + b
        x1 = x1 * a + b
        x2 = x2 * a + b
        x3 = x3 * a + b
        x4 = x4 * a + b
        x5 = x5 * a + b
        x6 = x6 * a + b
        x7 = x7 * a + b
    return x0 + x1 + x2 + x3 + x4 + x5 + x6 + x7


def _lanes(W):
    @njit(fastmath={"contract"})
    def simd_fma(steps, a, b):
        x = np.ones(8 * W)
        for _ in range(steps):
            for c in range(8 * W):
                x[c] = x[c] * a + b
        return x.sum()
    return simd_fma


def best(fn, *args, repeats=5):
    fn(10, *args[1:])
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn(*args)
        ts.append(time.perf_counter() - t0)
    return min(ts)


def fma_regs(fn) -> set:
    asm = "\n".join(fn.inspect_asm().values())
    return set(re.findall(r"vfmadd\w*\s+%?([xyz])mm", asm))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json")
    args = ap.parse_args(argv)
    a, b = 0.999999, 1e-7
    out = {}
    t = best(scalar_fma, STEPS, a, b)
    out["scalar"] = 8 * STEPS * 2 / t
    print(f"scalar FMA chains: {out['scalar'] / 1e9:6.2f} Gflop/s  (fma registers: {sorted(fma_regs(scalar_fma))})")
    for W in (2, 4, 8):
        fn = _lanes(W)
        steps = STEPS // W
        t = best(fn, steps, a, b)
        out[f"simd{W}"] = 8 * W * steps * 2 / t
        print(f"{W} lanes x 8 chains: {out[f'simd{W}'] / 1e9:6.2f} Gflop/s  (fma registers: {sorted(fma_regs(fn))})")
    if args.json:
        from wsmap.io import write_json
        write_json(out, args.json)


if __name__ == "__main__":
    main()

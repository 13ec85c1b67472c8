"""This core's double-precision throughput, scalar and SIMD: numba loops of independent fused
multiply-adds (8 chains per lane group, so latency is hidden), best of 5, one thread.

    NUMBA_NUM_THREADS=1 python benchmarks/kernel/flops_probe.py [--json out.json]

Scalar: 8 independent chains of ``x = x * a + b`` on float64 locals (one FMA, 2 flops, per step);
SIMD: the same on 8 chains of ``W`` lanes (W = 4: AVX2 ymm, W = 8: AVX-512 zmm), written as loops
over a constant lane count that LLVM vectorises (the assembly is checked for ymm/zmm FMAs and
printed). The bound in docs/speed.md ("The limit") divides these rates by an LM iteration's
flop count.

Then the question of the lane kernel: does numba vectorise a loop over lanes? A joint step of the
forward kinematics (a 3 x 3 rotation about z, the joint axis, per lane) in three layouts of the lane
state, 8 and 16 lanes: 3-D arrays ``(rows, 3, L)`` as the lane kernel had them, one flat 1-D scratch
array with constant offsets, and a separate 1-D array per matrix entry; ns per lane and joint step,
and whether the assembly has packed (``pd``) or only scalar (``sd``) FMAs. numba runs LLVM's loop
vectoriser but not the SLP vectoriser (``NUMBA_SLP_VECTORIZE`` = 0 by default), the loop vectoriser
leaves loops of fewer than 16 iterations alone when it would need run-time alias checks, and numba
arrays carry no no-alias information.
"""
from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
from numba import njit

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402

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


def _lane_layouts(L):
    @njit(fastmath={"contract", "reassoc"})
    def arrays3d(qt, n, reps):
        R = np.ones((3, 3, L))
        w = np.empty((n, 3, L))
        for _ in range(reps):
            for i in range(n):
                for r in range(3):
                    for l in range(L):
                        w[i, r, l] = R[r, 2, l] * 0.5
                        r0 = R[r, 0, l] * qt[i, l] + R[r, 1, l] * 0.3
                        r1 = R[r, 1, l] * qt[i, l] - R[r, 0, l] * 0.3
                        R[r, 0, l] = r0
                        R[r, 1, l] = r1
        return R[0, 0, 0] + w[0, 0, 0]

    @njit(fastmath={"contract", "reassoc"})
    def flat(qt, n, reps):
        S = np.ones(9 * L + 3 * n * L)
        for _ in range(reps):
            for i in range(n):
                for r in range(3):
                    for l in range(L):
                        S[(9 + 3 * i + r) * L + l] = S[(3 * r + 2) * L + l] * 0.5
                        r0 = S[(3 * r) * L + l] * qt[i, l] + S[(3 * r + 1) * L + l] * 0.3
                        r1 = S[(3 * r + 1) * L + l] * qt[i, l] - S[(3 * r) * L + l] * 0.3
                        S[(3 * r) * L + l] = r0
                        S[(3 * r + 1) * L + l] = r1
        return S[0]

    @njit(fastmath={"contract", "reassoc"})
    def separate(qt, n, reps):
        R00, R01, R10, R11, R20, R21 = (np.ones(L), np.ones(L), np.ones(L), np.ones(L), np.ones(L), np.ones(L))
        for _ in range(reps):
            for i in range(n):
                for l in range(L):
                    x = qt[i, l]
                    a = R00[l] * x + R01[l] * 0.3
                    b = R01[l] * x - R00[l] * 0.3
                    R00[l] = a
                    R01[l] = b
                    a = R10[l] * x + R11[l] * 0.3
                    b = R11[l] * x - R10[l] * 0.3
                    R10[l] = a
                    R11[l] = b
                    a = R20[l] * x + R21[l] * 0.3
                    b = R21[l] * x - R20[l] * 0.3
                    R20[l] = a
                    R21[l] = b
        return R00[0]

    return arrays3d, flat, separate


def best(fn, *args, repeats=5):
    """Best of `repeats` timed calls `fn(*args)`, after a short call that compiles it."""
    fn(10, *args[1:])
    return harness.best_of(lambda: fn(*args), repeats)[0]


def fma_regs(fn) -> set:
    asm = "\n".join(fn.inspect_asm().values())
    return set(re.findall(r"vfmadd\w*\s+%?([xyz])mm", asm))


def main(argv=None):
    ap = harness.parser(__doc__, repeat=5, repeat_help="timed calls per loop, best kept (default 5)")
    args = ap.parse_args(argv)
    a, b = 0.999999, 1e-7
    out = {}
    t = best(scalar_fma, STEPS, a, b, repeats=args.repeat)
    out["scalar"] = 8 * STEPS * 2 / t
    print(f"scalar FMA chains: {out['scalar'] / 1e9:6.2f} Gflop/s  (fma registers: {sorted(fma_regs(scalar_fma))})")
    for W in (2, 4, 8):
        fn = _lanes(W)
        steps = STEPS // W
        t = best(fn, steps, a, b, repeats=args.repeat)
        out[f"simd{W}"] = 8 * W * steps * 2 / t
        print(f"{W} lanes x 8 chains: {out[f'simd{W}'] / 1e9:6.2f} Gflop/s  (fma registers: {sorted(fma_regs(fn))})")
    print("\nlane loops: one joint step of the forward kinematics per lane, 7 joints")
    reps = 200_000
    for L in (8, 16):
        qt = np.random.default_rng(0).uniform(0, 0.01, (7, L))
        for fn in _lane_layouts(L):
            fn(qt, 7, 1)  # compile
            t = harness.best_of(lambda: fn(qt, 7, reps), args.repeat)[0]  # noqa: B023 - called at once
            asm = "\n".join(fn.inspect_asm().values())
            packed = len(re.findall(r"vf(?:n?madd|n?msub)\w*pd", asm))
            scalar = len(re.findall(r"vf(?:n?madd|n?msub)\w*sd", asm))
            name = fn.py_func.__name__
            out[f"lanes{L}_{name}"] = {"ns_per_lane_step": t / reps / 7 / L * 1e9, "packed_fma": packed,
                                       "scalar_fma": scalar}
            print(f"  {L:2d} lanes, {name:9s}: {t / reps / 7 / L * 1e9:5.2f} ns per lane and joint; "
                  f"packed FMAs {packed}, scalar FMAs {scalar}")
    harness.write_json(args, out)


if __name__ == "__main__":
    main()

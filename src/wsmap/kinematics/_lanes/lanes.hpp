// The LM search of wsmap.kinematics.lm_compiled (_task, _lm and their callees) over a block of
// L targets at once: every per-target number of the iteration is an array of L lanes, so the
// forward kinematics, the pose error, the Jacobian, the normal equations and the solve run on
// several lanes per SIMD instruction (AVX-512 / AVX2 where the CPU has them, lanesmodule.cpp picks
// the build at run time). For 6 and 7 joints the iteration is register-blocked (iterate_fixed:
// unrolled straight-line code on vector values, the pose, the Jacobian's columns and the
// elimination kept in registers; acceptance, damping and the stopping tests as masks over the
// lanes); other chains run loops over the lanes' arrays (iterate_arrays). What ends a lane's run
// (its next start, its next target) is done lane by lane, and a lane whose target is finished takes
// the next one, so the lanes stay full.
//
// Same arithmetic per target as the scalar kernel (the tests compare the two: the same successes
// and starts, q within the tolerance); the sums are in the same order but the compiler's fused
// multiply-adds differ, so the bits may differ in the last places. A target's answer does not
// depend on its lane, the other targets, or the thread count: every lane runs the same operations.
//
// This header is compiled once per instruction set (lanes_isa.cpp, namespace WSMAP_ISA).
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

namespace wsmap_lanes {

constexpr int MODE_SEARCH = 0, MODE_PAPER = 1, MODE_POSITION = 2;
constexpr int SUCCESS = 1, REJECTIONS = 2, ILIMIT = 3, STAGNATED = 4, AT_START = 5, STATIONARY = 6;
constexpr int MAX_JOINTS = 16;  // longer chains run on the scalar kernel

// The fields of lm_compiled.KernelCall, one line each: the group (its attribute of the call), the C
// type, the name (the Python field's), and for an array its element count in M targets, B arms, n
// joints and S explicit starts per target. The members of Args, their reading from Python and their
// checks (lanesmodule.cpp) all come from these two tables; lm_lanes checks at import that they name
// the Python fields. A new field: a line here, a field there, and its use in each kernel.
#define WSMAP_LANES_ARRAYS(X)                        \
    X(targets, const int64_t, arm, M)                \
    X(targets, const double, Rt, M * 9)              \
    X(targets, const double, pt, M * 3)              \
    X(targets, const uint64_t, keys, M)              \
    X(targets, const double, qexp, M * S * n)        \
    X(targets, const int64_t, nexp, M)               \
    X(arms, const double, Rf, B * (n + 1) * 9)       \
    X(arms, const double, tf, B * (n + 1) * 3)       \
    X(arms, const int8_t, rkind, B * (n + 1))        \
    X(arms, const double, off, B * n)                \
    X(arms, const double, axes, n * 3)               \
    X(arms, const bool, pris, n)                     \
    X(arms, const bool, zax, n)                      \
    X(arms, const double, lo, B * n)                 \
    X(arms, const double, hi, B * n)                 \
    X(arms, const double, clo, B * n)                \
    X(arms, const double, chi, B * n)                \
    X(arms, const bool, clipped, B * n)              \
    X(arms, const bool, limited, B)                  \
    X(arms, const bool, unlimited, B * n)            \
    X(arms, const double, blo, B * n)                \
    X(arms, const double, bhi, B * n)                \
    X(out, double, q, M * n)                         \
    X(out, bool, ok, M)                              \
    X(out, int64_t, iterations, M)                   \
    X(out, double, residual, M)                      \
    X(out, int64_t, start, M)
#define WSMAP_LANES_SCALARS(X)          \
    X(settings, int64_t, mode)          \
    X(settings, int64_t, k_first)       \
    X(settings, int64_t, k_last)        \
    X(settings, int64_t, ilimit)        \
    X(settings, int64_t, rlimit)        \
    X(settings, double, tol)            \
    X(settings, double, lam0)           \
    X(settings, double, gtol)           \
    X(settings, double, confirm_tol)    \
    X(settings, bool, free_pass)

// Everything one call reads and writes: a pointer per array of the call (numpy arrays, C order),
// its settings, its sizes, and the counter of the targets taken.
struct Args {
    int64_t M, B, n, S;  // targets, arms, joints, explicit starts per target
#define WSMAP_LANES_ARRAY_MEMBER(group, T, name, count) T *name;
#define WSMAP_LANES_SCALAR_MEMBER(group, T, name) T name;
    WSMAP_LANES_ARRAYS(WSMAP_LANES_ARRAY_MEMBER)
    WSMAP_LANES_SCALARS(WSMAP_LANES_SCALAR_MEMBER)
#undef WSMAP_LANES_ARRAY_MEMBER
#undef WSMAP_LANES_SCALAR_MEMBER
    int64_t *counter;  // the next target to take, shared by every thread of the call
};

}  // namespace wsmap_lanes

#ifdef WSMAP_ISA
namespace wsmap_lanes {
namespace WSMAP_ISA {

constexpr double TWO_PI = 2.0 * 3.14159265358979311600;
constexpr double PI = 3.14159265358979311600;
constexpr double EPS = 2.220446049250313e-16;
constexpr double TINY = 5e-324;
constexpr double INF = std::numeric_limits<double>::infinity();

// a loop over the lanes, vectorised whatever the compiler's cost model says (-fopenmp-simd)
#define LANES_LOOP _Pragma("omp simd") for (int l = 0; l < L; ++l)
// an OR over the lanes into the int `anyv` (vectorised as a reduction)
#define LANES_ANY _Pragma("omp simd reduction(|:anyv)") for (int l = 0; l < L; ++l)
// a loop over the lanes of the part h .. h + W - 1 of a block (the register-blocked iteration)
#define PART_LOOP _Pragma("omp simd") for (int l = h; l < h + W; ++l)

// L doubles as one value (GCC's vector extension; one register of AVX-512 for L = 8, two of AVX2),
// and the mask a comparison of two gives (all bits set where true)
template <int L>
struct VecOf {
    typedef double T __attribute__((vector_size(8 * L)));
    typedef int64_t M __attribute__((vector_size(8 * L)));
};
// a loop over joints or rows unrolled (its trip count a compile-time constant)
#define UNROLL _Pragma("GCC unroll 16")
// the doubles one vector register holds in this build: GCC splits a wider vector type badly (into
// many times the instructions), so a block wider than this runs its iteration part by part
#if defined(__AVX512F__)
constexpr int NATIVE_LANES = 8;
#elif defined(__AVX__)
constexpr int NATIVE_LANES = 4;
#else
constexpr int NATIVE_LANES = 2;
#endif

// sin and cos as lm_compiled._sincos (fdlibm's kernels after a three-part Cody-Waite reduction),
// branch-free so that a loop over lanes vectorises; |x| >= 1e5 and NaN are fixed afterwards by libm.
static inline __attribute__((always_inline)) void sincos_poly(double x, double &sv, double &cv) {
    const double t = x * 6.36619772367581382433e-01 + 6755399441055744.0;  // round to nearest
    const double k = t - 6755399441055744.0;
    int64_t q;
    std::memcpy(&q, &t, sizeof(q));  // the low bits of t's mantissa: k modulo 2^51
    const double r = ((x - k * 1.57079632673412561417e+00) - k * 6.07710050630396597660e-11) - k * 2.02226624871116645580e-21;
    const double z = r * r;
    const double s = r + r * z * (-1.66666666666666324348e-01 + z * (8.33333333332248946124e-03 + z * (
        -1.98412698298579493134e-04 + z * (2.75573137070700676789e-06 + z * (
        -2.50507602534068634195e-08 + z * 1.58969099521155010221e-10)))));
    const double c = 1.0 - 0.5 * z + z * z * (4.16666666666666019037e-02 + z * (-1.38888888888741095749e-03 + z * (
        2.48015872894767294178e-05 + z * (-2.75573143513906633035e-07 + z * (
        2.08757232129817482790e-09 + z * -1.13596475577881948265e-11)))));
    double a = (q & 1) ? c : s;
    double b = (q & 1) ? s : c;
    sv = (q & 2) ? -a : a;
    cv = ((q + 1) & 2) ? -b : b;
}

static inline uint64_t mix(uint64_t z) {
    z += 0x9E3779B97F4A7C15ULL;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
}

// numpy's float remainder (np.mod): the sign of the divisor
static inline double npmod(double a, double b) {
    double m = std::fmod(a, b);
    if (m != 0.0) {
        if ((b < 0) != (m < 0)) m += b;
    } else {
        m = std::copysign(0.0, b);
    }
    return m;
}

static inline double project1(double qj, double lo, double hi, bool revolute) {
    if (qj >= lo && qj <= hi) return qj;
    if (!revolute) return std::fmin(std::fmax(qj, lo), hi);
    double s;
    if (std::isfinite(lo)) s = lo + npmod(qj - lo, TWO_PI);
    else s = hi - npmod(hi - qj, TWO_PI);
    if (s > hi) s = (s - hi <= lo + TWO_PI - s) ? hi : lo;
    return s;
}

// np.spacing(|x|), the gap to the next float above |x|, from the exponent bits (no libm call, so a
// loop over lanes vectorises); below 2^-970 the smallest subnormal instead (smaller than the true
// gap there: the stagnation test that uses it only gets stricter)
static inline __attribute__((always_inline)) double spacing_fast(double x) {
    uint64_t bits;
    const double ax = std::fabs(x);
    std::memcpy(&bits, &ax, sizeof(bits));
    const uint64_t e = bits >> 52;  // the biased exponent
    const uint64_t out = (e > 52 ? e - 52 : 0) << 52;
    double v;
    std::memcpy(&v, &out, sizeof(v));
    return v > 0.0 ? v : TINY;
}

// atan2(y, x) for y >= 0 (the rotation angle's sine and cosine), branch-free so that a loop over
// lanes vectorises: Cephes' reduction of atan to [-0.42, 0.66] (by pi/4 and pi/2 with their
// low-order parts) and its rational minimax approximation; within 2 ulp of libm
// (tests/kinematics/test_lm_lanes.py)
static inline __attribute__((always_inline)) double atan2_pos(double y, double x) {
    const double ax = std::fabs(x);
    const bool swap = y > ax;
    const double num = swap ? ax : y, den = swap ? y : ax;
    double t = den > 0.0 ? num / den : 0.0;  // in [0, 1]
    // atan(t): t > 0.66 reduced by pi/4
    const bool mid = t > 0.66;
    const double base = mid ? 7.85398163397448309616e-1 : 0.0;
    const double lo = mid ? 0.5 * 6.123233995736765886130e-17 : 0.0;
    t = mid ? (t - 1.0) / (t + 1.0) : t;
    const double z = t * t;
    const double P = (((-8.750608600031904122785e-1 * z - 1.615753718733365076637e1) * z - 7.500855792314704667340e1) * z -
                      1.228866684490136173410e2) * z - 6.485021904942025371773e1;
    const double Q = ((((z + 2.485846490142306297962e1) * z + 1.650270098316988542046e2) * z + 4.328810604912902668951e2) * z +
                      4.853903996359136964868e2) * z + 1.945506571482613964425e2;
    double r = base + (t * (z * P / Q) + lo) + t;
    // undo the swap (pi/2 - r) and the sign of x (pi - r)
    r = swap ? (1.57079632679489661923 - r) + 6.123233995736765886130e-17 : r;
    r = x < 0.0 ? (3.14159265358979311600 - r) + 1.2246467991473532e-16 : r;
    return (std::isnan(x) || std::isnan(y)) ? x + y : r;
}

// lm_compiled._confirm: forward kinematics by 4 x 4 products (another path than the lanes' own),
// the tool within atol of the target and q inside the limits
static bool confirm(const Args &a, const double *q, int64_t b, const double *Rt, const double *pt, int rows) {
    const int64_t n = a.n;
    for (int64_t j = 0; j < n; ++j)
        if (q[j] < a.lo[b * n + j] - 1e-9 || q[j] > a.hi[b * n + j] + 1e-9) return false;
    double M4[4][4] = {}, N4[4][4], P4[4][4];
    const double *Rf = a.Rf + b * (n + 1) * 9, *tf = a.tf + b * (n + 1) * 3;
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) M4[r][c] = Rf[r * 3 + c];
        M4[r][3] = tf[r];
    }
    M4[3][3] = 1.0;
    for (int64_t i = 0; i < n; ++i) {
        const double x = q[i] + a.off[b * n + i];
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c) N4[r][c] = r == c ? 1.0 : 0.0;
        const double *u = a.axes + 3 * i;
        if (a.pris[i]) {
            for (int r = 0; r < 3; ++r) N4[r][3] = u[r] * x;
        } else {
            const double c0 = std::cos(x), s0 = std::sin(x);
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c) N4[r][c] = c0 * (r == c ? 1.0 : 0.0) + (1.0 - c0) * u[r] * u[c];
            N4[0][1] -= s0 * u[2];
            N4[1][0] += s0 * u[2];
            N4[0][2] += s0 * u[1];
            N4[2][0] -= s0 * u[1];
            N4[1][2] -= s0 * u[0];
            N4[2][1] += s0 * u[0];
        }
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c)
                P4[r][c] = M4[r][0] * N4[0][c] + M4[r][1] * N4[1][c] + M4[r][2] * N4[2][c] + M4[r][3] * N4[3][c];
        const double *R1 = Rf + (i + 1) * 9, *t1 = tf + (i + 1) * 3;
        for (int r = 0; r < 3; ++r) {
            for (int c = 0; c < 3; ++c) N4[r][c] = R1[r * 3 + c];
            N4[r][3] = t1[r];
        }
        for (int c = 0; c < 4; ++c) N4[3][c] = c == 3 ? 1.0 : 0.0;
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c)
                M4[r][c] = P4[r][0] * N4[0][c] + P4[r][1] * N4[1][c] + P4[r][2] * N4[2][c] + P4[r][3] * N4[3][c];
    }
    const double dx = M4[0][3] - pt[0], dy = M4[1][3] - pt[1], dz = M4[2][3] - pt[2];
    const double dp = std::sqrt(dx * dx + dy * dy + dz * dz);
    if (rows == 3) return dp <= a.confirm_tol;
    double v0 = 0, v1 = 0, v2 = 0, cs = 0;
    for (int k = 0; k < 3; ++k) {
        v0 += M4[1][k] * Rt[2 * 3 + k] - M4[2][k] * Rt[1 * 3 + k];
        v1 += M4[2][k] * Rt[0 * 3 + k] - M4[0][k] * Rt[2 * 3 + k];
        v2 += M4[0][k] * Rt[1 * 3 + k] - M4[1][k] * Rt[0 * 3 + k];
        for (int r = 0; r < 3; ++r) cs += M4[r][k] * Rt[r * 3 + k];
    }
    const double ang = std::atan2(0.5 * std::sqrt(v0 * v0 + v1 * v1 + v2 * v2), 0.5 * (cs - 1.0));
    return dp <= a.confirm_tol && ang <= a.confirm_tol;
}

// One block of L lanes. NM: the joint count where it is a compile-time constant (6, 7), else
// MAX_JOINTS with the count n given at run time.
template <int NM, int L>
struct Block {
    const Args &a;
    const int n_rt, rows;
    // the joint count: a compile-time constant where NM is the count (the loops over joints unroll)
    static constexpr bool FIXED = NM <= 7;
    const bool paper, rotvec;
    const double gtol_run;

    // the lanes' copies of their arms' numbers (gathered when a lane takes a target)
    alignas(64) double Rf[NM + 1][9][L], tf[NM + 1][3][L], off[NM][L], clo[NM][L], chi[NM][L];
    alignas(64) double Rt[9][L], pt[3][L];
    // the iteration's state
    alignas(64) double q[NM][L], qt[NM][L], qs[NM][L], dq[NM][L];
    alignas(64) double R[9][L], p[3][L], w[NM][3][L], o[NM][3][L];
    alignas(64) double e[6][L], en[6][L], J[6][NM][L], A[NM][NM][L], g[NM][L], H[NM][NM + 1][L];
    alignas(64) double nn[L], better[L], held[NM][L], lam2[L], solving[L];
    alignas(64) double rlo[NM][L], rhi[NM][L];  // the bounds of the lane's run: clo/chi, or +-inf in a free run
    alignas(64) double g2[L], trA[L], stuck[L];
    int8_t kind[NM + 1][L];
    int8_t ukind[NM + 1];  // the kind shared by every lane, or 2 (the full product) where they differ
    bool kinds_dirty = true;  // ukind to be recomputed: the lanes' targets changed

    // per lane, decided lane by lane
    int64_t tgt[L], arm[L], s[L], ntry[L], total[L], it[L], rej[L];
    double lam[L], na[L], best[L];
    int pss[L], passes[L];
    int64_t active[L], start[L], touched[L];  // 0 or 1 (int64: read as vector masks)
    bool limited_run[L], limited[L];

    Block(const Args &args)
        : a(args), n_rt((int)args.n), rows(args.mode == MODE_POSITION ? 3 : 6),
          paper(args.mode == MODE_PAPER), rotvec(args.mode != MODE_PAPER), gtol_run(args.mode == MODE_PAPER ? 0.0 : args.gtol) {
        // idle lanes compute on harmless numbers
        std::memset(Rf, 0, sizeof(Rf));
        std::memset(tf, 0, sizeof(tf));
        std::memset(off, 0, sizeof(off));
        std::memset(Rt, 0, sizeof(Rt));
        std::memset(pt, 0, sizeof(pt));
        std::memset(q, 0, sizeof(q));
        std::memset(qt, 0, sizeof(qt));
        std::memset(qs, 0, sizeof(qs));
        std::memset(kind, 0, sizeof(kind));
        std::memset(held, 0, sizeof(held));
        for (int j = 0; j < NM; ++j)
            for (int l = 0; l < L; ++l) { clo[j][l] = rlo[j][l] = -INF; chi[j][l] = rhi[j][l] = INF; }
        for (int l = 0; l < L; ++l) {
            for (int k = 0; k <= NM; ++k) { Rf[k][0][l] = Rf[k][4][l] = Rf[k][8][l] = 1.0; }
            Rt[0][l] = Rt[4][l] = Rt[8][l] = 1.0;
            active[l] = false;
            start[l] = false;
            lam[l] = 1.0;
            lam2[l] = 1.0;
            solving[l] = 0.0;
        }
    }

    // ------------------------------------------------------------------ lane by lane
    bool take_target(int l) {
        const int n = FIXED ? NM : n_rt;
        kinds_dirty = true;
        const int64_t i = __atomic_fetch_add(a.counter, 1, __ATOMIC_RELAXED);
        if (i >= a.M) {
            active[l] = false;
            return false;
        }
        active[l] = true;
        tgt[l] = i;
        const int64_t b = a.arm[i];
        arm[l] = b;
        for (int k = 0; k <= n; ++k) {
            for (int m = 0; m < 9; ++m) Rf[k][m][l] = a.Rf[(b * (n + 1) + k) * 9 + m];
            for (int m = 0; m < 3; ++m) tf[k][m][l] = a.tf[(b * (n + 1) + k) * 3 + m];
            kind[k][l] = a.rkind[b * (n + 1) + k];
        }
        for (int j = 0; j < n; ++j) {
            off[j][l] = a.off[b * n + j];
            clo[j][l] = a.clo[b * n + j];
            chi[j][l] = a.chi[b * n + j];
        }
        for (int m = 0; m < 9; ++m) Rt[m][l] = a.Rt[i * 9 + m];
        for (int m = 0; m < 3; ++m) pt[m][l] = a.pt[i * 3 + m];
        limited[l] = a.limited[b];
        total[l] = 0;
        best[l] = INF;
        s[l] = 0;
        if (paper) {
            ntry[l] = 1;
            for (int j = 0; j < n; ++j) q[j][l] = a.qexp[(i * a.S) * n + j];
            begin_run(l, false);
            return true;
        }
        const int64_t extra = a.k_last - a.k_first;
        ntry[l] = a.nexp[i] + (extra > 0 ? extra : 0);
        if (ntry[l] == 0) {
            finish(l, false);
            return take_target(l);
        }
        begin_start(l);
        return true;
    }

    void begin_start(int l) {
        const int n = FIXED ? NM : n_rt;
        const int64_t i = tgt[l], b = arm[l], k = s[l];
        if (k < a.nexp[i]) {
            for (int j = 0; j < n; ++j) qs[j][l] = a.qexp[(i * a.S + k) * n + j];
        } else {
            const uint64_t key = a.keys[i], kk = (uint64_t)(a.k_first + k - a.nexp[i]);
            for (int j = 0; j < n; ++j) {
                const uint64_t ctr = mix(kk * (uint64_t)(1 << 16) + (uint64_t)(j + 1));
                const uint64_t bits = mix(key + ctr);
                const double u = (double)(bits >> 11) * (1.0 / 9007199254740992.0);
                qs[j][l] = a.blo[b * n + j] + u * (a.bhi[b * n + j] - a.blo[b * n + j]);
            }
        }
        passes[l] = (limited[l] && a.free_pass) ? 2 : 1;
        pss[l] = 0;
        for (int j = 0; j < n; ++j) q[j][l] = qs[j][l];
        begin_run(l, limited[l]);
    }

    // a new LM run from q: its first evaluation is the start
    void begin_run(int l, bool lim) {
        const int n = FIXED ? NM : n_rt;
        limited_run[l] = lim;
        for (int j = 0; j < n; ++j) {
            qt[j][l] = q[j][l];
            rlo[j][l] = lim ? clo[j][l] : -INF;
            rhi[j][l] = lim ? chi[j][l] : INF;
        }
        lam[l] = a.lam0;
        rej[l] = 0;
        it[l] = 0;
        na[l] = INF;
        start[l] = true;
        touched[l] = false;
    }

    void finish(int l, bool found) {
        const int n = FIXED ? NM : n_rt;
        const int64_t i = tgt[l];
        a.ok[i] = found;
        a.iterations[i] = total[l];
        if (!found) {
            a.residual[i] = best[l];
            a.start[i] = -1;
        }
    }

    void end_run(int l, int code) {
        const int n = FIXED ? NM : n_rt;
        const int64_t i = tgt[l], b = arm[l];
        if (paper) {
            int64_t its;
            if (code == AT_START) its = a.ilimit < 1 ? a.ilimit : 1;
            else if (code == SUCCESS) its = std::min<int64_t>(it[l] + 1, a.ilimit);
            else if (code == REJECTIONS) its = it[l];
            else if (code == STAGNATED) its = std::min<int64_t>(it[l] + 1 + (a.rlimit - rej[l]), a.ilimit);
            else its = a.ilimit;
            for (int j = 0; j < n; ++j) a.q[i * n + j] = q[j][l];
            const bool ok = code == SUCCESS || code == AT_START;
            a.ok[i] = ok;
            a.iterations[i] = its;
            a.residual[i] = na[l];
            a.start[i] = ok ? 0 : -1;
            take_target(l);
            return;
        }
        total[l] += it[l];
        double qv[MAX_JOINTS];
        for (int j = 0; j < n; ++j) {
            double v = project1(q[j][l], a.lo[b * n + j], a.hi[b * n + j], !a.pris[j]);
            if (a.unlimited[b * n + j]) v = npmod(v + PI, TWO_PI) - PI;
            qv[j] = v;
            q[j][l] = v;
        }
        const bool conv = code == SUCCESS || code == AT_START;
        if (pss[l] == 0 && na[l] < best[l]) {
            best[l] = na[l];
            for (int j = 0; j < n; ++j) a.q[i * n + j] = qv[j];
        }
        if (conv && confirm(a, qv, b, a.Rt + i * 9, a.pt + i * 3, rows)) {
            for (int j = 0; j < n; ++j) a.q[i * n + j] = qv[j];
            a.residual[i] = na[l];
            a.start[i] = s[l];
            finish(l, true);
            take_target(l);
            return;
        }
        if (touched[l] && pss[l] + 1 < passes[l]) {
            pss[l] += 1;  // the free run from the same start
            for (int j = 0; j < n; ++j) q[j][l] = qs[j][l];
            begin_run(l, false);
            return;
        }
        s[l] += 1;
        if (s[l] < ntry[l]) {
            begin_start(l);
            return;
        }
        finish(l, false);
        take_target(l);
    }

    // ------------------------------------------------------------------ every lane at once
    void fk() {
        const int n = FIXED ? NM : n_rt;
        for (int m = 0; m < 9; ++m) LANES_LOOP R[m][l] = Rf[0][m][l];
        for (int r = 0; r < 3; ++r) LANES_LOOP p[r][l] = tf[0][r][l];
        for (int i = 0; i < n; ++i) {
            const double a0 = a.axes[3 * i], a1 = a.axes[3 * i + 1], a2 = a.axes[3 * i + 2];
            const bool zi = a.zax[i];
            for (int r = 0; r < 3; ++r) {
                LANES_LOOP o[i][r][l] = p[r][l];
                if (zi) LANES_LOOP w[i][r][l] = R[3 * r + 2][l] * a2;
                else LANES_LOOP w[i][r][l] = R[3 * r][l] * a0 + R[3 * r + 1][l] * a1 + R[3 * r + 2][l] * a2;
            }
            if (a.pris[i]) {
                for (int r = 0; r < 3; ++r) LANES_LOOP p[r][l] = p[r][l] + w[i][r][l] * (qt[i][l] + off[i][l]);
            } else if (zi) {
                LANES_LOOP {
                    double si, ci;
                    sincos_poly(qt[i][l] + off[i][l], si, ci);
                    si = si * a2;
                    for (int r = 0; r < 3; ++r) {
                        const double r0 = R[3 * r][l] * ci + R[3 * r + 1][l] * si;
                        const double r1 = R[3 * r + 1][l] * ci - R[3 * r][l] * si;
                        R[3 * r][l] = r0;
                        R[3 * r + 1][l] = r1;
                    }
                }
            } else {
                const double K[3][3] = {{0.0, -a2, a1}, {a2, 0.0, -a0}, {-a1, a0, 0.0}};
                double K2[3][3];
                for (int r = 0; r < 3; ++r)
                    for (int m = 0; m < 3; ++m) K2[r][m] = K[r][0] * K[0][m] + K[r][1] * K[1][m] + K[r][2] * K[2][m];
                LANES_LOOP {
                    double sv, cv;
                    sincos_poly(qt[i][l] + off[i][l], sv, cv);
                    double T[3][3];
                    for (int r = 0; r < 3; ++r)
                        for (int m = 0; m < 3; ++m) T[r][m] = (r == m ? 1.0 : 0.0) + K[r][m] * sv + K2[r][m] * (1.0 - cv);
                    for (int r = 0; r < 3; ++r) {
                        const double v0 = R[3 * r][l] * T[0][0] + R[3 * r + 1][l] * T[1][0] + R[3 * r + 2][l] * T[2][0];
                        const double v1 = R[3 * r][l] * T[0][1] + R[3 * r + 1][l] * T[1][1] + R[3 * r + 2][l] * T[2][1];
                        const double v2 = R[3 * r][l] * T[0][2] + R[3 * r + 1][l] * T[1][2] + R[3 * r + 2][l] * T[2][2];
                        R[3 * r][l] = v0;
                        R[3 * r + 1][l] = v1;
                        R[3 * r + 2][l] = v2;
                    }
                }
            }
            for (int r = 0; r < 3; ++r)
                LANES_LOOP p[r][l] = p[r][l] + (R[3 * r][l] * tf[i + 1][0][l] + R[3 * r + 1][l] * tf[i + 1][1][l] + R[3 * r + 2][l] * tf[i + 1][2][l]);
            const int k = ukind[i + 1];
            if (k == 1) {
                for (int r = 0; r < 3; ++r) {
                    LANES_LOOP {
                        const double v1 = R[3 * r + 1][l] * Rf[i + 1][4][l] + R[3 * r + 2][l] * Rf[i + 1][7][l];
                        const double v2 = R[3 * r + 1][l] * Rf[i + 1][5][l] + R[3 * r + 2][l] * Rf[i + 1][8][l];
                        R[3 * r + 1][l] = v1;
                        R[3 * r + 2][l] = v2;
                    }
                }
            } else if (k == 2) {
                for (int r = 0; r < 3; ++r) {
                    LANES_LOOP {
                        const double v0 = R[3 * r][l] * Rf[i + 1][0][l] + R[3 * r + 1][l] * Rf[i + 1][3][l] + R[3 * r + 2][l] * Rf[i + 1][6][l];
                        const double v1 = R[3 * r][l] * Rf[i + 1][1][l] + R[3 * r + 1][l] * Rf[i + 1][4][l] + R[3 * r + 2][l] * Rf[i + 1][7][l];
                        const double v2 = R[3 * r][l] * Rf[i + 1][2][l] + R[3 * r + 1][l] * Rf[i + 1][5][l] + R[3 * r + 2][l] * Rf[i + 1][8][l];
                        R[3 * r][l] = v0;
                        R[3 * r + 1][l] = v1;
                        R[3 * r + 2][l] = v2;
                    }
                }
            }
        }
    }

    // a lane with an angle beyond the polynomials' range (|x| >= 1e5, or NaN; the LM bounds keep
    // every joint within a few turns, so in practice never): its whole chain again, sines and
    // cosines from libm, as lm_compiled._sincos does for such an angle
    void fix_huge_angles() {
        if (any_huge()) fix_huge_lanes();
    }

    bool any_huge() const {
        const int n = FIXED ? NM : n_rt;
        int anyv = 0;
        for (int i = 0; i < n; ++i)
            if (!a.pris[i]) LANES_ANY anyv |= !(std::fabs(qt[i][l] + off[i][l]) < 1e5);
        return anyv;
    }

    void fix_huge_lanes() {
        const int n = FIXED ? NM : n_rt;
        for (int l = 0; l < L; ++l) {
            bool huge = false;
            for (int i = 0; i < n; ++i) huge = huge || (!a.pris[i] && !(std::fabs(qt[i][l] + off[i][l]) < 1e5));
            if (huge) redo_lane_libm(l);
        }
    }

    void redo_lane_libm(int l) {
        const int n = FIXED ? NM : n_rt;
        // the chain of lane l from the start, every sine and cosine from libm
        double Rl[9], pl[3];
        for (int m = 0; m < 9; ++m) Rl[m] = Rf[0][m][l];
        for (int r = 0; r < 3; ++r) pl[r] = tf[0][r][l];
        for (int i = 0; i < n; ++i) {
            const double a0 = a.axes[3 * i], a1 = a.axes[3 * i + 1], a2 = a.axes[3 * i + 2];
            const double x = qt[i][l] + off[i][l];
            for (int r = 0; r < 3; ++r) {
                o[i][r][l] = pl[r];
                w[i][r][l] = a.zax[i] ? Rl[3 * r + 2] * a2 : Rl[3 * r] * a0 + Rl[3 * r + 1] * a1 + Rl[3 * r + 2] * a2;
            }
            if (a.pris[i]) {
                for (int r = 0; r < 3; ++r) pl[r] += w[i][r][l] * x;
            } else {
                const double sv = std::sin(x), cv = std::cos(x);
                const double K[3][3] = {{0.0, -a2, a1}, {a2, 0.0, -a0}, {-a1, a0, 0.0}};
                double T[3][3];
                for (int r = 0; r < 3; ++r)
                    for (int m = 0; m < 3; ++m) {
                        const double k2 = K[r][0] * K[0][m] + K[r][1] * K[1][m] + K[r][2] * K[2][m];
                        T[r][m] = (r == m ? 1.0 : 0.0) + K[r][m] * sv + k2 * (1.0 - cv);
                    }
                double Rn[9];
                for (int r = 0; r < 3; ++r)
                    for (int m = 0; m < 3; ++m) Rn[3 * r + m] = Rl[3 * r] * T[0][m] + Rl[3 * r + 1] * T[1][m] + Rl[3 * r + 2] * T[2][m];
                std::memcpy(Rl, Rn, sizeof(Rl));
            }
            for (int r = 0; r < 3; ++r)
                pl[r] += Rl[3 * r] * tf[i + 1][0][l] + Rl[3 * r + 1] * tf[i + 1][1][l] + Rl[3 * r + 2] * tf[i + 1][2][l];
            double Rn[9];
            for (int r = 0; r < 3; ++r)
                for (int m = 0; m < 3; ++m)
                    Rn[3 * r + m] = Rl[3 * r] * Rf[i + 1][m][l] + Rl[3 * r + 1] * Rf[i + 1][3 + m][l] + Rl[3 * r + 2] * Rf[i + 1][6 + m][l];
            std::memcpy(Rl, Rn, sizeof(Rl));
        }
        for (int m = 0; m < 9; ++m) R[m][l] = Rl[m];
        for (int r = 0; r < 3; ++r) p[r][l] = pl[r];
    }

    // nn[l] = |e| of the trial; en[.][l] the error (lm_compiled._pose_error)
    void pose_error() {
        const int n = FIXED ? NM : n_rt;
        for (int r = 0; r < 3; ++r) LANES_LOOP en[r][l] = pt[r][l] - p[r][l];
        if (rows == 3) {
            LANES_LOOP {
                en[3][l] = 0.0; en[4][l] = 0.0; en[5][l] = 0.0;
                nn[l] = std::sqrt(en[0][l] * en[0][l] + en[1][l] * en[1][l] + en[2][l] * en[2][l]);
            }
            return;
        }
        for (int r = 0; r < 3; ++r) {
            const int x = (r + 1) % 3, y = (r + 2) % 3;
            LANES_LOOP {
                double acc = R[3 * x][l] * Rt[3 * y][l] - R[3 * y][l] * Rt[3 * x][l];
                acc = acc + (R[3 * x + 1][l] * Rt[3 * y + 1][l] - R[3 * y + 1][l] * Rt[3 * x + 1][l]);
                acc = acc + (R[3 * x + 2][l] * Rt[3 * y + 2][l] - R[3 * y + 2][l] * Rt[3 * x + 2][l]);
                en[3 + r][l] = 0.5 * acc;
            }
        }
        if (rotvec) {
            alignas(64) double sn[L], cs[L];
            LANES_LOOP {
                double tr = R[0][l] * Rt[0][l];
                for (int m = 1; m < 9; ++m) tr = tr + R[m][l] * Rt[m][l];
                sn[l] = std::sqrt(en[3][l] * en[3][l] + en[4][l] * en[4][l] + en[5][l] * en[5][l]);
                cs[l] = 0.5 * (tr - 1.0);
            }
            alignas(64) double th[L];
            LANES_LOOP th[l] = atan2_pos(sn[l], cs[l]);
            for (int l = 0; l < L; ++l) {
                const double theta = th[l];
                if (sn[l] > 1e-9) {
                    const double scale = theta / sn[l];
                    for (int r = 0; r < 3; ++r) en[3 + r][l] *= scale;
                } else if (cs[l] < 0.0) {
                    half_turn(l, theta);
                }
            }
        }
        LANES_LOOP {
            double sq = en[0][l] * en[0][l];
            for (int r = 1; r < 6; ++r) sq = sq + en[r][l] * en[r][l];
            nn[l] = std::sqrt(sq);
        }
    }

    // where better[l]: e ← en, and J, A = JᵀJ, g = Jᵀe of the trial (lm_compiled._normal_equations)
    void normal_equations() {
        const int n = FIXED ? NM : n_rt;
        for (int r = 0; r < 6; ++r) LANES_LOOP e[r][l] = better[l] != 0.0 ? en[r][l] : e[r][l];
        for (int j = 0; j < n; ++j) {
            if (a.pris[j]) {
                for (int r = 0; r < 3; ++r) LANES_LOOP { J[r][j][l] = w[j][r][l]; J[3 + r][j][l] = 0.0; }
            } else {
                LANES_LOOP {
                    const double d0 = p[0][l] - o[j][0][l], d1 = p[1][l] - o[j][1][l], d2 = p[2][l] - o[j][2][l];
                    J[0][j][l] = w[j][1][l] * d2 - w[j][2][l] * d1;
                    J[1][j][l] = w[j][2][l] * d0 - w[j][0][l] * d2;
                    J[2][j][l] = w[j][0][l] * d1 - w[j][1][l] * d0;
                    J[3][j][l] = w[j][0][l];
                    J[4][j][l] = w[j][1][l];
                    J[5][j][l] = w[j][2][l];
                }
            }
        }
        if (rows == 6) products<6>();
        else products<3>();
    }

    // A = JᵀJ (its upper triangle: A is symmetric) and g = Jᵀe over the first ROWS rows of J,
    // summed row after row as the scalar kernel does; kept where the trial was rejected
    template <int ROWS>
    void products() {
        const int n = FIXED ? NM : n_rt;
        for (int j = 0; j < n; ++j) {
            for (int m = j; m < n; ++m) {
                LANES_LOOP {
                    double sacc = J[0][j][l] * J[0][m][l];
                    for (int r = 1; r < ROWS; ++r) sacc = sacc + J[r][j][l] * J[r][m][l];
                    A[j][m][l] = better[l] != 0.0 ? sacc : A[j][m][l];
                }
            }
            LANES_LOOP {
                double sacc = J[0][j][l] * e[0][l];
                for (int r = 1; r < ROWS; ++r) sacc = sacc + J[r][j][l] * e[r][l];
                g[j][l] = better[l] != 0.0 ? sacc : g[j][l];
            }
        }
    }

    // dq ← (A + λ²I)⁻¹ g, held joints fixed (lm_compiled._solve): Gaussian elimination without
    // pivoting on the upper triangle alone (the trailing block stays symmetric; half the updates of
    // the scalar kernel's full elimination, the same answer to rounding)
    void solve(bool any_held) {
        const int n = FIXED ? NM : n_rt;
        for (int i = 0; i < n; ++i) {
            for (int k = i; k < n; ++k) LANES_LOOP H[i][k][l] = A[i][k][l];
            LANES_LOOP { H[i][n][l] = g[i][l]; H[i][i][l] = H[i][i][l] + lam2[l]; }
        }
        if (any_held) {
            for (int i = 0; i < n; ++i) {
                for (int k = i; k < n; ++k)
                    LANES_LOOP H[i][k][l] = ((held[i][l] != 0.0) | (held[k][l] != 0.0)) ? (i == k ? 1.0 : 0.0) : H[i][k][l];
                LANES_LOOP H[i][n][l] = held[i][l] != 0.0 ? 0.0 : H[i][n][l];
            }
        }
        alignas(64) double f[NM][L];
        for (int j = 0; j < n; ++j) {
            // column j below the pivot is row j right of it (symmetry), taken before row j is scaled
            for (int i = j + 1; i < n; ++i) LANES_LOOP f[i][l] = H[j][i][l];
            alignas(64) double inv[L];
            LANES_LOOP inv[l] = 1.0 / H[j][j][l];
            for (int k = j + 1; k <= n; ++k) LANES_LOOP H[j][k][l] = H[j][k][l] * inv[l];
            for (int i = j + 1; i < n; ++i)
                for (int k = i; k <= n; ++k) LANES_LOOP H[i][k][l] = H[i][k][l] - f[i][l] * H[j][k][l];
        }
        for (int i = 0; i < n; ++i) LANES_LOOP dq[i][l] = H[i][n][l];
        for (int j = n - 1; j > 0; --j)
            for (int i = 0; i < j; ++i) LANES_LOOP dq[i][l] = dq[i][l] - H[i][j][l] * dq[j][l];
    }

    // ------------------------------------------------------------------ register-blocked iteration
    // For a joint count known at compile time (6, 7): one iteration as straight-line code over
    // vectors of W lanes (GCC's vector extension: V is W doubles, one register), every loop over
    // joints and rows unrolled, so the pose, the Jacobian's columns and the elimination's matrix
    // stay in registers between the steps instead of going through the block's arrays. A block of
    // L > W lanes runs it on its parts of W lanes (lanes h .. h + W - 1)
    // one after the other. The arithmetic per lane is the same sequence as the lane-array
    // functions above (the MAX_JOINTS path), except where GCC fuses a multiply-add differently.
    static constexpr int W = L < NATIVE_LANES ? L : NATIVE_LANES;
    using V = typename VecOf<W>::T;
    using VM = typename VecOf<W>::M;
    static inline __attribute__((always_inline)) V ld(const double *x) {
        V v;
        std::memcpy(&v, x, sizeof(V));
        return v;
    }
    static inline __attribute__((always_inline)) void st(double *x, V v) { std::memcpy(x, &v, sizeof(V)); }
    static inline __attribute__((always_inline)) V bc(double x) { return V{} + x; }
    static inline __attribute__((always_inline)) VM ldm(const int64_t *x) {
        VM v;
        std::memcpy(&v, x, sizeof(VM));
        return v;
    }
    static inline __attribute__((always_inline)) void stm(int64_t *x, VM v) { std::memcpy(x, &v, sizeof(VM)); }
    static inline __attribute__((always_inline)) VM im(int64_t x) { return VM{} + x; }
    static inline __attribute__((always_inline)) V vsqrt(V x) {
        alignas(64) double t[W];
        st(t, x);
        _Pragma("omp simd") for (int l = 0; l < W; ++l) t[l] = std::sqrt(t[l]);
        return ld(t);
    }
    static inline __attribute__((always_inline)) V vabs(V x) { return (V)((VM)x & (VM{} + INT64_MAX)); }
    // spacing_fast on every lane
    static inline __attribute__((always_inline)) V vspacing(V x) {
        const VM e = ((VM)x & (VM{} + INT64_MAX)) >> 52;
        const VM out = (e > 52 ? e - 52 : VM{}) << 52;
        const V v = (V)out;
        return v > 0.0 ? v : bc(TINY);
    }
    static inline __attribute__((always_inline)) bool any(VM m) {
        alignas(64) int64_t t[W];
        std::memcpy(t, &m, sizeof(VM));
        int anyv = 0;
        _Pragma("omp simd reduction(|:anyv)") for (int l = 0; l < W; ++l) anyv |= t[l] != 0;
        return anyv;
    }

    // fk() into registers: Rr, pp the tool's pose; o, w (the joints' origins and axes) stored for
    // the Jacobian
    inline __attribute__((always_inline)) void fk_v(const int h, V (&Rr)[9], V (&pp)[3]) {
        // every joint's sine and cosine first: independent of each other and of the chain
        alignas(64) double sn[NM][L], cs[NM][L];
        UNROLL for (int i = 0; i < NM; ++i) {
            if (a.pris[i]) continue;
            PART_LOOP sincos_poly(qt[i][l] + off[i][l], sn[i][l], cs[i][l]);
        }
        UNROLL for (int m = 0; m < 9; ++m) Rr[m] = ld(Rf[0][m] + h);
        UNROLL for (int r = 0; r < 3; ++r) pp[r] = ld(tf[0][r] + h);
        UNROLL for (int i = 0; i < NM; ++i) {
            const double a0 = a.axes[3 * i], a1 = a.axes[3 * i + 1], a2 = a.axes[3 * i + 2];
            const bool zi = a.zax[i];
            V wv[3];
            UNROLL for (int r = 0; r < 3; ++r) {
                st(o[i][r] + h, pp[r]);
                wv[r] = zi ? Rr[3 * r + 2] * a2 : Rr[3 * r] * a0 + Rr[3 * r + 1] * a1 + Rr[3 * r + 2] * a2;
                st(w[i][r] + h, wv[r]);
            }
            if (a.pris[i]) {
                const V x = ld(qt[i] + h) + ld(off[i] + h);
                UNROLL for (int r = 0; r < 3; ++r) pp[r] = pp[r] + wv[r] * x;
            } else if (zi) {
                const V si = ld(sn[i] + h) * a2, ci = ld(cs[i] + h);
                UNROLL for (int r = 0; r < 3; ++r) {
                    const V r0 = Rr[3 * r] * ci + Rr[3 * r + 1] * si;
                    const V r1 = Rr[3 * r + 1] * ci - Rr[3 * r] * si;
                    Rr[3 * r] = r0;
                    Rr[3 * r + 1] = r1;
                }
            } else {
                const double K[3][3] = {{0.0, -a2, a1}, {a2, 0.0, -a0}, {-a1, a0, 0.0}};
                double K2[3][3];
                for (int r = 0; r < 3; ++r)
                    for (int m = 0; m < 3; ++m) K2[r][m] = K[r][0] * K[0][m] + K[r][1] * K[1][m] + K[r][2] * K[2][m];
                const V sv = ld(sn[i] + h), omc = 1.0 - ld(cs[i] + h);
                V T[3][3];
                UNROLL for (int r = 0; r < 3; ++r)
                    UNROLL for (int m = 0; m < 3; ++m) T[r][m] = (r == m ? 1.0 : 0.0) + K[r][m] * sv + K2[r][m] * omc;
                UNROLL for (int r = 0; r < 3; ++r) {
                    const V v0 = Rr[3 * r] * T[0][0] + Rr[3 * r + 1] * T[1][0] + Rr[3 * r + 2] * T[2][0];
                    const V v1 = Rr[3 * r] * T[0][1] + Rr[3 * r + 1] * T[1][1] + Rr[3 * r + 2] * T[2][1];
                    const V v2 = Rr[3 * r] * T[0][2] + Rr[3 * r + 1] * T[1][2] + Rr[3 * r + 2] * T[2][2];
                    Rr[3 * r] = v0;
                    Rr[3 * r + 1] = v1;
                    Rr[3 * r + 2] = v2;
                }
            }
            const V t0 = ld(tf[i + 1][0] + h), t1 = ld(tf[i + 1][1] + h), t2 = ld(tf[i + 1][2] + h);
            UNROLL for (int r = 0; r < 3; ++r) pp[r] = pp[r] + (Rr[3 * r] * t0 + Rr[3 * r + 1] * t1 + Rr[3 * r + 2] * t2);
            const int k = ukind[i + 1];
            if (k == 1) {
                const V f4 = ld(Rf[i + 1][4] + h), f5 = ld(Rf[i + 1][5] + h), f7 = ld(Rf[i + 1][7] + h), f8 = ld(Rf[i + 1][8] + h);
                UNROLL for (int r = 0; r < 3; ++r) {
                    const V v1 = Rr[3 * r + 1] * f4 + Rr[3 * r + 2] * f7;
                    const V v2 = Rr[3 * r + 1] * f5 + Rr[3 * r + 2] * f8;
                    Rr[3 * r + 1] = v1;
                    Rr[3 * r + 2] = v2;
                }
            } else if (k == 2) {
                V f[9];
                UNROLL for (int m = 0; m < 9; ++m) f[m] = ld(Rf[i + 1][m] + h);
                UNROLL for (int r = 0; r < 3; ++r) {
                    const V v0 = Rr[3 * r] * f[0] + Rr[3 * r + 1] * f[3] + Rr[3 * r + 2] * f[6];
                    const V v1 = Rr[3 * r] * f[1] + Rr[3 * r + 1] * f[4] + Rr[3 * r + 2] * f[7];
                    const V v2 = Rr[3 * r] * f[2] + Rr[3 * r + 1] * f[5] + Rr[3 * r + 2] * f[8];
                    Rr[3 * r] = v0;
                    Rr[3 * r + 1] = v1;
                    Rr[3 * r + 2] = v2;
                }
            }
        }
    }

    // pose_error() from the registers: en, nn of the trial
    inline __attribute__((always_inline)) void pose_error_v(const int h, V (&Rr)[9], V (&pp)[3]) {
        V env[6];
        UNROLL for (int r = 0; r < 3; ++r) env[r] = ld(pt[r] + h) - pp[r];
        if (rows == 3) {
            UNROLL for (int r = 0; r < 3; ++r) {
                st(en[r] + h, env[r]);
                st(en[3 + r] + h, V{});
            }
            st(nn + h, vsqrt(env[0] * env[0] + env[1] * env[1] + env[2] * env[2]));
            return;
        }
        V Rtv[9];
        UNROLL for (int m = 0; m < 9; ++m) Rtv[m] = ld(Rt[m] + h);
        UNROLL for (int r = 0; r < 3; ++r) {
            const int x = (r + 1) % 3, y = (r + 2) % 3;
            V acc = Rr[3 * x] * Rtv[3 * y] - Rr[3 * y] * Rtv[3 * x];
            acc = acc + (Rr[3 * x + 1] * Rtv[3 * y + 1] - Rr[3 * y + 1] * Rtv[3 * x + 1]);
            acc = acc + (Rr[3 * x + 2] * Rtv[3 * y + 2] - Rr[3 * y + 2] * Rtv[3 * x + 2]);
            env[3 + r] = 0.5 * acc;
        }
        if (rotvec) {
            V tr = Rr[0] * Rtv[0];
            UNROLL for (int m = 1; m < 9; ++m) tr = tr + Rr[m] * Rtv[m];
            const V snv = vsqrt(env[3] * env[3] + env[4] * env[4] + env[5] * env[5]);
            const V csv = 0.5 * (tr - 1.0);
            alignas(64) double sa[L], ca[L], th[L];
            st(sa + h, snv);
            st(ca + h, csv);
            PART_LOOP th[l] = atan2_pos(sa[l], ca[l]);
            const V thv = ld(th + h);
            const VM big = snv > 1e-9;
            const V scale = thv / snv;
            UNROLL for (int r = 0; r < 3; ++r) env[3 + r] = big ? env[3 + r] * scale : env[3 + r];
            const VM half = ~big & (csv < 0.0);
            if (__builtin_expect(any(half), 0)) {
                // about a half turn from the target: pose_error()'s axis from the largest diagonal
                // entry, lane by lane
                UNROLL for (int m = 0; m < 9; ++m) st(R[m] + h, Rr[m]);
                UNROLL for (int r = 0; r < 6; ++r) st(en[r] + h, env[r]);
                for (int l = h; l < h + W; ++l)
                    if (half[l - h]) half_turn(l, th[l]);
                UNROLL for (int r = 0; r < 6; ++r) env[r] = ld(en[r] + h);
            }
        }
        UNROLL for (int r = 0; r < 6; ++r) st(en[r] + h, env[r]);
        V sq = env[0] * env[0];
        UNROLL for (int r = 1; r < 6; ++r) sq = sq + env[r] * env[r];
        st(nn + h, vsqrt(sq));
    }

    // about a half turn from the target (the rotation error's sine below 1e-9, its cosine negative):
    // the error's axis from the largest diagonal entry of R·Rtᵀ + I, lane l alone
    void half_turn(int l, double theta) {
        int jmax = 0;
        double bestd = -INF;
        for (int j = 0; j < 3; ++j) {
            const double d = 0.5 * (Rt[3 * j][l] * R[3 * j][l] + Rt[3 * j + 1][l] * R[3 * j + 1][l] + Rt[3 * j + 2][l] * R[3 * j + 2][l] + 1.0);
            if (d > bestd) { bestd = d; jmax = j; }
        }
        const double den = std::sqrt(std::fmax(bestd, 1e-300));
        for (int r = 0; r < 3; ++r) {
            const double sij = 0.5 * (Rt[3 * r][l] * R[3 * jmax][l] + Rt[3 * r + 1][l] * R[3 * jmax + 1][l] +
                                      Rt[3 * r + 2][l] * R[3 * jmax + 2][l] + (r == jmax ? 1.0 : 0.0));
            en[3 + r][l] = sij / den * theta;
        }
    }

    // normal_equations() and products() in one pass over registers: where better, e ← en and
    // A = JᵀJ (upper triangle), g = Jᵀe of the trial's Jacobian (its columns never stored); then
    // g2 = |g|², trA = tr A
    template <int ROWS>
    inline __attribute__((always_inline)) void normal_equations_v(const int h, const V (&pp)[3]) {
        const VM bt = ld(better + h) != 0.0;
        V ev[6];
        UNROLL for (int r = 0; r < 6; ++r) {
            ev[r] = bt ? ld(en[r] + h) : ld(e[r] + h);
            st(e[r] + h, ev[r]);
        }
        V Jc[NM][ROWS];
        UNROLL for (int j = 0; j < NM; ++j) {
            const V w0 = ld(w[j][0] + h), w1 = ld(w[j][1] + h), w2 = ld(w[j][2] + h);
            if (a.pris[j]) {
                Jc[j][0] = w0, Jc[j][1] = w1, Jc[j][2] = w2;
                if constexpr (ROWS == 6) Jc[j][3] = Jc[j][4] = Jc[j][5] = V{};
            } else {
                const V d0 = pp[0] - ld(o[j][0] + h), d1 = pp[1] - ld(o[j][1] + h), d2 = pp[2] - ld(o[j][2] + h);
                Jc[j][0] = w1 * d2 - w2 * d1;
                Jc[j][1] = w2 * d0 - w0 * d2;
                Jc[j][2] = w0 * d1 - w1 * d0;
                if constexpr (ROWS == 6) Jc[j][3] = w0, Jc[j][4] = w1, Jc[j][5] = w2;
            }
        }
        V g2v{}, trv{};
        UNROLL for (int j = 0; j < NM; ++j) {
            UNROLL for (int m = j; m < NM; ++m) {
                V sacc = Jc[j][0] * Jc[m][0];
                UNROLL for (int r = 1; r < ROWS; ++r) sacc = sacc + Jc[j][r] * Jc[m][r];
                sacc = bt ? sacc : ld(A[j][m] + h);
                st(A[j][m] + h, sacc);
                if (m == j) trv = j == 0 ? sacc : trv + sacc;
            }
            V sacc = Jc[j][0] * ev[0];
            UNROLL for (int r = 1; r < ROWS; ++r) sacc = sacc + Jc[j][r] * ev[r];
            sacc = bt ? sacc : ld(g[j] + h);
            st(g[j] + h, sacc);
            g2v = j == 0 ? sacc * sacc : g2v + sacc * sacc;
        }
        st(g2 + h, g2v);
        st(trA + h, trv);
    }

    // stagnation() on vectors
    inline __attribute__((always_inline)) void stagnation_v(const int h) {
        const V lamv = ld(lam + h);
        const V mu = lamv * lamv;
        const V slack = (ld(trA + h) / mu + 64.0 * NM * EPS) * vsqrt(ld(g2 + h));
        const V lim = 0.125 * mu;
        VM ok = VM{} - 1;
        UNROLL for (int j = 0; j < NM; ++j) ok &= vabs(ld(g[j] + h)) + slack <= vspacing(ld(q[j] + h)) * lim;
        st(stuck + h, ok ? bc(1.0) : V{});
    }

    // solve() and the trial step on registers: dq ← (A + λ²I)⁻¹ g with the held joints fixed, then
    // qt ← q + dq where solving
    inline __attribute__((always_inline)) void solve_v(const int h, bool any_held, const VM (&hd)[NM], const VM sv) {
        V H[NM][NM + 1];
        const V lam2v = ld(lam2 + h);
        UNROLL for (int i = 0; i < NM; ++i) {
            UNROLL for (int k = i; k < NM; ++k) H[i][k] = ld(A[i][k] + h);
            H[i][NM] = ld(g[i] + h);
            H[i][i] = H[i][i] + lam2v;
        }
        if (any_held) {
            UNROLL for (int i = 0; i < NM; ++i) {
                UNROLL for (int k = i; k < NM; ++k) H[i][k] = (hd[i] | hd[k]) ? bc(i == k ? 1.0 : 0.0) : H[i][k];
                H[i][NM] = hd[i] ? V{} : H[i][NM];
            }
        }
        UNROLL for (int j = 0; j < NM; ++j) {
            V f[NM];
            UNROLL for (int i = j + 1; i < NM; ++i) f[i] = H[j][i];
            const V inv = 1.0 / H[j][j];
            UNROLL for (int k = j + 1; k <= NM; ++k) H[j][k] = H[j][k] * inv;
            UNROLL for (int i = j + 1; i < NM; ++i)
                UNROLL for (int k = i; k <= NM; ++k) H[i][k] = H[i][k] - f[i] * H[j][k];
        }
        V dqv[NM];
        UNROLL for (int i = 0; i < NM; ++i) dqv[i] = H[i][NM];
        UNROLL for (int j = NM - 1; j > 0; --j)
            UNROLL for (int i = 0; i < j; ++i) dqv[i] = dqv[i] - H[i][j] * dqv[j];
        UNROLL for (int j = 0; j < NM; ++j) st(qt[j] + h, sv ? ld(q[j] + h) + dqv[j] : ld(qt[j] + h));
    }

    // the trial's acceptance, λ, the counts and the stopping tests of every lane at once (run()'s
    // lane-by-lane tests as masks); lanes with a code end their run (lane by lane), the others
    // solve. Returns the mask of the lanes that solve.
    inline __attribute__((always_inline)) VM decide_v(const int h, const VM act, const VM stt, const VM bt) {
        const VM step = act & ~stt;
        const VM itv = ldm(it + h) - step;  // step is -1 where true
        V lamv = ld(lam + h);
        lamv = step ? (bt ? lamv * 0.5 : lamv * 2.0) : lamv;
        VM rj = ldm(rej + h);
        rj = step ? (bt ? VM{} : rj + 1) : rj;
        stm(it + h, itv);
        st(lam + h, lamv);
        stm(rej + h, rj);
        stagnation_v(h);
        const double tol = a.tol, gt = gtol_run;
        const int64_t ilimit = a.ilimit, rlimit = a.rlimit;
        const V nav = ld(na + h);
        const VM c_start = (nav <= tol) ? im(AT_START) : im(ilimit == 0 ? ILIMIT : 0);
        const VM stat = gt > 0.0 ? bt & (vsqrt(ld(g2 + h)) <= gt * vsqrt(ld(trA + h)) * nav) : VM{};
        const VM c_run = (bt & (nav <= tol)) ? im(SUCCESS)
                         : stat ? im(STATIONARY)
                         : (rj > rlimit) ? im(REJECTIONS)
                         : (itv >= ilimit) ? im(ILIMIT)
                         : ((rj > 0) & (ld(stuck + h) != 0.0)) ? im(STAGNATED) : VM{};
        const VM code = act ? (stt ? c_start : c_run) : VM{};
        const VM solv = act & (code == 0);
        st(solving + h, solv ? bc(1.0) : V{});
        st(lam2 + h, lamv * lamv);
        stm(start + h, VM{});
        if (any(code != 0)) {
            alignas(64) int64_t c[L];
            stm(c + h, code);
            for (int l = h; l < h + W; ++l)
                if (c[l]) end_run(l, (int)c[l]);  // a new run (start[l]) or target, or the lane goes idle
        }
        return solv;
    }

    // project_trials() with the lanes to project found by vector tests: a lane with a joint
    // outside its run's bounds (or NaN) is projected whatever its neighbours do
    inline __attribute__((always_inline)) void project_v(const int h) {
        VM notin{};
        UNROLL for (int j = 0; j < NM; ++j) {
            const V x = ld(qt[j] + h), lo = ld(rlo[j] + h), hi = ld(rhi[j] + h);
            notin |= ~((x >= lo) & (x <= hi));  // NaN too: project1 changes it
        }
        if (!any(notin)) return;
        const VM visit = notin & (ldm(active + h) != 0);
        alignas(64) int64_t vl[L];
        stm(vl + h, visit);
        for (int l = h; l < h + W; ++l) {
            if (!vl[l] || !limited_run[l]) continue;
            for (int j = 0; j < NM; ++j) {
                const double v = project1(qt[j][l], rlo[j][l], rhi[j][l], !a.pris[j]);
                if (v != qt[j][l]) touched[l] = true;
                qt[j][l] = v;
            }
        }
    }

    void iterate_fixed() {
        for (int h = 0; h < L; h += W) iterate_part(h);
    }

    // lanes h .. h + W - 1 (one copy of the code for every part: two would not fit the
    // instruction cache)
    __attribute__((noinline)) void iterate_part(const int h) {
        project_v(h);
        V Rr[9], pp[3];
        fk_v(h, Rr, pp);
        VM huge{};
        UNROLL for (int i = 0; i < NM; ++i)
            if (!a.pris[i]) huge |= ~(vabs(ld(qt[i] + h) + ld(off[i] + h)) < 1e5);
        if (__builtin_expect(any(huge), 0)) {
            UNROLL for (int m = 0; m < 9; ++m) st(R[m] + h, Rr[m]);
            UNROLL for (int r = 0; r < 3; ++r) st(p[r] + h, pp[r]);
            for (int l = h; l < h + W; ++l)
                if (huge[l - h]) redo_lane_libm(l);
            UNROLL for (int m = 0; m < 9; ++m) Rr[m] = ld(R[m] + h);
            UNROLL for (int r = 0; r < 3; ++r) pp[r] = ld(p[r] + h);
        }
        pose_error_v(h, Rr, pp);
        const VM act = ldm(active + h) != 0, stt = ldm(start + h) != 0;
        const V nnv = ld(nn + h), na0 = ld(na + h);
        const VM bt = act & (stt | (nnv < na0));
        st(better + h, bt ? bc(1.0) : V{});
        UNROLL for (int j = 0; j < NM; ++j) st(q[j] + h, bt ? ld(qt[j] + h) : ld(q[j] + h));
        st(na + h, bt ? nnv : na0);
        if (rows == 6) normal_equations_v<6>(h, pp);
        else normal_equations_v<3>(h, pp);
        const VM solv = decide_v(h, act, stt, bt);
        // a joint on a bound of its run that the gradient pushes outward is held for the step
        VM hd[NM], anyh{};
        UNROLL for (int j = 0; j < NM; ++j) {
            const V qj = ld(q[j] + h), gj = ld(g[j] + h);
            hd[j] = solv & (((qj <= ld(rlo[j] + h)) & (gj < 0.0)) | ((qj >= ld(rhi[j] + h)) & (gj > 0.0)));
            anyh |= hd[j];
        }
        const bool any_held = any(anyh);
        if (any_held) stm(touched + h, ldm(touched + h) | (anyh & 1));
        solve_v(h, any_held, hd, solv);
    }

    void shared_kinds() {
        const int n = FIXED ? NM : n_rt;
        for (int k = 0; k <= n; ++k) {
            int8_t u = -1;
            for (int l = 0; l < L; ++l) {
                if (!active[l]) continue;
                if (u < 0) u = kind[k][l];
                else if (u != kind[k][l]) u = 2;
            }
            ukind[k] = u < 0 ? 2 : u;
        }
    }

    // ------------------------------------------------------------------ the loop
    void run() {
        for (int l = 0; l < L; ++l) take_target(l);
        while (true) {
            bool any = false;
            for (int l = 0; l < L; ++l) any = any || active[l];
            if (!any) break;
            if (kinds_dirty) {  // a lane took a target (or none was left) since the last iteration
                shared_kinds();
                kinds_dirty = false;
            }
            if constexpr (FIXED) iterate_fixed();
            else iterate_arrays();
        }
    }

    // one iteration of every lane on the block's arrays (chains of other lengths than 6 and 7)
    void iterate_arrays() {
        const int n = FIXED ? NM : n_rt;
        project_trials();
        fk();
        fix_huge_angles();
        pose_error();
        LANES_LOOP better[l] = (active[l] && (start[l] || nn[l] < na[l])) ? 1.0 : 0.0;
        for (int j = 0; j < n; ++j) LANES_LOOP q[j][l] = better[l] != 0.0 ? qt[j][l] : q[j][l];
        LANES_LOOP na[l] = better[l] != 0.0 ? nn[l] : na[l];
        normal_equations();
        LANES_LOOP { g2[l] = g[0][l] * g[0][l]; trA[l] = A[0][0][l]; }
        for (int j = 1; j < n; ++j) LANES_LOOP { g2[l] = g2[l] + g[j][l] * g[j][l]; trA[l] = trA[l] + A[j][j][l]; }
        // an accepted step halves λ, a rejected one doubles it (the start's evaluation is no step)
        LANES_LOOP {
            const bool step = active[l] & !start[l];
            const bool bt = better[l] != 0.0;
            it[l] += step ? 1 : 0;
            lam[l] = step ? (bt ? lam[l] * 0.5 : lam[l] * 2.0) : lam[l];
            rej[l] = step ? (bt ? 0 : rej[l] + 1) : rej[l];
        }
        stagnation();
        for (int l = 0; l < L; ++l) {
            solving[l] = 0.0;
            if (!active[l]) continue;
            int code = 0;
            const bool bt = better[l] != 0.0;
            if (start[l]) {
                start[l] = false;
                if (na[l] <= a.tol) code = AT_START;
                else if (a.ilimit == 0) code = ILIMIT;
            } else {
                if (bt && na[l] <= a.tol) code = SUCCESS;
                else if (bt && gtol_run > 0.0 && std::sqrt(g2[l]) <= gtol_run * std::sqrt(trA[l]) * na[l]) code = STATIONARY;
                else if (rej[l] > a.rlimit) code = REJECTIONS;
                else if (it[l] >= a.ilimit) code = ILIMIT;
                else if (rej[l] > 0 && stuck[l] != 0.0) code = STAGNATED;
            }
            if (code) {
                end_run(l, code);  // a new run (start[l]) or target, or the lane goes idle
                continue;
            }
            solving[l] = 1.0;
            lam2[l] = lam[l] * lam[l];
        }
        // a joint on a bound of its run that the gradient pushes outward is held for the step
        bool any_held = false;
        for (int j = 0; j < n; ++j) {
            LANES_LOOP held[j][l] = ((solving[l] != 0.0) & (((q[j][l] <= rlo[j][l]) & (g[j][l] < 0.0)) |
                                                           ((q[j][l] >= rhi[j][l]) & (g[j][l] > 0.0)))) ? 1.0 : 0.0;
            int anyv = 0;
            LANES_ANY anyv |= held[j][l] != 0.0;
            any_held = any_held || anyv;
        }
        if (any_held)
            for (int j = 0; j < n; ++j)
                for (int l = 0; l < L; ++l) touched[l] = touched[l] || held[j][l] != 0.0;
        solve(any_held);
        for (int j = 0; j < n; ++j) LANES_LOOP qt[j][l] = solving[l] != 0.0 ? q[j][l] + dq[j][l] : qt[j][l];
    }

    // the start and every trial step into the bounds of its run; a lane whose step they change is
    // "touched" (its free run may find what the bounds hid)
    void project_trials() {
        const int n = FIXED ? NM : n_rt;
        int anyv = 0;
        for (int j = 0; j < n; ++j) LANES_ANY anyv |= (qt[j][l] < rlo[j][l]) | (qt[j][l] > rhi[j][l]);
        if (!anyv) return;
        for (int l = 0; l < L; ++l) {
            if (!active[l] || !limited_run[l]) continue;
            for (int j = 0; j < n; ++j) {
                const double v = project1(qt[j][l], rlo[j][l], rhi[j][l], !a.pris[j]);
                if (v != qt[j][l]) touched[l] = true;
                qt[j][l] = v;
            }
        }
    }

    // exact stagnation (lm_compiled._lm): with μ = λ², every component of the next step obeys
    // |dq_j| <= (|g_j| + (tr A / μ)·|g|) / μ plus the solve's rounding, which only shrinks as λ
    // doubles; below an eighth of the spacing at q_j for every joint, q + dq rounds back to q now
    // and at every later trial. stuck[l] for every lane at once (tested where a step was rejected),
    // the comparison multiplied through by μ > 0
    void stagnation() {
        const int n = FIXED ? NM : n_rt;
        LANES_LOOP stuck[l] = 1.0;
        for (int j = 0; j < n; ++j) {
            LANES_LOOP {
                const double mu = lam[l] * lam[l];
                const double slack = (trA[l] / mu + 64.0 * n * EPS) * std::sqrt(g2[l]);
                stuck[l] = (std::fabs(g[j][l]) + slack <= 0.125 * spacing_fast(q[j][l]) * mu) ? stuck[l] : 0.0;
            }
        }
    }
};

template <int NM, int L>
void run_block(const Args &a) {
    // on the heap: a block of a 16-joint arm is ~100 kB
    auto *blk = new Block<NM, L>(a);
    blk->run();
    delete blk;
}

void run(const Args &a, int lanes);
void atan2_array(const double *y, const double *x, double *out, int64_t count);

}  // namespace WSMAP_ISA
}  // namespace wsmap_lanes
#endif

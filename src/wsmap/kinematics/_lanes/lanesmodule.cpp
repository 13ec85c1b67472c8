// wsmap.kinematics._lanes: the lane kernel (lanes.hpp) for Python, through nanobind. The build for
// the widest instruction set this CPU has is chosen at import; every call releases the GIL, so
// several threads run it at once, taking targets from one shared counter.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>

#include <cstring>
#include <stdexcept>
#include <string>

#include "lanes.hpp"

namespace nb = nanobind;
namespace wl = wsmap_lanes;

namespace wsmap_lanes {
namespace base { void run(const Args &, int); void atan2_array(const double *, const double *, double *, int64_t); }
#ifdef WSMAP_HAVE_X86
namespace avx2 { void run(const Args &, int); void atan2_array(const double *, const double *, double *, int64_t); }
namespace avx512 { void run(const Args &, int); void atan2_array(const double *, const double *, double *, int64_t); }
#endif
}  // namespace wsmap_lanes

template <class T>
using In = nb::ndarray<const T, nb::c_contig, nb::device::cpu>;
template <class T>
using Out = nb::ndarray<T, nb::c_contig, nb::device::cpu>;

using RunFn = void (*)(const wl::Args &, int);

static std::string best_isa() {
#ifdef WSMAP_HAVE_X86
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl"))
        return "avx512";
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return "avx2";
#endif
    return "base";
}

using Atan2Fn = void (*)(const double *, const double *, double *, int64_t);

// the build `isa` names ("auto": the widest this CPU runs): 0 base, 1 avx2, 2 avx512
static int isa_index(const std::string &isa) {
    const std::string best = best_isa();
    const std::string want = isa == "auto" ? best : isa;
    if (want == "base") return 0;
    if (want != "avx2" && want != "avx512")
        throw std::invalid_argument("isa must be 'auto', 'avx512', 'avx2' or 'base', not '" + isa + "'");
    if ((want == "avx2" && best == "base") || (want == "avx512" && best != "avx512"))
        throw std::invalid_argument("this CPU cannot run the " + want + " build (it has " + best + ")");
    return want == "avx2" ? 1 : 2;
}

// the entry points of the build `isa` names
struct Build {
    RunFn run;
    Atan2Fn atan2;
};

static Build build(const std::string &isa) {
    const int k = isa_index(isa);
#ifdef WSMAP_HAVE_X86
    if (k == 1) return {wl::avx2::run, wl::avx2::atan2_array};
    if (k == 2) return {wl::avx512::run, wl::avx512::atan2_array};
#endif
    (void)k;
    return {wl::base::run, wl::base::atan2_array};
}

static void atan2_lanes(In<double> y, In<double> x, Out<double> out, const std::string &isa) {
    if (y.size() != x.size() || out.size() != x.size()) throw std::invalid_argument("y, x and out must have one size");
    build(isa).atan2(y.data(), x.data(), out.data(), (int64_t)x.size());
}

template <class A>
static void need(const A &arr, size_t size, const char *name) {
    if (arr.size() != size)
        throw std::invalid_argument(std::string(name) + " has " + std::to_string(arr.size()) + " elements, not " + std::to_string(size));
}

static void run_targets(int mode, In<int64_t> arm, In<double> Rt, In<double> pt, In<uint64_t> keys, In<double> qexp,
                        In<int64_t> nexp, int64_t k_first, int64_t k_last, In<double> Rf, In<double> tf, In<int8_t> rkind,
                        In<double> off, In<double> axes, In<bool> pris, In<bool> zax, In<double> lo, In<double> hi,
                        In<double> clo, In<double> chi, In<bool> clipped, In<bool> limited_arm, In<bool> unlimited,
                        In<double> blo, In<double> bhi, int64_t ilimit, int64_t rlimit, double tol, double lam0, double gtol,
                        double confirm_tol, bool free_pass, Out<double> q_out, Out<bool> ok_out, Out<int64_t> it_out,
                        Out<double> res_out, Out<int64_t> start_out, Out<int64_t> counter, int lanes, const std::string &isa) {
    if (mode < 0 || mode > 2) throw std::invalid_argument("mode must be 0, 1 or 2");
    if (axes.ndim() != 2 || axes.shape(1) != 3) throw std::invalid_argument("axes must be (n, 3)");
    if (qexp.ndim() != 3) throw std::invalid_argument("qexp must be (M, S, n)");
    const size_t M = arm.size(), n = axes.shape(0), B = limited_arm.size(), S = qexp.shape(1);
    if (n < 1 || n > (size_t)wl::MAX_JOINTS) throw std::invalid_argument("the lane kernel takes 1 to 16 joints");
    need(Rt, 9 * M, "Rt"); need(pt, 3 * M, "pt"); need(keys, M, "keys"); need(qexp, M * S * n, "qexp"); need(nexp, M, "nexp");
    need(Rf, B * (n + 1) * 9, "Rf"); need(tf, B * (n + 1) * 3, "tf"); need(rkind, B * (n + 1), "rkind");
    for (auto *x : {&off, &lo, &hi, &clo, &chi, &blo, &bhi}) need(*x, B * n, "a per-arm joint array");
    need(clipped, B * n, "clipped"); need(unlimited, B * n, "unlimited"); need(pris, n, "pris"); need(zax, n, "zax");
    need(q_out, M * n, "q_out"); need(ok_out, M, "ok_out"); need(it_out, M, "it_out"); need(res_out, M, "res_out");
    need(start_out, M, "start_out"); need(counter, 1, "counter");
    for (size_t i = 0; i < M; ++i) {
        if (arm.data()[i] < 0 || (size_t)arm.data()[i] >= B) throw std::invalid_argument("arm index out of range");
        if (nexp.data()[i] < 0 || (size_t)nexp.data()[i] > S) throw std::invalid_argument("nexp out of range");
    }
    RunFn fn = build(isa).run;
    if (lanes != 4 && lanes != 8 && lanes != 16) throw std::invalid_argument("lanes must be 4, 8 or 16");
    wl::Args a{mode, (int64_t)M, (int64_t)B, (int64_t)n, (int64_t)S, arm.data(), Rt.data(), pt.data(), keys.data(),
               qexp.data(), nexp.data(), k_first, k_last, Rf.data(), tf.data(), rkind.data(), off.data(), axes.data(),
               pris.data(), zax.data(), lo.data(), hi.data(), clo.data(), chi.data(), clipped.data(), limited_arm.data(),
               unlimited.data(), blo.data(), bhi.data(), ilimit, rlimit, tol, lam0, gtol, confirm_tol, free_pass,
               q_out.data(), ok_out.data(), it_out.data(), res_out.data(), start_out.data(), counter.data()};
    nb::gil_scoped_release release;
    fn(a, lanes);
}

NB_MODULE(_lanes, m) {
    m.doc() = "The lane (SIMD) build of the LM search of wsmap.kinematics.lm_compiled; see wsmap.kinematics.lm_lanes.";
    m.def("run_targets", &run_targets,
          "lm_compiled.run_targets's arguments, then counter (1,) int64 (the next target, shared by the "
          "threads of one call), lanes (4, 8 or 16) and isa ('auto', 'avx512', 'avx2', 'base').");
    m.def("atan2", &atan2_lanes, "out <- atan2(y, x) for y >= 0 as the lanes compute it (tests): y, x, out, isa.");
    m.def("best_isa", &best_isa, "The widest instruction set this CPU has that a build exists for.");
    m.attr("MAX_JOINTS") = wl::MAX_JOINTS;
}

// wsmap.kinematics._lanes: the lane kernel (lanes.hpp) for Python, through nanobind. The build for
// the widest instruction set this CPU has is chosen at import. A call takes one object, an
// lm_compiled.KernelCall, whose fields it reads by the names of lanes.hpp's tables, releases the
// GIL once and runs `threads` blocks of lanes, on this thread and threads - 1 std::threads of its
// own, every block taking targets from one shared counter: no Python between the threads.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>

#include <cstring>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>

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
using Arr = nb::ndarray<T, nb::c_contig, nb::device::cpu>;
template <class T>
using In = Arr<const T>;
template <class T>
using Out = Arr<T>;

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

// the numpy names of the C types of the tables (for the error messages)
template <class T>
static const char *dtype_name() {
    using U = std::remove_const_t<T>;
    if (std::is_same_v<U, double>) return "float64";
    if (std::is_same_v<U, bool>) return "bool";
    if (std::is_same_v<U, int8_t>) return "int8";
    if (std::is_same_v<U, uint64_t>) return "uint64";
    return "int64";
}

// field `group.name` of the call as an array of T, read as it is (no copy: the kernel writes into
// the out arrays)
template <class T>
static Arr<T> array_field(nb::handle call, const char *group, const char *name) {
    Arr<T> arr;
    if (!nb::try_cast(nb::getattr(nb::getattr(call, group), name), arr, false))
        throw std::invalid_argument(std::string(group) + "." + name + " must be a C-contiguous " + dtype_name<T>() +
                                    (std::is_const_v<T> ? "" : " writable") + " numpy array");
    return arr;
}

template <class T>
static T scalar_field(nb::handle call, const char *group, const char *name) {
    T v;
    if (!nb::try_cast(nb::getattr(nb::getattr(call, group), name), v, false))
        throw std::invalid_argument(std::string(group) + "." + name + " must be a Python " +
                                    (std::is_same_v<T, double> ? "float" : std::is_same_v<T, bool> ? "bool" : "int"));
    return v;
}

// every array of the call, held while it runs
struct Arrays {
#define WSMAP_LANES_HOLD(group, T, name, count) Arr<T> name;
    WSMAP_LANES_ARRAYS(WSMAP_LANES_HOLD)
#undef WSMAP_LANES_HOLD
};

// the call's fields, checked: every array of the size its table line says, the targets' arms and
// explicit start counts in range
static wl::Args read_call(nb::handle call, Arrays &h) {
    wl::Args a{};
#define WSMAP_LANES_READ_ARRAY(group, T, name, count) h.name = array_field<T>(call, #group, #name);
#define WSMAP_LANES_READ_SCALAR(group, T, name) a.name = scalar_field<T>(call, #group, #name);
    WSMAP_LANES_ARRAYS(WSMAP_LANES_READ_ARRAY)
    WSMAP_LANES_SCALARS(WSMAP_LANES_READ_SCALAR)
#undef WSMAP_LANES_READ_ARRAY
#undef WSMAP_LANES_READ_SCALAR
    if (a.mode < 0 || a.mode > 2) throw std::invalid_argument("mode must be 0, 1 or 2");
    if (h.axes.ndim() != 2 || h.axes.shape(1) != 3) throw std::invalid_argument("axes must be (n, 3)");
    if (h.qexp.ndim() != 3) throw std::invalid_argument("qexp must be (M, S, n)");
    const size_t M = h.arm.size(), n = h.axes.shape(0), B = h.limited.size(), S = h.qexp.shape(1);
    if (n < 1 || n > (size_t)wl::MAX_JOINTS) throw std::invalid_argument("the lane kernel takes 1 to 16 joints");
#define WSMAP_LANES_CHECK(group, T, name, count) need(h.name, count, #group "." #name);
    WSMAP_LANES_ARRAYS(WSMAP_LANES_CHECK)
#undef WSMAP_LANES_CHECK
    for (size_t i = 0; i < M; ++i) {
        if (h.arm.data()[i] < 0 || (size_t)h.arm.data()[i] >= B) throw std::invalid_argument("arm index out of range");
        if (h.nexp.data()[i] < 0 || (size_t)h.nexp.data()[i] > S) throw std::invalid_argument("nexp out of range");
    }
    a.M = (int64_t)M, a.B = (int64_t)B, a.n = (int64_t)n, a.S = (int64_t)S;
#define WSMAP_LANES_POINT(group, T, name, count) a.name = h.name.data();
    WSMAP_LANES_ARRAYS(WSMAP_LANES_POINT)
#undef WSMAP_LANES_POINT
    return a;
}

// fn(a, lanes) on this thread and threads - 1 new ones (they share a's counter); the first
// exception any of them throws is rethrown here, after every thread has ended
static void run_on_threads(RunFn fn, const wl::Args &a, int lanes, int threads) {
    std::exception_ptr error;
    std::mutex lock;
    auto work = [&]() {
        try {
            fn(a, lanes);
        } catch (...) {
            std::lock_guard<std::mutex> g(lock);
            if (!error) error = std::current_exception();
        }
    };
    std::vector<std::thread> pool;
    pool.reserve(threads - 1);
    for (int t = 1; t < threads; ++t) pool.emplace_back(work);
    work();
    for (auto &t : pool) t.join();
    if (error) std::rethrow_exception(error);
}

static void run_targets(nb::handle call, Out<int64_t> counter, int lanes, const std::string &isa, int threads) {
    Arrays h;
    wl::Args a = read_call(call, h);
    need(counter, 1, "counter");
    RunFn fn = build(isa).run;
    if (lanes != 4 && lanes != 8 && lanes != 16) throw std::invalid_argument("lanes must be 4, 8 or 16");
    if (threads < 1 || threads > 1024) throw std::invalid_argument("threads must be 1 to 1024, not " + std::to_string(threads));
    a.counter = counter.data();
    nb::gil_scoped_release release;
    run_on_threads(fn, a, lanes, threads);
}

// "group.name" of every field lanes.hpp's tables hold (lm_lanes checks them against lm_compiled.KernelCall)
static nb::tuple fields() {
    nb::list out;
#define WSMAP_LANES_NAME_ARRAY(group, T, name, count) out.append(#group "." #name);
#define WSMAP_LANES_NAME_SCALAR(group, T, name) out.append(#group "." #name);
    WSMAP_LANES_ARRAYS(WSMAP_LANES_NAME_ARRAY)
    WSMAP_LANES_SCALARS(WSMAP_LANES_NAME_SCALAR)
#undef WSMAP_LANES_NAME_ARRAY
#undef WSMAP_LANES_NAME_SCALAR
    return nb::tuple(out);
}

NB_MODULE(_lanes, m) {
    m.doc() = "The lane (SIMD) build of the LM search of wsmap.kinematics.lm_compiled; see wsmap.kinematics.lm_lanes.";
    m.def("run_targets", &run_targets, nb::arg("call"), nb::arg("counter"), nb::arg("lanes"), nb::arg("isa"),
          nb::arg("threads") = 1,
          "lm_compiled.run_targets on the lanes: call (an lm_compiled.KernelCall), counter (1,) int64 (the next "
          "target, shared by every block of the call), lanes (4, 8 or 16), isa ('auto', 'avx512', 'avx2', 'base') "
          "and threads (blocks run at once: this thread and threads - 1 of the call's own, the GIL released).");
    m.def("atan2", &atan2_lanes, "out <- atan2(y, x) for y >= 0 as the lanes compute it (tests): y, x, out, isa.");
    m.def("best_isa", &best_isa, "The widest instruction set this CPU has that a build exists for.");
    m.attr("MAX_JOINTS") = wl::MAX_JOINTS;
    // run_targets takes threads= (builds before it ran one block per call: lm_lanes's Python threads)
    m.attr("THREADS") = true;
    m.attr("FIELDS") = fields();
}

// test_bt_erfc.cpp — bt_erfc (kernels/common/bt_math.h), the kernels' own
// double-precision complementary error function, on the host (C++) and on
// the OpenCL device, against oracles that do not share its code:
//   * glibc's long double erfcl on dense sweeps of [-7, 28] (64-bit
//     mantissa: 11 bits more than a double, so the measured error is exact to
//     about 1/1000 ulp);
//   * 36-digit values computed for this file with mpmath (erfc of the double
//     nearest each decimal written below, i.e. of the argument the function
//     actually receives), read as long double;
//   * glibc's double erfc, itself a few ulp from the exact value, as a third
//     and coarser cross-check.
// The error of a result y for the exact value v is |y - v| / ulp(v), ulp(v)
// the spacing of doubles at v (the smallest denormal below 2^-1022).
#include <doctest/doctest.h>

#include <cfloat>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "host/engine/kernel_sources.h"
#include "host/engine/opencl_runtime.h"
#include "kernels/common/bt_math.h"
#include "test_support.h"

using namespace brdftab;
using brdftab::test::ulp_error;
namespace fs = std::filesystem;

namespace {

const bool pocl_cache_ready = test::default_pocl_cache(BT_BINARY_DIR);

// Bound over every input below, host and device (the device contracts
// a * b + c into FMAs, which changes the last bits).  Measured maxima:
// the test's MESSAGE lines and docs/contributing.md (the bt_math table).
const double erfc_ulp_bound = 3.0;

// The arguments: dense sweeps over the range the Beckmann sampler uses
// ([-7, 7] and large negative) and on to the underflow; the switches of
// bt_erfc (|x| = 15/32 and 1/2) and the seams of its exponential's
// reduction; tiny and huge arguments of both signs.
std::vector<double> erfc_inputs() {
    std::vector<double> x;
    const int n = 700000;
    for (int i = 0; i <= n; ++i) x.push_back(-7.0 + 35.0 * i / n);
    for (int i = 0; i <= 200000; ++i) x.push_back(-1.0 + 2.0 * i / 200000);
    for (double s : {0.46875, 0.5, -0.46875, -0.5})
        for (int k = -1000; k <= 1000; ++k) x.push_back(s + k * DBL_EPSILON);
    // Arguments whose a^2 sits next to a multiple of ln 2 (n changes there).
    for (int j = 1; j < 1130; ++j) {
        const double a = std::sqrt(j * 0.69314718055994530942);
        for (int k = -3; k <= 3; ++k) x.push_back(a + k * 4 * DBL_EPSILON * a);
    }
    for (int e = -1074; e < 10; ++e)
        for (int k = 0; k < 8; ++k) {
            const double v = std::ldexp(1.0 + k / 8.0, e);
            x.push_back(v);
            x.push_back(-v);
        }
    return x;
}

struct Worst {
    double ulp = 0, x = 0, relative = 0;
};

Worst worst_error(const std::vector<double>& in, const std::vector<double>& out) {
    Worst w;
    for (std::size_t i = 0; i < in.size(); ++i) {
        const long double v = erfcl((long double)in[i]);
        const double e = ulp_error(out[i], v);
        if (e > w.ulp) w.ulp = e, w.x = in[i];
        if (v >= DBL_MIN) w.relative = std::fmax(w.relative, (double)(std::fabs(out[i] - v) / v));
    }
    return w;
}

// erfc(x) to 36 digits (mpmath, 45-digit working precision), x the double
// nearest the written decimal.
struct Reference {
    double x;
    const char* value;
};
const Reference mpmath_values[] = {
    {-6.5, "1.99999999999999999996157851672879353"},
    {-3, "1.99997790950300141455862722387041768"},
    {-1, "1.84270079294971486934122063508260926"},
    {-0.5, "1.52049987781304653768274665389196453"},
    {-1e-10, "1.00000000011283791670955126150017301"},
    {1e-300, "1.0"},
    {1e-8, "9.99999988716208329044874401078982371e-1"},
    {0.001, "9.9887162120903076359656243586062851e-1"},
    {0.1, "8.87537083981715101595287748985695938e-1"},
    {0.25, "7.23673609831763067014931732235184288e-1"},
    {0.46875, "5.07386526782062008411823898064653343e-1"},
    {0.5, "4.79500122186953462317253346108035471e-1"},
    {0.75, "2.88844366346484868401062165408589223e-1"},
    {1, "1.57299207050285130658779364917390741e-1"},
    {1.5, "3.38948535246892729330237383540521413e-2"},
    {2, "4.67773498104726583793074363274707139e-3"},
    {2.5, "4.0695201744495893956421573997491272e-4"},
    {3, "2.20904969985854413727761295823203798e-5"},
    {4.5, "1.96616044154288747627916036766433266e-10"},
    {6, "2.15197367124989131165933503991873846e-17"},
    {7, "4.18382560777941439861401022389993225e-23"},
    {10, "2.08848758376254475700078629495778861e-45"},
    {15, "7.21299417245120666656506655869292711e-100"},
    {20, "5.3958656116079009289349991679053456e-176"},
    {26, "5.66319240885614284647572789692609258e-296"},
    {26.5, "2.21090766426373427592923902291582604e-307"},
    {27, "5.23704892378925568501606768284954709e-319"},
    {27.2, "1.01890491427031553951423375670766647e-323"},
};

const char* const device_source = R"CL(
__kernel void bt_erfc_eval(__global const double* x, __global double* out)
{
    size_t i = get_global_id(0);
    out[i] = bt_erfc(x[i]);
}
)CL";

DeviceInfo fp64_cpu_device() {
    for (const auto& d : list_devices())
        if (d.is_cpu && d.has_fp64) return d;
    return {};
}

} // namespace

TEST_CASE("bt_erfc on the host: within its ulp bound of long double erfcl") {
    const std::vector<double> in = erfc_inputs();
    std::vector<double> out(in.size());
    for (std::size_t i = 0; i < in.size(); ++i) out[i] = bt_erfc(in[i]);
    const Worst w = worst_error(in, out);
    INFO(in.size() << " inputs, max " << w.ulp << " ulp at x = " << w.x);
    MESSAGE("bt_erfc host: max " << w.ulp << " ulp (at x = " << w.x << "), max relative " << w.relative);
    CHECK(w.ulp <= erfc_ulp_bound);
    CHECK(w.relative <= 5e-16);

    // glibc's double erfc on the same inputs, for scale (not a bound on
    // bt_erfc); the two must agree within the sum of their errors.
    std::vector<double> glibc(in.size());
    for (std::size_t i = 0; i < in.size(); ++i) glibc[i] = std::erfc(in[i]);
    const Worst g = worst_error(in, glibc);
    MESSAGE("glibc erfc (double): max " << g.ulp << " ulp (at x = " << g.x << ")");
    double apart = 0;
    for (std::size_t i = 0; i < in.size(); ++i)
        apart = std::fmax(apart, ulp_error(out[i], (long double)glibc[i]));
    CHECK(apart <= erfc_ulp_bound + g.ulp + 1);
}

TEST_CASE("bt_erfc against 36-digit mpmath values") {
    double worst = 0;
    for (const Reference& r : mpmath_values) {
        const long double v = std::strtold(r.value, nullptr);
        const double e = ulp_error(bt_erfc(r.x), v);
        INFO("x = " << r.x << ": bt_erfc " << bt_erfc(r.x) << ", reference " << r.value << ", " << e << " ulp");
        CHECK(e <= erfc_ulp_bound);
        worst = std::fmax(worst, e);
        // The long double oracle of the sweeps agrees with mpmath to far
        // below an ulp (it is the sweeps' oracle, so check it too).
        CHECK(ulp_error((double)erfcl((long double)r.x), v) <= 0.5001);
    }
    MESSAGE("bt_erfc against mpmath: max " << worst << " ulp");
}

TEST_CASE("bt_erfc special values and limits") {
    const double inf = std::numeric_limits<double>::infinity();
    CHECK(bt_erfc(0.0) == 1.0);
    CHECK(bt_erfc(-0.0) == 1.0);
    CHECK(bt_erfc(1e-300) == 1.0);
    CHECK(bt_erfc(-1e-300) == 1.0);
    CHECK(bt_erfc(inf) == 0.0);
    CHECK(bt_erfc(-inf) == 2.0);
    CHECK(bt_erfc(-1e15) == 2.0); // the sampler's erfc(-mu) at normal incidence
    CHECK(bt_erfc(-7.0) == 2.0);  // 2 - 4.2e-23 rounds to 2
    CHECK(bt_erfc(28.0) == 0.0);
    CHECK(bt_erfc(1e300) == 0.0);
    CHECK(bt_erfc(27.2) > 0.0); // denormal results are kept
    CHECK(std::isnan(bt_erfc(std::nan(""))));
    // erfc is decreasing: no step back across the seams of the pieces.
    double prev = bt_erfc(-7.0);
    for (int i = 1; i <= 350000; ++i) {
        const double x = -7.0 + 35.0 * i / 350000;
        const double y = bt_erfc(x);
        if (y > prev) {
            INFO("bt_erfc increases at x = " << x);
            CHECK(y <= prev);
        }
        prev = y;
    }
}

TEST_CASE("bt_erfc on the OpenCL device: the same inputs, the same bound") {
    REQUIRE(pocl_cache_ready);
    const DeviceInfo device = fp64_cpu_device();
    if (device.name.empty()) {
        MESSAGE("no fp64 CPU device: device check skipped");
        return;
    }
    ClRuntime rt(device);
    const std::string source = load_kernel_source("common/bt_math.h") + device_source;
    cl::Program program = rt.build_program(source, "-cl-std=CL1.2 -D BT_HAS_FP64=1");
    // Float mode builds too (bt_erfc is the built-in there).
    CHECK_NOTHROW(rt.build_program(load_kernel_source("common/bt_math.h") +
                                       "__kernel void f(__global float* o) { o[0] = bt_erfc(o[1]); }\n",
                                   "-cl-std=CL1.2 -D BT_HAS_FP64=1 -D BT_REAL_IS_FLOAT=1"));
    const std::vector<double> in = erfc_inputs();
    const std::size_t n = in.size();
    cl::Buffer bx(rt.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, n * sizeof(double),
                  const_cast<double*>(in.data()));
    cl::Buffer bo(rt.context(), CL_MEM_WRITE_ONLY, n * sizeof(double));
    cl::Kernel kernel(program, "bt_erfc_eval");
    kernel.setArg(0, bx);
    kernel.setArg(1, bo);
    rt.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(n));
    std::vector<double> out(n);
    rt.queue().enqueueReadBuffer(bo, CL_TRUE, 0, n * sizeof(double), out.data());
    const Worst w = worst_error(in, out);
    INFO(n << " inputs, max " << w.ulp << " ulp at x = " << w.x);
    MESSAGE("bt_erfc device: max " << w.ulp << " ulp (at x = " << w.x << "), max relative " << w.relative);
    CHECK(w.ulp <= erfc_ulp_bound);
    CHECK(w.relative <= 5e-16);
    // Where the result is exact (erfc 0 = 1, the clamps at 2 and 0, NaN),
    // host and device agree exactly; elsewhere they may differ in the last
    // bits (FMA contraction on the device).
    for (std::size_t i = 0; i < n; ++i) {
        const double x = in[i];
        if (!(x == 0 || x <= -7 || x >= 28)) continue;
        const double h = bt_erfc(x);
        if (h != out[i]) {
            INFO("x = " << x << " device " << out[i] << " host " << h);
            CHECK(h == out[i]);
        }
    }
}

// test_kernel_math.cpp — the kernels' own transcendental functions
// (kernels/common/bt_math.h) against the C library's long double functions,
// on the host (C++) and on the OpenCL device, with the same inputs and the
// same ulp bounds.
//
// Oracle: glibc's long double sinl/cosl/expl/logl/... (64-bit mantissa: the
// reference carries 11 bits more than a double, so the measured error is
// exact to ~1/2000 ulp), an implementation independent of bt_math.h.  The
// error of a result y for the exact value v is |y - v| / ulp(v), ulp(v) the
// spacing of doubles at v (the smallest denormal below 2^-1022).
// Special values (signed zeros, infinities, log of 0 and of negatives) are
// checked exactly against C99's rules.
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

enum Fn { SIN, COS, SINCOS_S, SINCOS_C, TAN, EXP, LOG, LOG1P, ATAN, ATAN2, ASIN, ACOS, ERF, N_FN };
const char* const fn_names[N_FN] = {"sin",  "cos", "sincos.s", "sincos.c", "tan",  "exp",
                                    "log",  "log1p", "atan",   "atan2",    "asin", "acos",
                                    "erf"};
// Bounds in ulp over the sweeps below (measured maxima are in the comments
// of the test cases and in docs/contributing.md; the bounds leave room for
// FMA contraction on the device).
// erf: 8 ulp is below 1e-15 relative on [0.5, 1), where its largest errors
// are (measured 6.9 ulp at x = 2.415, the end of its series).
const double fn_bound[N_FN] = {2.5, 2.5, 2.5, 2.5, 4.0, 1.5, 1.5, 2.0, 2.0, 2.0, 3.0, 2.5, 8.0};

double host_eval(int fn, double x, double y) {
    double c;
    switch (fn) {
    case SIN: return bt_sin(x);
    case COS: return bt_cos(x);
    case SINCOS_S: return bt_sincos(x, &c);
    case SINCOS_C: bt_sincos(x, &c); return c;
    case TAN: return bt_tan(x);
    case EXP: return bt_exp(x);
    case LOG: return bt_log(x);
    case LOG1P: return bt_log1p(x);
    case ATAN: return bt_atan(x);
    case ATAN2: return bt_atan2(y, x);
    case ASIN: return bt_asin(x);
    case ERF: return bt_erf(x);
    default: return bt_acos(x);
    }
}

long double reference(int fn, double x, double y) {
    const long double lx = x;
    switch (fn) {
    case SIN: case SINCOS_S: return sinl(lx);
    case COS: case SINCOS_C: return cosl(lx);
    case TAN: return tanl(lx);
    case EXP: return expl(lx);
    case LOG: return logl(lx);
    case LOG1P: return log1pl(lx);
    case ATAN: return atanl(lx);
    case ATAN2: return atan2l((long double)y, lx);
    case ASIN: return asinl(lx);
    case ERF: return erfl(lx);
    default: return acosl(lx);
    }
}

// Inputs (x, y) of one function: dense sweeps over the domain the kernels
// use and beyond, plus the hard spots of each reduction.
struct Inputs {
    std::vector<double> x, y;
    void add(double a, double b = 0) { x.push_back(a); y.push_back(b); }
};

void sweep(Inputs& in, double lo, double hi, int n) {
    for (int i = 0; i <= n; ++i) in.add(lo + (hi - lo) * i / n);
}
// Geometric sweep of both signs from 2^e0 to 2^e1.
void log_sweep(Inputs& in, int e0, int e1, int per_octave, bool negative) {
    for (int e = e0; e < e1; ++e)
        for (int k = 0; k < per_octave; ++k) {
            const double v = std::ldexp(1.0 + (double)k / per_octave, e);
            in.add(v);
            if (negative) in.add(-v);
        }
}

Inputs inputs_for(int fn) {
    Inputs in;
    const double pio2 = 1.5707963267948966;
    switch (fn) {
    case SIN: case COS: case SINCOS_S: case SINCOS_C: case TAN:
        sweep(in, -10, 10, 200000);
        sweep(in, -1e5, 1e5, 20011);
        log_sweep(in, -1074, 3, 8, true);
        // Next to multiples of pi/2, where the reduced argument cancels.
        for (int k = -64; k <= 64; ++k) {
            double v = k * pio2;
            for (int s = 0; s < 4; ++s) {
                in.add(v);
                v = std::nextafter(v, 1e300);
            }
        }
        in.add(0.0); in.add(-0.0);
        break;
    case EXP:
        sweep(in, -745.1, 709.78, 300000);
        sweep(in, -1, 1, 100000);
        log_sweep(in, -1074, 0, 16, true);
        in.add(0.0); in.add(-0.0); in.add(709.782712893384); in.add(-708.39641853226408);
        break;
    case LOG:
        log_sweep(in, -1074, 1024, 256, false);
        for (int k = -2000; k <= 2000; ++k) in.add(1.0 + k * 1e-6), in.add(1.0 + k * DBL_EPSILON);
        sweep(in, 0.5, 2, 100000);
        in.add(DBL_MAX); in.add(DBL_MIN); in.add(std::ldexp(1.0, -1074));
        break;
    case LOG1P:
        log_sweep(in, -1074, 1000, 64, false);
        log_sweep(in, -1074, 0, 64, false);
        for (std::size_t i = 0, n = in.x.size(); i < n; ++i)
            if (in.x[i] < 1) in.add(-in.x[i]);
        sweep(in, -0.999999, 3, 100000);
        break;
    case ATAN:
        log_sweep(in, -1074, 1024, 64, true);
        sweep(in, -4, 4, 200000);
        in.add(0.0); in.add(-0.0);
        break;
    case ATAN2:
        // Angles all round the circle at radii from denormal to huge.
        for (int e = -1070; e <= 1020; e += 30)
            for (int k = 0; k < 2000; ++k) {
                const double a = -3.14159 + 6.28318 * k / 1999;
                in.add(std::ldexp(std::cos(a), e), std::ldexp(std::sin(a), e));
            }
        for (int i = -100; i <= 100; ++i)
            for (int j = -100; j <= 100; ++j) in.add(i * 0.37, j * 0.41);
        break;
    case ASIN: case ACOS:
        sweep(in, -1, 1, 400000);
        for (int k = 0; k < 4000; ++k) {
            const double d = std::ldexp(1.0, -53) * k;
            in.add(1 - d); in.add(-1 + d);
        }
        log_sweep(in, -1074, 0, 16, true);
        in.add(0.0); in.add(-0.0); in.add(1.0); in.add(-1.0);
        break;
    case ERF:
        // Both pieces, the switch between them at |x| = 2.5, tiny and huge.
        sweep(in, -7, 7, 400000);
        for (int k = -2000; k <= 2000; ++k) in.add(2.5 + k * DBL_EPSILON), in.add(-2.5 + k * 1e-9);
        log_sweep(in, -1074, 1024, 16, true);
        in.add(0.0); in.add(-0.0); in.add(INFINITY); in.add(-INFINITY);
        break;
    }
    return in;
}

struct Worst {
    double ulp = 0, x = 0, y = 0;
};

Worst worst_error(int fn, const Inputs& in, const std::vector<double>& out) {
    Worst w;
    for (std::size_t i = 0; i < in.x.size(); ++i) {
        const double e = ulp_error(out[i], reference(fn, in.x[i], in.y[i]));
        if (e > w.ulp) w = {e, in.x[i], in.y[i]};
    }
    return w;
}

const char* const device_source = R"CL(
__kernel void bt_math_eval(__global const double* x, __global const double* y,
                           __global double* out, int fn)
{
    size_t i = get_global_id(0);
    double a = x[i], b = y[i], c;
    double r;
    switch (fn) {
    case 0: r = bt_sin(a); break;
    case 1: r = bt_cos(a); break;
    case 2: r = bt_sincos(a, &c); break;
    case 3: bt_sincos(a, &c); r = c; break;
    case 4: r = bt_tan(a); break;
    case 5: r = bt_exp(a); break;
    case 6: r = bt_log(a); break;
    case 7: r = bt_log1p(a); break;
    case 8: r = bt_atan(a); break;
    case 9: r = bt_atan2(b, a); break;
    case 10: r = bt_asin(a); break;
    case 12: r = bt_erf(a); break;
    default: r = bt_acos(a); break;
    }
    out[i] = r;
}
)CL";

DeviceInfo fp64_cpu_device() {
    for (const auto& d : list_devices())
        if (d.is_cpu && d.has_fp64) return d;
    return {};
}

} // namespace

TEST_CASE("bt_math on the host: every function within its ulp bound against long double") {
    for (int fn = 0; fn < N_FN; ++fn) {
        const Inputs in = inputs_for(fn);
        std::vector<double> out(in.x.size());
        for (std::size_t i = 0; i < out.size(); ++i) out[i] = host_eval(fn, in.x[i], in.y[i]);
        const Worst w = worst_error(fn, in, out);
        INFO(std::string(fn_names[fn]) << ": " << in.x.size() << " inputs, max " << w.ulp << " ulp at x = " << w.x
                          << ", y = " << w.y);
        MESSAGE(std::string(fn_names[fn]) << " host max ulp " << w.ulp);
        CHECK(w.ulp <= fn_bound[fn]);
    }
}

TEST_CASE("bt_math special values follow C99") {
    const double inf = std::numeric_limits<double>::infinity();
    const double pi = 3.14159265358979323846;
    CHECK(std::signbit(bt_sin(-0.0)));
    CHECK(bt_sin(0.0) == 0.0);
    CHECK(!std::signbit(bt_sin(0.0)));
    CHECK(bt_cos(0.0) == 1.0);
    CHECK(bt_cos(-0.0) == 1.0);
    CHECK(std::isnan(bt_sin(inf)));
    CHECK(std::isnan(bt_cos(-inf)));
    CHECK(std::isnan(bt_sin(std::nan(""))));
    CHECK(bt_exp(0.0) == 1.0);
    CHECK(bt_exp(-inf) == 0.0);
    CHECK(bt_exp(inf) == inf);
    CHECK(bt_exp(710.0) == inf);
    CHECK(bt_exp(-746.0) == 0.0);
    CHECK(bt_exp(-745.0) > 0.0); // the smallest denormal range is reached
    CHECK(std::isnan(bt_exp(std::nan(""))));
    CHECK(bt_log(1.0) == 0.0);
    CHECK(bt_log(0.0) == -inf);
    CHECK(bt_log(-0.0) == -inf);
    CHECK(bt_log(inf) == inf);
    CHECK(std::isnan(bt_log(-1.0)));
    CHECK(std::isnan(bt_log(std::nan(""))));
    CHECK(bt_log1p(-1.0) == -inf);
    CHECK(bt_log1p(0.0) == 0.0);
    CHECK(std::signbit(bt_log1p(-0.0)));
    CHECK(bt_log1p(1e-300) == 1e-300);
    CHECK(bt_atan(inf) == pi / 2);
    CHECK(bt_atan(-inf) == -pi / 2);
    CHECK(std::signbit(bt_atan(-0.0)));
    CHECK(bt_atan2(0.0, 0.0) == 0.0);
    CHECK(std::signbit(bt_atan2(-0.0, 0.0)));
    CHECK(bt_atan2(0.0, -0.0) == pi);
    CHECK(bt_atan2(-0.0, -0.0) == -pi);
    CHECK(bt_atan2(0.0, -1.0) == pi);
    CHECK(bt_atan2(-0.0, -1.0) == -pi);
    CHECK(bt_atan2(1.0, 0.0) == pi / 2);
    CHECK(bt_atan2(-1.0, -0.0) == -pi / 2);
    CHECK(bt_atan2(inf, inf) == pi / 4);
    CHECK(bt_atan2(-inf, -inf) == -3 * pi / 4);
    CHECK(bt_atan2(1.0, inf) == 0.0);
    CHECK(bt_atan2(1.0, -inf) == pi);
    CHECK(bt_acos(1.0) == 0.0);
    CHECK(bt_acos(-1.0) == pi);
    CHECK(bt_asin(1.0) == pi / 2);
    CHECK(bt_asin(-1.0) == -pi / 2);
    CHECK(std::signbit(bt_asin(-0.0)));
    CHECK(bt_acos(0.0) == pi / 2);
    CHECK(bt_erf(0.0) == 0.0);
    CHECK(std::signbit(bt_erf(-0.0)));
    CHECK(bt_erf(inf) == 1.0);
    CHECK(bt_erf(-inf) == -1.0);
    CHECK(std::isnan(bt_erf(std::nan(""))));
}

TEST_CASE("bt_math on the OpenCL device: the same inputs, the same bounds") {
    REQUIRE(pocl_cache_ready);
    const DeviceInfo device = fp64_cpu_device();
    if (device.name.empty()) {
        MESSAGE("no fp64 CPU device: device check skipped");
        return;
    }
    ClRuntime rt(device);
    const std::string source = load_kernel_source("common/bt_math.h") + device_source;
    cl::Program program = rt.build_program(source, "-cl-std=CL1.2 -D BT_HAS_FP64=1");
    // Float mode must build too (the names map to the built-ins).
    CHECK_NOTHROW(rt.build_program(load_kernel_source("common/bt_math.h") +
                                       "__kernel void f(__global float* o) { float c;"
                                       " o[0] = bt_sin(o[0]) + bt_sincos(o[1], &c) + bt_atan2(o[2], c)"
                                       " + bt_exp(o[3]) + bt_log1p(o[4]) + bt_acos(o[5]) + bt_erf(o[6]); }\n",
                                   "-cl-std=CL1.2 -D BT_HAS_FP64=1 -D BT_REAL_IS_FLOAT=1"));
    for (int fn = 0; fn < N_FN; ++fn) {
        const Inputs in = inputs_for(fn);
        const std::size_t n = in.x.size();
        cl::Buffer bx(rt.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, n * sizeof(double),
                      const_cast<double*>(in.x.data()));
        cl::Buffer by(rt.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, n * sizeof(double),
                      const_cast<double*>(in.y.data()));
        cl::Buffer bo(rt.context(), CL_MEM_WRITE_ONLY, n * sizeof(double));
        cl::Kernel kernel(program, "bt_math_eval");
        kernel.setArg(0, bx);
        kernel.setArg(1, by);
        kernel.setArg(2, bo);
        kernel.setArg(3, (cl_int)fn);
        rt.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(n));
        std::vector<double> out(n);
        rt.queue().enqueueReadBuffer(bo, CL_TRUE, 0, n * sizeof(double), out.data());
        const Worst w = worst_error(fn, in, out);
        INFO(std::string(fn_names[fn]) << ": " << n << " inputs, max " << w.ulp << " ulp at x = " << w.x << ", y = " << w.y);
        MESSAGE(std::string(fn_names[fn]) << " device max ulp " << w.ulp);
        CHECK(w.ulp <= fn_bound[fn]);
        // Special values on the device as on the host.
        for (std::size_t i = 0; i < n; ++i)
            if (std::isinf(out[i]) || std::isnan(out[i]) || out[i] == 0) {
                const double h = host_eval(fn, in.x[i], in.y[i]);
                INFO(std::string(fn_names[fn]) << " x = " << in.x[i] << " device " << out[i] << " host " << h);
                CHECK((std::isnan(h) ? std::isnan(out[i]) : h == out[i]));
            }
    }
}

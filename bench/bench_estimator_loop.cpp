// bench_estimator_loop — does PoCL vectorise the estimator's sample loop?
//
// Builds the real entry point (kernels/common/estimate.cl, with the real
// samplers) around a synthetic,
// trigonometry-free sample function (two uniforms, a GGX-like density:
// additions, multiplications, divisions, one sqrt) and times it in several
// variants: specialised or generic, the barrier in the sample loop on or off,
// work-group sizes, shared helpers force-inlined or not.  Prints samples per
// second of wall time and per CPU-second of the process (the latter survives
// a busy machine).  Run by hand:
//   cmake --build build --target bench_estimator_loop && build/bench/bench_estimator_loop
#include <time.h>

#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "host/engine/kernel_sources.h"
#include "host/engine/opencl_runtime.h"

using namespace brdftab;

namespace {

const char* kSynthetic = R"CLC(
BT_INLINE REAL synthetic_sample(const REAL* p, const int* o, int quantity, const bt_sampler* s)
{
    const REAL u0 = bt_uniform(s, 0u), u1 = bt_uniform(s, 1u);
    const REAL a2 = p[4] * p[4];
    const REAL t = u0 / (R(1.0) - u0 + R(1e-12));
    const REAL c2 = R(1.0) / (R(1.0) + a2 * t);
    const REAL k = R(1.0) + (a2 - R(1.0)) * c2;
    const REAL d = a2 / (k * k);
    REAL w = d * sqrt(c2);
    if (o[0] == 1) w *= u1; else w *= R(1.0) - u1;
    if (quantity == 1) w += R(0.5);
    return w;
}
#define bt_hook_sample synthetic_sample
)CLC";

double cpu_seconds() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

struct Variant {
    std::string name, options;
    bool force_inline;
    std::size_t local;  // 0 = driver's choice
};

}  // namespace

int main() {
    const DeviceInfo info = select_device("");
    ClRuntime rt(info);
    std::printf("device: %s\n", info.name.c_str());
    const unsigned n = 16384, batch = 256, stride = 6;
    std::vector<double> points(n * stride);
    for (unsigned k = 0; k < n; ++k) {
        for (unsigned j = 0; j < stride; ++j) points[k * stride + j] = 0.1 + 0.3 * j;
        points[k * stride + 4] = 0.05 + 0.9 * (k % 97) / 97.0;
    }
    std::vector<cl_uint> cells(n), batches(n, 0);
    for (unsigned k = 0; k < n; ++k) cells[k] = k;
    int options[1] = {1};
    cl::Context& ctx = rt.context();
    cl::Buffer bp(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, points.size() * 8, points.data());
    cl::Buffer bo(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof options, options);
    cl::Buffer bc(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, n * 4, cells.data());
    cl::Buffer bb(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, n * 4, batches.data());
    cl::Buffer om(ctx, CL_MEM_WRITE_ONLY, n * 8), o2(ctx, CL_MEM_WRITE_ONLY, n * 8);

    const std::string spec = " -D BT_SPEC_QUANTITY=0 -D BT_SPEC_OPTIONS=1 -D BT_SPEC_STRIDE=6";
    std::vector<Variant> variants;
    for (unsigned method : {0u, 1u}) {
        const std::string m = method == 0 ? "mc" : "rqmc";
        const std::string ms = spec + " -D BT_SPEC_METHOD=" + std::to_string(method);
        for (int barrier : {0, 1}) {
            const std::string b = " -D BT_SAMPLE_BARRIER=" + std::to_string(barrier);
            const std::string bn = barrier ? " barrier" : " no-barrier";
            variants.push_back({m + " generic" + bn + " local=auto", b, false, 0});
            variants.push_back({m + " specialised" + bn + " local=auto", ms + b, false, 0});
            variants.push_back({m + " specialised" + bn + " local=64", ms + b, false, 64});
            variants.push_back({m + " specialised" + bn + " local=64 always_inline", ms + b, true, 64});
            variants.push_back({m + " specialised" + bn + " local=256 always_inline", ms + b, true, 256});
        }
    }
    std::printf("%-58s %12s %14s %s\n", "variant", "samples/s", "per CPU-s", "mean[0]");
    for (const Variant& v : variants) {
        // compat.h first; force-inlining redefines BT_INLINE before the
        // shared headers (estimator.h, sampler.h) define their functions.
        std::string source = "#define BT_NO_FORCE_INLINE 1\n";
        source += load_kernel_source("common/compat.h");
        if (v.force_inline)
            source += "#undef BT_INLINE\n#define BT_INLINE static inline __attribute__((always_inline))\n";
        source += load_kernel_source("common/estimator.h");
        source += kSynthetic;
        source += load_kernel_source("common/estimate.cl");
        const unsigned method = v.name.rfind("mc", 0) == 0 ? 0u : 1u;
        cl::Program program = rt.build_program(
            source, "-cl-std=CL1.2 -D BT_HAS_FP64=1" + v.options);
        cl::Kernel k(program, "bt_estimate");
        int a = 0;
        k.setArg(a++, bp);
        k.setArg(a++, cl_uint(stride));
        k.setArg(a++, bo);
        k.setArg(a++, cl_uint(1));
        k.setArg(a++, cl_int(0));
        k.setArg(a++, cl_uint(method));
        k.setArg(a++, cl_uint(7));
        k.setArg(a++, cl_uint(0));
        k.setArg(a++, bc);
        k.setArg(a++, bb);
        k.setArg(a++, cl_uint(n));
        k.setArg(a++, cl_uint(batch));
        k.setArg(a++, om);
        k.setArg(a++, o2);
        const cl::NDRange local = v.local ? cl::NDRange(v.local) : cl::NullRange;
        auto run = [&] {
            rt.queue().enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(n), local);
            rt.queue().finish();
        };
        run();  // work-group specialisation
        double best_wall = 1e30, best_cpu = 1e30;
        for (int r = 0; r < 3; ++r) {
            const double c0 = cpu_seconds();
            const auto t0 = std::chrono::steady_clock::now();
            run();
            best_wall = std::min(
                best_wall,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
            best_cpu = std::min(best_cpu, cpu_seconds() - c0);
        }
        double mean0 = 0;
        rt.queue().enqueueReadBuffer(om, CL_TRUE, 0, 8, &mean0);
        const double samples = double(n) * batch;
        std::printf("%-58s %12.3g %14.3g %.17g\n", v.name.c_str(), samples / best_wall,
                    samples / best_cpu, mean0);
        std::fflush(stdout);
    }
    return 0;
}

// bench.cpp — the engine benchmark behind `brdftab bench` (bench.h).
#include "host/engine/bench.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <thread>
#include <time.h>

#include "host/core/error.h"
#include "host/engine/opencl_runtime.h"

namespace brdftab {

std::vector<BenchCase> default_bench_cases() {
    // Every model's declared cases (ModelInfo::bench), in listing order.
    std::vector<BenchCase> cases;
    for (const ModelInfo& m : all_models())
        for (const BenchDeclaration& d : m.bench)
            cases.push_back({m.name, d.quantity, d.per_cell, d.flops_estimate, d.theta_o_max,
                             d.method, d.headline});
    return cases;
}

namespace {

// The k-th of `count` points: the quantity's directions spread by an
// additive recurrence (fractional parts of k * irrational), everything else
// at its default.  Quantities without directions spread their first
// parameter over its range.
std::vector<double> bench_points(const ModelInfo& model, const QuantityInfo& q,
                                 const BenchCase& c, std::size_t count) {
    PointBuilder builder(model, q);
    const std::size_t stride = model.point_stride();
    std::vector<double> points(count * stride);
    auto has = [&](const char* d) {
        return std::find(q.directions.begin(), q.directions.end(), d) != q.directions.end();
    };
    auto values_of = [&](std::size_t k) {
        auto frac = [&](double g) {
            const double x = static_cast<double>(k + 1) * g;
            return x - std::floor(x);
        };
        std::map<std::string, double> values;
        if (has("theta_i")) values["theta_i"] = 89.0 * frac(0.7548776662466927);
        if (has("theta_o")) values["theta_o"] = c.theta_o_max * frac(0.5698402909980532);
        if (has("phi_o")) values["phi_d"] = 360.0 * frac(0.6180339887498949) - 180.0;
        if (q.directions.empty() && !model.parameters.empty()) {
            const ParameterInfo& p = model.parameters.front();
            const double lo = p.min, hi = std::min(p.max, p.min + 1.0);
            values[p.name] = lo + (hi - lo) * (0.02 + 0.96 * frac(0.7548776662466927));
        }
        for (const ParameterInfo& p : model.parameters)
            if (!values.count(p.name) && !p.default_value)
                values[p.name] = 0.5 * (p.min + std::min(p.max, p.min + 2.0));
        return values;
    };
    if (count == 0) return points;
    if (q.directions.empty()) {
        for (std::size_t k = 0; k < count; ++k) builder.build(values_of(k), &points[k * stride]);
        return points;
    }
    // Only the directions change from point to point: the first point goes
    // through the builder (names, ranges, defaults, the model's checks), the
    // others copy it and set their direction slots with the builder's own
    // conversions (degrees to radians, phi_o = phi_i + phi_d).  Building
    // every point through the builder's maps took longer than the timed runs
    // of a closed-form case.
    builder.build(values_of(0), points.data());
    constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
    const bool theta_i = has("theta_i"), theta_o = has("theta_o"), phi_o = has("phi_o");
    for (std::size_t k = 1; k < count; ++k) {
        auto frac = [&](double g) {  // as in values_of
            const double x = static_cast<double>(k + 1) * g;
            return x - std::floor(x);
        };
        double* out = &points[k * stride];
        std::copy_n(points.data(), stride, out);
        if (theta_i) out[0] = 89.0 * frac(0.7548776662466927) * kDegToRad;
        if (theta_o) out[2] = c.theta_o_max * frac(0.5698402909980532) * kDegToRad;
        if (phi_o) out[3] = out[1] + (360.0 * frac(0.6180339887498949) - 180.0) * kDegToRad;
    }
    return points;
}

struct Workload {
    const ModelInfo* model = nullptr;
    const QuantityInfo* quantity = nullptr;
    std::vector<int> options;
    IntegrationSettings settings;
    std::vector<double> points;  // pilot-sized or final
};

double process_cpu_seconds() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// Seconds of one estimate() over the first `cells` points; sets the work done.
double time_run(Backend& backend, const Workload& w, std::size_t cells,
                std::uint64_t& evaluations) {
    const std::size_t stride = w.model->point_stride();
    // A span of cells at a time (PointsFn): one copy per launch on every
    // backend alike.
    const PointsFn points_of = [&](std::size_t first, std::size_t count, double* out) {
        std::copy_n(w.points.data() + first * stride, count * stride, out);
    };
    const auto t0 = std::chrono::steady_clock::now();
    EstimateResult r =
        estimate(backend, *w.model, *w.quantity, w.options, cells, points_of, w.settings);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    evaluations = r.total_samples;
    return s;
}

double median(std::vector<double> v) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// The timings of one backend, filled one repeat at a time (measure_backends).
struct TimingSeries {
    std::vector<double> seconds, cpu_rates;
};

// Times every backend on the same workload: a warm-up each (kernel builds,
// PoCL's work-group specialisation; the device, backends[0], at the full
// size, whose large launches need PoCL's general work-group variant, which
// small launches do not build), then `repeats` rounds in which each backend runs once in turn.  Interleaved, so that a slower phase of the
// machine (other processes, frequency) falls on every backend alike rather
// than on whichever was running then: the serial host's rate moved by 30 %
// from one whole series to the next on the project machine.
std::vector<BackendTiming> measure_backends(const std::vector<Backend*>& backends, const Workload& w,
                                            std::size_t cells, bool per_cell, unsigned repeats,
                                            std::uint64_t& evaluations) {
    std::uint64_t evals = 0;
    for (std::size_t k = 0; k < backends.size(); ++k)
        time_run(*backends[k], w, k == 0 ? cells : std::min<std::size_t>(cells, 256), evals);
    std::vector<BackendTiming> out(backends.size());
    std::vector<TimingSeries> series(backends.size());
    for (unsigned r = 0; r < std::max(1u, repeats); ++r) {
        for (std::size_t k = 0; k < backends.size(); ++k) {
            const double cpu0 = process_cpu_seconds();
            const double s = time_run(*backends[k], w, cells, evals);
            const double cpu = process_cpu_seconds() - cpu0;
            const double work = per_cell ? static_cast<double>(cells) : static_cast<double>(evals);
            series[k].seconds.push_back(s);
            out[k].all_rates.push_back(s > 0 ? work / s : 0);
            series[k].cpu_rates.push_back(cpu > 0 ? work / cpu : 0);
        }
    }
    evaluations = evals;
    for (std::size_t k = 0; k < backends.size(); ++k) {
        out[k].backend = backends[k]->device_name();
        out[k].seconds = median(series[k].seconds);
        out[k].rate = median(out[k].all_rates);
        out[k].rate_per_cpu_second = median(series[k].cpu_rates);
    }
    return out;
}

}  // namespace

BenchReport run_bench(Backend& device, const BenchSettings& in, const BenchStartFn& on_start) {
    BenchSettings settings = in;
    std::vector<BenchCase> cases;
    for (const BenchCase& c : default_bench_cases()) {
        if (!settings.model_filter.empty() && c.model != settings.model_filter) continue;
        if (!settings.quantity_filter.empty() && c.quantity != settings.quantity_filter) continue;
        cases.push_back(c);
    }
    if (cases.empty()) {
        std::string list;
        for (const BenchCase& c : default_bench_cases())
            list += (list.empty() ? "" : ", ") + c.model + " " + c.quantity;
        throw InputError("bench: no case matches --model '" + settings.model_filter +
                         "' --quantity '" + settings.quantity_filter + "'; cases: " + list);
    }

    auto host = make_backend("host", Precision::Double);
    auto threads = make_backend("host-threads", Precision::Double);
    BenchReport report;
    report.device_name = device.device_name();
    report.precision = precision_name(device.precision());
    report.host_threads = std::max(1u, std::thread::hardware_concurrency());

    report.load_average_start = load_average_1min();
    for (const BenchCase& c : cases) {
        if (on_start) on_start(c);
        Workload w;
        w.model = &find_model(c.model);
        w.quantity = &w.model->quantity(c.quantity);
        w.options = resolve_options(*w.model, nlohmann::json::object(), "");
        const Method method = resolve_method(*w.quantity, c.method);
        w.settings.method = method;
        w.settings.samples = settings.samples;
        const bool integral = method == Method::MonteCarlo || method == Method::Rqmc;

        // Pilot on the serial host: how many cells take host_seconds there.
        std::size_t cells = integral ? 16 : 256;
        std::uint64_t evals = 0;
        w.points = bench_points(*w.model, *w.quantity, c, cells);
        time_run(*host, w, std::min<std::size_t>(cells, 8), evals);  // first-call costs
        double s = time_run(*host, w, cells, evals);
        while (s < 0.05 && cells < (1u << 24)) {
            cells *= 4;
            w.points = bench_points(*w.model, *w.quantity, c, cells);
            s = time_run(*host, w, cells, evals);
        }
        const double scale = settings.host_seconds / std::max(s, 1e-6);
        cells = std::clamp<std::size_t>(static_cast<std::size_t>(cells * scale), 64, 1u << 24);
        // A device needs many work items to fill its cores (an MC cell is one
        // work item per batch): an expensive integral trades samples per cell
        // for cells, down to 64 samples, to get at least 512 cells.
        while (integral && cells < 512 && w.settings.samples >= 128) {
            w.settings.samples /= 2;
            cells *= 2;
        }
        w.points = bench_points(*w.model, *w.quantity, c, cells);

        BenchCaseResult r;
        r.spec = c;
        r.method = to_string(method);
        r.unit = c.per_cell ? "cells/s" : "evals/s";
        r.cells = cells;
        r.samples_per_cell = integral ? w.settings.samples : 1;
        const std::vector<BackendTiming> timings = measure_backends(
            {&device, host.get(), threads.get()}, w, cells, c.per_cell, settings.repeats, evals);
        r.device = timings[0];
        r.host = timings[1];
        r.host_threads = timings[2];
        r.evaluations = evals;
        auto ratio = [](double a, double b) { return b > 0 ? a / b : 0.0; };
        r.device_over_host = ratio(r.device.rate, r.host.rate);
        r.device_over_threads = ratio(r.device.rate, r.host_threads.rate);
        r.threads_over_host = ratio(r.host_threads.rate, r.host.rate);
        if (c.flops_estimate > 0 && !c.per_cell)
            r.device_gflops = r.device.rate * c.flops_estimate / 1e9;
        report.cases.push_back(std::move(r));
    }
    report.load_average_end = load_average_1min();
    return report;
}

std::string host_cpu_instruction_set() {
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f")) return "AVX-512";
    if (__builtin_cpu_supports("avx2")) return "AVX2";
    if (__builtin_cpu_supports("avx")) return "AVX";
    if (__builtin_cpu_supports("sse2")) return "SSE2";
#endif
    return "unknown";
}

std::string host_build_instruction_set() {
#if defined(__AVX512F__)
    return "AVX-512";
#elif defined(__AVX2__)
    return "AVX2";
#elif defined(__AVX__)
    return "AVX";
#elif defined(__SSE2__)
    return "SSE2";
#else
    return "unknown";
#endif
}

namespace {

// The widest vector instruction set with `lanes` doubles per register.
std::string lanes_instruction_set(unsigned lanes) {
    if (lanes >= 8) return "AVX-512";
    if (lanes == 4) return "AVX/AVX2";
    if (lanes == 2) return "SSE2";
    return lanes == 1 ? "scalar" : "unknown";
}

// Doubles per vector register of the code LLVM generates for an x86 CPU
// name (POCL_LLVM_CPU_NAME, or PoCL's detection of the host): 8 where the
// CPU has AVX-512, 4 for AVX/AVX2, 2 for SSE2; 0 for a name not known here.
unsigned llvm_cpu_double_lanes(const std::string& cpu) {
    static const char* const avx512[] = {"skylake-avx512", "cascadelake", "cooperlake", "cannonlake",
                                         "icelake-client", "icelake-server", "tigerlake", "rocketlake",
                                         "sapphirerapids", "emeraldrapids", "graniterapids", "znver4",
                                         "znver5", "knl", "knm", "x86-64-v4"};
    static const char* const avx[] = {"haswell", "broadwell", "skylake", "alderlake", "raptorlake",
                                      "meteorlake", "arrowlake", "lunarlake", "gracemont", "sierraforest",
                                      "grandridge", "znver1", "znver2", "znver3", "bdver1", "bdver2",
                                      "bdver3", "bdver4", "btver2", "sandybridge", "ivybridge",
                                      "corei7-avx", "core-avx-i", "core-avx2", "x86-64-v3"};
    for (const char* n : avx512)
        if (cpu == n) return 8;
    for (const char* n : avx)
        if (cpu == n) return 4;
    static const char* const sse[] = {"x86-64", "x86-64-v2", "nehalem", "westmere", "silvermont",
                                      "goldmont", "goldmont-plus", "tremont", "core2", "penryn", "btver1"};
    for (const char* n : sse)
        if (cpu == n) return 2;
    return 0;
}

// AVX2 is told apart from AVX by name only where LLVM's CPU has it.
std::string llvm_cpu_instruction_set(const std::string& cpu, unsigned lanes) {
    if (lanes != 4) return lanes_instruction_set(lanes);
    static const char* const avx_only[] = {"bdver1", "bdver2", "btver2", "sandybridge", "ivybridge",
                                           "corei7-avx", "core-avx-i"};
    for (const char* n : avx_only)
        if (cpu == n) return "AVX";
    return "AVX2";
}

}  // namespace

InstructionSets describe_instruction_sets(const std::string& device_selector, bool opencl) {
    InstructionSets isa;
    isa.host_cpu = host_cpu_instruction_set();
    isa.host_build = host_build_instruction_set();
    if (!opencl) {
        isa.device = isa.host_build;
        return isa;
    }
    const DeviceInfo info = select_device(device_selector);
    try {
        isa.device_compute_units = info.compute_units;
        isa.device_double_lanes = info.device.getInfo<CL_DEVICE_NATIVE_VECTOR_WIDTH_DOUBLE>();
        isa.device_preferred_double_lanes = info.device.getInfo<CL_DEVICE_PREFERRED_VECTOR_WIDTH_DOUBLE>();
    } catch (const cl::Error& e) {
        throw OpenCLError(e.what(), e.err(), "while reading the device's vector widths");
    }
    // PoCL's CPU devices are named "<driver>-<LLVM CPU>-<CPU model>", e.g.
    // "pthread-skylake-avx512-Intel(R) Xeon(R) ..." (POCL_LLVM_CPU_NAME sets it).
    // The CPU model may hold '-' too ("64-Core"), but no LLVM CPU name holds a
    // space: the target ends at the last '-' before the model's first space.
    if (info.platform_name.find("Portable Computing Language") != std::string::npos) {
        const std::size_t a = info.name.find('-');
        const std::size_t space = info.name.find(' ');
        const std::size_t b = a == std::string::npos ? a : info.name.rfind('-', space == std::string::npos ? space : space - 1);
        if (a != std::string::npos && b != std::string::npos && b > a)
            isa.device_target = info.name.substr(a + 1, b - a - 1);
    }
    // PoCL reports the vector widths of the CPU it runs on, also when
    // POCL_LLVM_CPU_NAME makes it compile for a narrower one: where the
    // target names a known CPU, its widths are the ones the kernels get.
    if (const unsigned lanes = llvm_cpu_double_lanes(isa.device_target)) {
        isa.device_double_lanes = lanes;
        isa.device_preferred_double_lanes = std::min(isa.device_preferred_double_lanes, lanes);
        isa.device = llvm_cpu_instruction_set(isa.device_target, lanes);
    } else {
        isa.device = lanes_instruction_set(isa.device_double_lanes);
    }
    return isa;
}

void set_efficiencies(BenchReport& report) {
    const unsigned ideal = report.isa.ideal_lanes();
    for (BenchCaseResult& c : report.cases) c.efficiency = ideal ? c.device_over_host / double(ideal) : 0.0;
}

double load_average_1min() {
    std::ifstream in("/proc/loadavg");
    double load = -1;
    if (!(in >> load)) return -1;
    return load;
}

PeakFma measure_peak_fma(const std::string& device_selector, double target_seconds) {
    const DeviceInfo info = select_device(device_selector);
    if (!info.has_fp64)
        throw Error("device '" + info.name + "' has no double precision (cl_khr_fp64)");
    ClRuntime runtime(info);
    // Twelve independent chains of double8 FMAs per work item: enough
    // independent work to cover the FMA latency on every unit; the result is
    // stored so that nothing is optimised away.
    const std::string source = R"CLC(
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
__kernel void bt_peak_fma(__global double* out, uint iterations)
{
    const double8 x = (double8)((double)get_global_id(0) * 1e-9);
    const double8 b = (double8)(0.9999999), c = (double8)(1e-9);
    double8 a0 = x + 0.1, a1 = x + 0.2, a2 = x + 0.3, a3 = x + 0.4, a4 = x + 0.5, a5 = x + 0.6;
    double8 a6 = x + 0.7, a7 = x + 0.8, a8 = x + 0.9, a9 = x + 1.0, a10 = x + 1.1, a11 = x + 1.2;
    for (uint k = 0; k < iterations; ++k) {
        a0 = fma(a0, b, c); a1 = fma(a1, b, c); a2 = fma(a2, b, c); a3 = fma(a3, b, c);
        a4 = fma(a4, b, c); a5 = fma(a5, b, c); a6 = fma(a6, b, c); a7 = fma(a7, b, c);
        a8 = fma(a8, b, c); a9 = fma(a9, b, c); a10 = fma(a10, b, c); a11 = fma(a11, b, c);
    }
    double8 s = ((a0 + a1) + (a2 + a3)) + ((a4 + a5) + (a6 + a7)) + ((a8 + a9) + (a10 + a11));
    out[get_global_id(0)] = s.s0 + s.s1 + s.s2 + s.s3 + s.s4 + s.s5 + s.s6 + s.s7;
}
)CLC";
    constexpr std::uint64_t kChains = 12, kLanes = 8;
    try {
        cl::Program program = runtime.build_program(source, "-cl-std=CL1.2");
        cl::Kernel kernel(program, "bt_peak_fma");
        const std::size_t global =
            std::max<std::size_t>(64, static_cast<std::size_t>(info.compute_units) * 64);
        cl::Buffer out(runtime.context(), CL_MEM_WRITE_ONLY, global * sizeof(double));
        kernel.setArg(0, out);
        auto run = [&](cl_uint iterations) {
            kernel.setArg(1, iterations);
            const auto t0 = std::chrono::steady_clock::now();
            runtime.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(global),
                                                 cl::NullRange);
            runtime.queue().finish();
            return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        };
        run(16);  // warm-up (build, work-group specialisation)
        cl_uint iterations = 1024;
        double s = run(iterations);
        while (s < 0.05 && iterations < (1u << 28)) {
            iterations *= 4;
            s = run(iterations);
        }
        const double want = std::max(0.05, target_seconds);
        iterations = static_cast<cl_uint>(std::clamp(iterations * want / std::max(s, 1e-6), 1.0,
                                                     static_cast<double>(1u << 30)));
        std::vector<double> times;
        for (int r = 0; r < 3; ++r) times.push_back(run(iterations));
        PeakFma p;
        p.seconds = *std::min_element(times.begin(), times.end());
        p.flops = static_cast<std::uint64_t>(global) * iterations * kChains * kLanes * 2;
        p.gflops = static_cast<double>(p.flops) / p.seconds / 1e9;
        return p;
    } catch (const cl::Error& e) {
        throw OpenCLError(e.what(), e.err(), "while measuring the peak FMA rate");
    }
}

BenchTargets evaluate_targets(const BenchReport& report) {
    BenchTargets t;
    std::vector<double> dh, dt;
    for (const BenchCaseResult& r : report.cases) {
        dh.push_back(r.device_over_host);
        dt.push_back(r.device_over_threads);
        if (r.spec.headline) t.bsdf_rate = r.device.rate;
    }
    if (dh.empty()) return t;
    t.min_device_over_host = *std::min_element(dh.begin(), dh.end());
    t.median_device_over_host = median(dh);
    t.min_device_over_threads = *std::min_element(dt.begin(), dt.end());
    t.device_over_host_each = t.min_device_over_host >= 3.5;
    t.device_over_host_median = t.median_device_over_host >= 4.0;
    t.device_over_threads_each = t.min_device_over_threads >= 1.7;
    t.bsdf_rate_met = t.bsdf_rate >= 30e6;
    return t;
}

}  // namespace brdftab

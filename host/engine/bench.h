// bench.h — throughput of the engine's backends on every model's main
// quantities (`brdftab bench`), and the peak double FMA rate of an OpenCL
// device.  The library measures and returns structs; the CLI prints.
//
// Each case is run, with the same points and the same samples, on the OpenCL
// device, the serial host path (--device host) and the threaded host path
// (--device host-threads).  Points are spread over the quantity's directions
// (low-discrepancy, fixed) with the model's default parameters.  A case's size
// is chosen from a short pilot run on the serial host so that the serial host
// takes about `host_seconds`; every backend then evaluates that same work
// `repeats` times and the median rate is reported.  Timings include the
// engine's own work (points, merging), not kernel builds (a warm-up run
// builds them first).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "host/engine/engine.h"

namespace brdftab {

struct BenchCase {
    std::string model, quantity;
    // Closed forms and integrals report evaluations of the integrand per
    // second; quadratures report cells per second (one cell = the accurate
    // and the coarse rule).
    bool per_cell = false;
    // Arithmetic operations of one evaluation, counted by hand from the
    // kernel source (an estimate; 0 = not counted).  Gives the achieved
    // GFLOP-equivalent next to the measured peak.
    double flops_estimate = 0;
    // theta_o range in degrees: 89 (upper hemisphere) or 179 (both sides).
    double theta_o_max = 89;
    // The method measured (Auto: the quantity's default).
    Method method = Method::Auto;
    // The case whose device rate BenchTargets::bsdf_rate reports.
    bool headline = false;
};

// The cases `brdftab bench` runs, in order: every model's main quantities,
// as the models declare them (ModelInfo::bench).
std::vector<BenchCase> default_bench_cases();

struct BenchSettings {
    bool quick = false;           // shorter runs, one repeat
    double host_seconds = 1.0;    // target serial-host time per case (quick: 0.15)
    unsigned repeats = 3;         // timed runs per backend (quick: 1); median reported
    std::uint64_t samples = 1024; // samples per cell for integrals (quick: 256)
    std::string model_filter, quantity_filter;  // empty = all
};

struct BackendTiming {
    std::string backend;      // device name
    double rate = 0;          // evaluations/s (cells/s for quadratures), median
    double seconds = 0;       // median wall time of one run
    // Work per CPU-second of the whole process (all threads, PoCL's
    // included), median: the efficiency figure that survives a busy machine.
    double rate_per_cpu_second = 0;
    std::vector<double> all_rates;  // every repeat
};

struct BenchCaseResult {
    BenchCase spec;
    std::string method;        // method name (registry vocabulary)
    std::string unit;          // "evals/s" or "cells/s"
    std::size_t cells = 0;
    std::uint64_t samples_per_cell = 0;
    std::uint64_t evaluations = 0;  // per run
    BackendTiming device, host, host_threads;
    double device_over_host = 0, device_over_threads = 0, threads_over_host = 0;
    double device_gflops = 0;  // with flops_estimate; 0 when not counted
    // device_over_host / (cores x double lanes): the fraction of the ideal
    // speed-up reached (0 when the lanes are unknown).
    double efficiency = 0;
};

// The instruction sets the figures were measured with.  The ideal speed-up
// of the device over the serial host is cores x double SIMD lanes
// (`ideal_lanes`): every core busy and every lane of its widest double
// vectors used, against one core running scalar code.
struct InstructionSets {
    std::string host_cpu;    // the CPU's widest (cpuid): "AVX-512", "AVX2", "AVX", "SSE2"
    std::string host_build;  // what the host code was compiled for (its -march): same names
    std::string device;      // the OpenCL device's, from its lanes (below)
    std::string device_target;  // PoCL: the LLVM CPU its kernels are compiled for ("" elsewhere)
    unsigned device_compute_units = 0;
    // Doubles per vector: the LLVM CPU PoCL compiles for where it is known,
    // else CL_DEVICE_NATIVE_VECTOR_WIDTH_DOUBLE (and its PREFERRED width).
    unsigned device_double_lanes = 0;
    unsigned device_preferred_double_lanes = 0;
    // cores x lanes: device_compute_units x device_double_lanes (0 = unknown).
    unsigned ideal_lanes() const { return device_compute_units * device_double_lanes; }
};

// The host CPU's widest vector instruction set (cpuid) and the one the host
// code was compiled for.
std::string host_cpu_instruction_set();
std::string host_build_instruction_set();

// The instruction sets of the host and of an OpenCL device (the selector as
// for measure_peak_fma).  A host backend ("host", "host-threads") reports the
// host build's as its own.
InstructionSets describe_instruction_sets(const std::string& device_selector, bool opencl);

struct PeakFma {
    double gflops = 0;   // double FMA, 2 flops each
    double seconds = 0;
    std::uint64_t flops = 0;
};

struct BenchReport {
    std::string device_name, precision;
    unsigned host_threads = 0;
    // The machine's 1-minute load average (/proc/loadavg) when the cases
    // started and when they ended; negative where the system does not
    // provide it.  Timings of a loaded machine are not comparable with a
    // quiet one's: reports should say the load.
    double load_average_start = -1, load_average_end = -1;
    PeakFma peak;
    InstructionSets isa;
    std::vector<BenchCaseResult> cases;
};

// Sets each case's efficiency from report.isa (call after filling isa).
void set_efficiencies(BenchReport& report);

// Called before each case starts (for a progress line); may be empty.
using BenchStartFn = std::function<void(const BenchCase&)>;

// Runs the cases selected by the filters (InputError when the filters select
// none or name an unknown model/quantity).  `device` is the OpenCL backend
// (any backend works; its name is reported).
BenchReport run_bench(Backend& device, const BenchSettings& settings,
                      const BenchStartFn& on_start = nullptr);

// The peak double FMA rate of an OpenCL device: a kernel of independent
// double8 FMA chains.  Throws Error when the device has no fp64.
PeakFma measure_peak_fma(const std::string& device_selector, double target_seconds);

// The speed targets for one report (docs/benchmarks.md, "Targets").
struct BenchTargets {
    double min_device_over_host = 0, median_device_over_host = 0;
    double min_device_over_threads = 0;
    double bsdf_rate = 0;  // the headline case (BenchCase::headline) on the device, evals/s
    bool device_over_host_each = false;   // >= 3.5x for every case
    bool device_over_host_median = false; // median >= 4x
    bool device_over_threads_each = false;  // >= 1.7x for every case
    bool bsdf_rate_met = false;           // >= 30 M evals/s
};
BenchTargets evaluate_targets(const BenchReport& report);

// The 1-minute load average of the machine, or -1 where unavailable.
double load_average_1min();

}  // namespace brdftab

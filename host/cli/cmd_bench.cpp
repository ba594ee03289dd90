// bench: throughput of the OpenCL device, the serial host path and the
// threaded host path on every model's main quantities (host/engine/bench.h),
// the device's peak double FMA rate, the instruction sets and each case's
// efficiency against the ideal, issue #12's targets; optionally the time
// to generate each preset.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

#include <nlohmann/json.hpp>

#include "host/cli/cli_common.h"
#include "host/cli/commands.h"
#include "host/core/error.h"
#include "host/engine/bench.h"
#include "host/generate/generate.h"
#include "host/io/table_io.h"
#include "host/spec/spec.h"

namespace brdftab::cli {

namespace {

nlohmann::json timing_json(const BackendTiming& t) {
    return {{"backend", t.backend},
            {"rate", t.rate},
            {"seconds", t.seconds},
            {"rates", t.all_rates},
            {"rate_per_cpu_second", t.rate_per_cpu_second}};
}

nlohmann::json report_json(const BenchReport& r, const BenchSettings& s) {
    nlohmann::json cases = nlohmann::json::array();
    for (const BenchCaseResult& c : r.cases) {
        nlohmann::json j = {{"model", c.spec.model},
                            {"quantity", c.spec.quantity},
                            {"method", c.method},
                            {"unit", c.unit},
                            {"cells", c.cells},
                            {"samples_per_cell", c.samples_per_cell},
                            {"evaluations", c.evaluations},
                            {"device", timing_json(c.device)},
                            {"host", timing_json(c.host)},
                            {"host_threads", timing_json(c.host_threads)},
                            {"device_over_host", c.device_over_host},
                            {"device_over_threads", c.device_over_threads},
                            {"threads_over_host", c.threads_over_host},
                            {"efficiency", c.efficiency}};
        if (c.spec.flops_estimate > 0) {
            j["flops_per_evaluation_estimate"] = c.spec.flops_estimate;
            j["device_gflops_estimate"] = c.device_gflops;
            j["device_peak_fraction_estimate"] =
                r.peak.gflops > 0 ? c.device_gflops / r.peak.gflops : 0.0;
        }
        cases.push_back(j);
    }
    const BenchTargets t = evaluate_targets(r);
    nlohmann::json targets = {
        {"device_over_host_min", t.min_device_over_host},
        {"device_over_host_median", t.median_device_over_host},
        {"device_over_threads_min", t.min_device_over_threads},
        {"bsdf_evals_per_second", t.bsdf_rate},
        {"met",
         {{"device_over_host_each_3.5x", t.device_over_host_each},
          {"device_over_host_median_4x", t.device_over_host_median},
          {"device_over_threads_each_1.7x", t.device_over_threads_each},
          {"bsdf_30M_evals_per_second", t.bsdf_rate_met}}}};
    nlohmann::json machine = {{"device", r.device_name},
                              {"precision", r.precision},
                              {"host_threads", r.host_threads},
                              {"peak_fma_gflops", r.peak.gflops},
                              {"instruction_sets",
                               {{"host_cpu", r.isa.host_cpu},
                                {"host_build", r.isa.host_build},
                                {"device", r.isa.device},
                                {"device_target", r.isa.device_target},
                                {"device_compute_units", r.isa.device_compute_units},
                                {"device_double_lanes", r.isa.device_double_lanes},
                                {"device_preferred_double_lanes", r.isa.device_preferred_double_lanes},
                                {"ideal_lanes", r.isa.ideal_lanes()}}}};
    // 1-minute load averages around the cases (absent where unknown).
    if (r.load_average_start >= 0) machine["load_average_start"] = r.load_average_start;
    if (r.load_average_end >= 0) machine["load_average_end"] = r.load_average_end;
    nlohmann::json settings = {{"quick", s.quick},
                               {"host_seconds", s.host_seconds},
                               {"repeats", s.repeats},
                               {"samples", s.samples}};
    return {{"brdftab_bench", 1},   {"machine", machine}, {"settings", settings},
            {"cases", cases},       {"targets", targets}};
}

std::string ratio_text(double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2fx", x);
    return buf;
}

void print_report(const BenchReport& r) {
    std::printf("device: %s (%s); host: serial C++ (double); host-threads: %u threads\n",
                r.device_name.c_str(), r.precision.c_str(), r.host_threads);
    const InstructionSets& isa = r.isa;
    std::printf("instruction sets: host CPU %s, host code built for %s; device %s", isa.host_cpu.c_str(),
                isa.host_build.c_str(), isa.device.c_str());
    if (!isa.device_target.empty()) std::printf(" (PoCL target %s)", isa.device_target.c_str());
    if (isa.ideal_lanes())
        std::printf(", %u compute units x %u double lanes (preferred %u) = ideal %ux the serial host",
                    isa.device_compute_units, isa.device_double_lanes, isa.device_preferred_double_lanes,
                    isa.ideal_lanes());
    std::printf("\n");
    if (r.peak.gflops > 0)
        std::printf("peak double FMA rate of the device (double8 FMA chains): %.1f GFLOP/s\n",
                    r.peak.gflops);
    if (r.load_average_start >= 0 && r.load_average_end >= 0)
        std::printf("load average (1 min): %.2f at the start, %.2f at the end (%u logical CPUs; a "
                    "higher load slows the wall-time figures)\n",
                    r.load_average_start, r.load_average_end, r.host_threads);
    std::printf("\n%-22s %-9s %-11s %8s %9s %10s %10s %10s %9s %9s %9s %7s\n", "model", "quantity",
                "method", "unit", "cells", "device", "host", "threads", "dev/host",
                "dev/thr", "thr/host", "ideal");
    for (const BenchCaseResult& c : r.cases) {
        char eff[16] = "-";
        if (isa.ideal_lanes()) std::snprintf(eff, sizeof eff, "%.1f%%", 100 * c.efficiency);
        std::printf("%-22s %-9s %-11s %8s %9zu %10s %10s %10s %9s %9s %9s %7s\n",
                    c.spec.model.c_str(), c.spec.quantity.c_str(), c.method.c_str(),
                    c.unit.c_str(), c.cells, format_count(c.device.rate).c_str(),
                    format_count(c.host.rate).c_str(), format_count(c.host_threads.rate).c_str(),
                    ratio_text(c.device_over_host).c_str(),
                    ratio_text(c.device_over_threads).c_str(),
                    ratio_text(c.threads_over_host).c_str(), eff);
    }
    if (isa.ideal_lanes())
        std::printf("(ideal: device / serial host as a fraction of %u = compute units x double lanes)\n",
                    isa.ideal_lanes());
    std::printf("\nper CPU-second of the process (all its threads; robust on a busy machine):\n");
    std::printf("%-22s %-9s %10s %10s %10s %9s %9s\n", "model", "quantity", "device", "host",
                "threads", "dev/host", "dev/thr");
    for (const BenchCaseResult& c : r.cases) {
        auto q = [](double a, double b) { return ratio_text(b > 0 ? a / b : 0); };
        std::printf("%-22s %-9s %10s %10s %10s %9s %9s\n", c.spec.model.c_str(),
                    c.spec.quantity.c_str(), format_count(c.device.rate_per_cpu_second).c_str(),
                    format_count(c.host.rate_per_cpu_second).c_str(),
                    format_count(c.host_threads.rate_per_cpu_second).c_str(),
                    q(c.device.rate_per_cpu_second, c.host.rate_per_cpu_second).c_str(),
                    q(c.device.rate_per_cpu_second, c.host_threads.rate_per_cpu_second).c_str());
    }
    for (const BenchCaseResult& c : r.cases) {
        if (c.device_gflops <= 0) continue;
        std::printf("\n%s %s: about %.0f flops per evaluation (a hand count, an estimate) -> "
                    "%.1f GFLOP/s on the device",
                    c.spec.model.c_str(), c.spec.quantity.c_str(), c.spec.flops_estimate,
                    c.device_gflops);
        if (r.peak.gflops > 0) std::printf(", %.1f %% of peak", 100 * c.device_gflops / r.peak.gflops);
        std::printf("\n");
    }
    const BenchTargets t = evaluate_targets(r);
    auto mark = [](bool ok) { return ok ? "met" : "not met"; };
    std::printf("\nissue #12 targets (over the cases above):\n");
    std::printf("  device >= 3.5x serial host for every case: min %.2fx  %s\n",
                t.min_device_over_host, mark(t.device_over_host_each));
    std::printf("  median device / serial host >= 4x:         %.2fx  %s\n",
                t.median_device_over_host, mark(t.device_over_host_median));
    std::printf("  device >= 1.7x threaded host for every case: min %.2fx  %s\n",
                t.min_device_over_threads, mark(t.device_over_threads_each));
    if (t.bsdf_rate > 0)
        std::printf("  rough-dielectric bsdf >= 30M evals/s:      %s  %s\n",
                    format_count(t.bsdf_rate).c_str(), mark(t.bsdf_rate_met));
    std::fflush(stdout);
}

void time_presets(const std::string& dir, Backend& device) {
    namespace fs = std::filesystem;
    const fs::path tmp = fs::temp_directory_path() / ("brdftab-bench-" + std::to_string(getpid()));
    fs::create_directories(tmp);
    std::cout << "\npreset generation (" << device.device_name() << "):\n";
    std::vector<fs::path> specs;
    for (const auto& e : fs::directory_iterator(dir))
        if (e.path().extension() == ".toml") specs.push_back(e.path());
    std::sort(specs.begin(), specs.end());
    for (const auto& p : specs) {
        Spec spec = parse_spec_file(p.string());
        const auto t0 = std::chrono::steady_clock::now();
        auto tables = generate_tables(spec, device, spec.integration);
        std::vector<TableData> data;
        std::size_t cells = 0;
        for (auto& t : tables) {
            cells += t.data.cell_count();
            data.push_back(t.data);
        }
        write_tables((tmp / (p.stem().string() + ".h5")).string(), data);
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::cout << "  " << p.filename().string() << ": " << tables.size() << " table(s), "
                  << cells << " cells, " << format_seconds(s) << "\n"
                  << std::flush;
    }
    fs::remove_all(tmp);
}

}  // namespace

void register_bench(CLI::App& app) {
    auto* cmd = app.add_subcommand(
        "bench",
        "measure every model's main quantities on the OpenCL device, the serial host path "
        "and the threaded host path (same points, same samples), the device's peak double "
        "FMA rate, and optionally the time to generate each preset");
    struct State {
        bool quick = false, json = false, no_peak = false;
        std::string model, quantity, presets_dir;
        std::uint64_t samples = 0;
        double seconds = 0;
        unsigned repeats = 0;
        ComputeOptions compute;
    };
    auto state = std::make_shared<State>();  // owned by the callback
    cmd->add_flag("--quick", state->quick,
                  "short run: about 0.15 s of serial-host time per case, one repeat");
    cmd->add_flag("--json", state->json, "print the report as JSON (keys: docs/benchmarks.md)");
    cmd->add_option("--model", state->model, "only the cases of this model");
    cmd->add_option("--quantity", state->quantity, "only the cases of this quantity");
    cmd->add_option("--samples", state->samples,
                    "samples per cell for integrals (default 1024; --quick 256)")
        ->check(CLI::Range(std::uint64_t(1), std::uint64_t(1) << 24));
    cmd->add_option("--seconds", state->seconds,
                    "target serial-host seconds per case (default 1; --quick 0.15)")
        ->check(CLI::Range(0.01, 600.0));
    cmd->add_option("--repeats", state->repeats,
                    "timed runs per backend, median reported (default 3; --quick 1)")
        ->check(CLI::Range(1u, 100u));
    cmd->add_flag("--no-peak", state->no_peak, "skip the peak FMA measurement");
    cmd->add_option("--presets", state->presets_dir,
                    "also time `generate` for every *.toml in this directory (output to a "
                    "temporary directory, deleted afterwards)");
    state->compute.add_to(*cmd, false);
    cmd->callback([state] {
        const State& st = *state;
        BenchSettings s;
        s.quick = st.quick;
        s.host_seconds = st.seconds > 0 ? st.seconds : st.quick ? 0.15 : 1.0;
        s.repeats = st.repeats ? st.repeats : st.quick ? 1 : 3;
        s.samples = st.samples ? st.samples : st.quick ? 256 : 1024;
        s.model_filter = st.model;
        s.quantity_filter = st.quantity;
        auto device = st.compute.make_backend();
        PeakFma peak;
        const bool opencl = device->device_name().rfind("host", 0) != 0;
        if (!st.no_peak && opencl && device->precision() == Precision::Double)
            peak = measure_peak_fma(st.compute.device, st.quick ? 0.1 : 0.5);
        BenchReport report = run_bench(*device, s, [&](const BenchCase& c) {
            if (!st.json) std::cerr << "bench: " << c.model << " " << c.quantity << "\n";
        });
        report.peak = peak;
        report.isa = describe_instruction_sets(st.compute.device, opencl);
        set_efficiencies(report);
        if (st.json)
            std::cout << report_json(report, s).dump(2) << "\n";
        else
            print_report(report);
        if (!st.presets_dir.empty()) time_presets(st.presets_dir, *device);
    });
}

}  // namespace brdftab::cli

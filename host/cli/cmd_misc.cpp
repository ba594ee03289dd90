// bench (export is in cmd_export.cpp).
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <iostream>
#include <memory>

#include "host/cli/cli_common.h"
#include "host/cli/commands.h"
#include "host/cli/read_guard.h"
#include "host/core/error.h"
#include "host/generate/generate.h"
#include "host/spec/spec.h"
#include "host/io/table_io.h"

namespace brdftab::cli {

namespace {

// Throughput of one quantity on one backend: evaluations of the integrand per
// second (closed forms: evaluations of the formula).
double measure(Backend& backend, const ModelInfo& model, const std::string& quantity,
               std::size_t cells, std::uint64_t samples, double& seconds) {
    const QuantityInfo& q = model.quantity(quantity);
    PointBuilder builder(model, q);
    std::vector<int> options = resolve_options(model, nlohmann::json::object(), "");
    IntegrationSettings s;
    s.samples = samples;
    s.method = q.kind == QuantityKind::ClosedForm ? Method::ClosedForm : Method::MonteCarlo;
    // Points are built before timing: the figure is the integrand's, not
    // the name-resolving PointBuilder's.
    const std::size_t stride = model.point_stride();
    std::vector<double> points(cells * stride);
    for (std::size_t cell = 0; cell < cells; ++cell)
        builder.build({{"theta_i", static_cast<double>(cell % 89)},
                       {"theta_o", static_cast<double>((cell * 7) % 180)},
                       {"phi_d", static_cast<double>((cell * 13) % 360) - 180},
                       {"alpha", 0.05 + 0.01 * static_cast<double>(cell % 50)},
                       {"eta", 1.5}},
                      &points[cell * stride]);
    auto point_of = [&](std::size_t cell, double* out) {
        std::copy_n(&points[cell * stride], stride, out);
    };
    // Warm-up (kernel build, PoCL work-group specialisation), then measure.
    estimate(backend, model, q, options, std::min<std::size_t>(cells, 512), point_of, s);
    const auto t0 = std::chrono::steady_clock::now();
    EstimateResult r = estimate(backend, model, q, options, cells, point_of, s);
    seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return static_cast<double>(r.total_samples) / seconds;
}

}  // namespace

void register_bench(CLI::App& app) {
    auto* cmd = app.add_subcommand(
        "bench",
        "measure throughput of the OpenCL path against the host serial path, and optionally "
        "the time to generate each preset");
    struct State {
        std::size_t cells = 4096;
        std::uint64_t samples = 1024;
        std::string presets_dir;
        ComputeOptions compute;
    };
    auto state = std::make_shared<State>();  // owned by the callback
    cmd->add_option("--cells", state->cells, "cells per measurement (default 4096)");
    cmd->add_option("--samples", state->samples, "samples per cell for integrals (default 1024)");
    cmd->add_option("--presets", state->presets_dir,
                    "also time `generate` for every *.toml in this directory (output to a "
                    "temporary directory, deleted afterwards)");
    state->compute.add_to(*cmd, false);
    cmd->callback([state] {
        const State& st = *state;
        const ModelInfo& model = find_model("rough-dielectric");
        auto device = st.compute.make_backend();
        auto host = make_backend("host", Precision::Double);
        std::cout << "device: " << device->device_name() << " ("
                  << precision_name(device->precision()) << "), host: serial C++ (double)\n";
        std::cout << "quantity                      device evals/s    host evals/s   speed-up\n";
        for (const char* q : {"bsdf", "albedo_r", "albedo_t"}) {
            const bool closed = model.quantity(q).kind == QuantityKind::ClosedForm;
            const std::size_t cells = closed ? st.cells * 256 : st.cells;
            double td = 0, th = 0;
            const double rd = measure(*device, model, q, cells, st.samples, td);
            const double rh = measure(*host, model, q, closed ? cells / 16 : cells / 16,
                                      st.samples, th);
            char line[160];
            std::snprintf(line, sizeof line, "rough-dielectric %-12s %14s %15s %9.1fx\n", q,
                          format_count(rd).c_str(), format_count(rh).c_str(), rd / rh);
            std::cout << line << std::flush;
        }
        if (st.presets_dir.empty()) return;
        namespace fs = std::filesystem;
        const fs::path tmp = fs::temp_directory_path() /
                             ("brdftab-bench-" + std::to_string(getpid()));
        fs::create_directories(tmp);
        std::cout << "\npreset generation (" << device->device_name() << "):\n";
        std::vector<fs::path> specs;
        for (const auto& e : fs::directory_iterator(st.presets_dir))
            if (e.path().extension() == ".toml") specs.push_back(e.path());
        std::sort(specs.begin(), specs.end());
        for (const auto& p : specs) {
            Spec spec = parse_spec_file(p.string());
            const auto t0 = std::chrono::steady_clock::now();
            auto tables = generate_tables(spec, *device, spec.integration);
            std::vector<TableData> data;
            std::size_t cells = 0;
            for (auto& t : tables) {
                cells += t.data.cell_count();
                data.push_back(t.data);
            }
            write_tables((tmp / (p.stem().string() + ".h5")).string(), data);
            const double s =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            std::cout << "  " << p.filename().string() << ": " << tables.size() << " table(s), "
                      << cells << " cells, " << format_seconds(s) << "\n"
                      << std::flush;
        }
        fs::remove_all(tmp);
    });
}

}  // namespace brdftab::cli

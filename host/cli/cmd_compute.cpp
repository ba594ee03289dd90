// eval and generate: the commands that run the engine.  The work is done by
// host/engine/evaluate.h and host/generate/generate.h; this file parses and
// prints.
#include <sys/statvfs.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include "host/core/atomic_file.h"
#include "host/cli/cli_common.h"
#include "host/cli/commands.h"
#include "host/core/error.h"
#include "host/engine/evaluate.h"
#include "host/generate/checkpoint.h"
#include "host/generate/generate.h"
#include "host/io/point_file.h"
#include "host/spec/spec.h"
#include "host/io/table_io.h"

namespace brdftab::cli {

namespace {

struct EvalArgs {
    std::string model, quantity;
    std::vector<std::string> assignments;
    bool json = false;
    std::string points_file, output;
    ComputeOptions compute;
};

void run_eval(const EvalArgs& st) {
    const ModelInfo& model = find_model(st.model);
    const QuantityInfo& q = model.quantity(st.quantity);
    NamedInputs inputs(model, q, "argument");
    for (const auto& a : st.assignments) {
        auto [name, text] = split_assignment(a);
        inputs.add(name, text);
    }
    const std::vector<int> options = inputs.options();

    // Points: one from the arguments, or one per CSV row (arguments act as
    // defaults for columns the CSV does not have).
    PointFile file;
    std::vector<std::map<std::string, double>> points;
    if (!st.points_file.empty()) {
        file = read_model_point_file(st.points_file, model, q);
        for (const auto& row : file.rows) points.push_back(file.named(row, inputs.values()));
    } else {
        points.push_back(inputs.values());
    }
    const std::vector<double> kernel_points =
        build_kernel_points(model, q, points, [&](std::size_t k) {
            return st.points_file.empty() ? std::string("arguments")
                                          : st.points_file + " row " + std::to_string(k + 1);
        });
    IntegrationSettings settings = st.compute.apply(IntegrationSettings{});
    check_settings(settings);
    if (!st.output.empty()) check_output_writable(st.output);
    auto backend = st.compute.make_backend();
    EstimateResult r = estimate_at(*backend, model, q, options, kernel_points, settings);

    if (st.points_file.empty()) {
        if (st.json) {
            nlohmann::json j = {{"model", model.name},
                                {"quantity", q.name},
                                {"value", r.value[0]},
                                {"stderr", r.stderr_[0]},
                                {"samples", r.method == Method::ClosedForm ? 1u : r.samples[0]},
                                {"method", to_string(r.method)},
                                {"units", q.units},
                                {"device", backend->device_name()},
                                {"precision", precision_name(backend->precision())}};
            std::cout << j.dump() << "\n";
        } else {
            std::cout << model.name << " " << q.name << " = " << format_double(r.value[0]);
            if (r.method != Method::ClosedForm)
                std::cout << " ± " << r.stderr_[0] << " (1 stderr, " << r.samples[0]
                          << " samples, " << to_string(r.method) << ")";
            else
                std::cout << " (closed form)";
            std::cout << " [" << q.units << "]\n";
        }
        return;
    }
    std::ostringstream csv;
    for (const auto& h : file.header) csv << h << ",";
    csv << "value,stderr,samples\n";
    for (std::size_t k = 0; k < file.rows.size(); ++k) {
        for (const auto& c : file.rows[k].cells) csv << c << ",";
        csv << format_double(r.value[k]) << "," << format_double(r.stderr_[k]) << ","
            << (r.method == Method::ClosedForm ? 1u : r.samples[k]) << "\n";
    }
    if (st.output.empty()) {
        std::cout << csv.str();
    } else {
        write_text_atomically(st.output, csv.str());
        std::cerr << "wrote " << file.rows.size() << " rows to " << st.output << "\n";
    }
}

}  // namespace

void register_eval(CLI::App& app) {
    auto* cmd = app.add_subcommand(
        "eval",
        "evaluate one quantity at one point (or at every row of --points FILE.csv) on the "
        "device, with its standard error");
    // Owned by the callback, which CLI11 keeps as long as the command.
    auto st = std::make_shared<EvalArgs>();
    cmd->add_option("MODEL", st->model, "model name (see `brdftab models`)")->required();
    cmd->add_option("QUANTITY", st->quantity, "quantity of the model")->required();
    cmd->add_option("VALUES", st->assignments,
                    "name=value pairs: directions theta_i phi_i theta_o phi_o phi_d (degrees) "
                    "or mu_i mu_o, model parameters, and options (e.g. distribution=ggx)");
    cmd->add_flag("--json", st->json, "print one JSON object (value, stderr, samples, method)");
    cmd->add_option("--points", st->points_file,
                    "CSV file with a header row of coordinate/parameter names and one point per "
                    "row; all rows are evaluated in one device launch");
    cmd->add_option("-o,--output", st->output, "with --points: write the CSV here instead of stdout")
        ->check(non_empty_path());
    st->compute.add_to(*cmd);
    cmd->callback([st] { run_eval(*st); });
}

namespace {

// "3.9%" for relative errors, "0.0012 1/sr" for absolute ones.
std::string format_error(double e, const ErrorSummary& s, const std::string& units) {
    if (s.measure == "relative") {
        std::ostringstream o;
        o.precision(3);
        o << e * 100 << "%";
        return o.str();
    }
    return units.empty() || units == "1" ? format_short(e) : format_short(e) + " " + units;
}

void print_error_summary(const ErrorSummary& s, const TableData& d) {
    std::cout << "    " << s.measure << " error of " << s.table << " against " << s.reference
              << ": max |e| " << format_error(s.max_abs, s, d.units) << " at ";
    for (std::size_t a = 0; a < s.worst.size(); ++a)
        std::cout << (a ? ", " : "") << d.axes[a].name << " " << format_short(s.worst[a]);
    std::cout << "; RMS " << format_error(s.rms, s, d.units) << ", mean "
              << format_error(s.mean, s, d.units) << "; noise (median stderr) "
              << format_error(s.median_stderr, s, d.units) << "; " << s.beyond_2sigma << " of "
              << s.cells << " cells beyond 2 stderr\n";
    if (s.nonfinite)
        std::cout << "    warning: " << s.nonfinite << " cell(s) are NaN or infinite\n";
    for (const auto& n : s.by_nodes)
        std::cout << "      " << s.by << " = " << format_short(n.value) << ": max |e| "
                  << format_error(n.max_abs, s, d.units) << ", RMS "
                  << format_error(n.rms, s, d.units) << "\n";
}

}  // namespace

namespace {

// MemAvailable of /proc/meminfo in bytes; 0 when unknown (not Linux).
double available_memory() {
    std::ifstream in("/proc/meminfo");
    std::string key, unit;
    double kib = 0;
    while (in >> key >> kib) {
        std::getline(in, unit);
        if (key == "MemAvailable:") return kib * 1024;
    }
    return 0;
}

// Free bytes (for an unprivileged user) on the file system of `path`'s
// directory; negative when unknown.
double free_disk_space(const std::string& path) {
    std::filesystem::path dir = std::filesystem::path(path).parent_path();
    if (dir.empty()) dir = ".";
    struct statvfs fs {};
    if (statvfs(dir.c_str(), &fs) != 0) return -1;
    return static_cast<double>(fs.f_bavail) * static_cast<double>(fs.f_frsize);
}

// Refuses (InputError, exit 2) a run whose estimated memory or disk use
// exceeds what is available, before anything is computed.
void check_resources(const Spec& spec, const IntegrationSettings& settings,
                     const std::string& out_path, std::uint64_t max_memory) {
    const ResourceEstimate need = estimate_resources(spec, settings);
    const std::string cells = format_count(need.cells) + " cells (largest table " +
                              format_count(need.largest_cells) + ")";
    // --max-memory, when given, replaces MemAvailable as the limit (the
    // estimate is an upper bound, measured about 1.5x to 2x the real peak).
    if (max_memory && need.memory_bytes > static_cast<double>(max_memory))
        throw InputError(spec.file + ": the tables need about " + format_bytes(need.memory_bytes) +
                         " of memory for " + cells + ", above --max-memory " +
                         format_bytes(static_cast<double>(max_memory)) +
                         "; reduce the axes' counts or split the spec into several");
    const double available = max_memory ? 0 : available_memory();
    if (available > 0 && need.memory_bytes > available)
        throw InputError(spec.file + ": the tables need about " + format_bytes(need.memory_bytes) +
                         " of memory for " + cells + ", but only " + format_bytes(available) +
                         " is available (MemAvailable); reduce the axes' counts or split the "
                         "spec into several");
    const double free_space = free_disk_space(out_path);
    if (free_space >= 0 && need.disk_bytes > free_space)
        throw InputError(out_path + ": the tables need about " + format_bytes(need.disk_bytes) +
                         " on disk before compression for " + cells + ", but only " +
                         format_bytes(free_space) +
                         " is free on its file system; write elsewhere (-o) or reduce the "
                         "axes' counts");
}

}  // namespace

void register_generate(CLI::App& app) {
    auto* cmd = app.add_subcommand(
        "generate",
        "compute every table of a TOML spec (see tables/ and docs/spec.md) and write them to "
        "one HDF5 file");
    struct State {
        std::string spec_path, output, max_memory;
        ComputeOptions compute;
        bool quiet = false;
        bool resume = false;
        double checkpoint_interval = 60;
    };
    auto state = std::make_shared<State>();  // owned by the callback
    cmd->add_option("SPEC", state->spec_path, "table specification (TOML)")->required();
    cmd->add_option("-o,--output", state->output, "output file (default: the spec's output.path)")
        ->check(non_empty_path());
    cmd->add_flag("-q,--quiet", state->quiet, "no progress display");
    cmd->add_option("--max-memory", state->max_memory,
                    "memory limit: refuse (exit 2) before computing when the estimated memory "
                    "use exceeds BYTES (suffixes K, M, G, T: powers of 1024, e.g. 8G). Default: "
                    "MemAvailable of /proc/meminfo. The estimated size on disk is checked "
                    "against the output file system's free space (docs/spec.md)");
    cmd->add_flag("--resume", state->resume,
                  "continue an interrupted run from its checkpoint (OUTPUT.checkpoint/, written "
                  "while tables are computed and removed once the output is written); the "
                  "result is bit-identical to an uninterrupted run. Refused when the spec or "
                  "a setting that changes values differs. See docs/spec.md, \"Interrupted "
                  "runs\"");
    cmd->add_option("--checkpoint-interval", state->checkpoint_interval,
                    "seconds between checkpoints of a table in progress (default 60; 0: "
                    "checkpoint finished tables only)")
        ->check(number_in(0, true, 1e308, "seconds >= 0"));
    state->compute.add_to(*cmd);
    cmd->callback([state] {
        const State& st = *state;
        Spec spec = parse_spec_file(st.spec_path);
        const std::string out_path = st.output.empty() ? spec.output.path : st.output;
        check_output_writable(out_path);
        const IntegrationSettings settings = st.compute.apply(spec.integration);
        check_settings(settings);
        check_resources(spec, settings, out_path,
                        st.max_memory.empty() ? 0 : parse_byte_size(st.max_memory, "--max-memory"));
        auto backend = st.compute.make_backend();
        std::cerr << "brdftab: " << spec.model << ", " << spec.tables.size() << " table(s)";
        if (!spec.recombined.empty()) std::cerr << " + " << spec.recombined.size() << " recombined";
        if (!spec.errors.empty()) std::cerr << " + " << spec.errors.size() << " error table(s)";
        if (!spec.inverted.empty()) std::cerr << " + " << spec.inverted.size() << " inverted";
        std::cerr << " from " << st.spec_path << " on " << backend->device_name()
                  << " (" << precision_name(backend->precision()) << ")\n";
        std::cerr << "writing " << std::filesystem::absolute(out_path).lexically_normal().string()
                  << "\n";
        // Checkpoint (host/generate/checkpoint.h): one beside the output,
        // unless an older one is there and --resume was not given.
        std::unique_ptr<Checkpoint> checkpoint;
        const CheckpointPresence presence = checkpoint_presence(out_path);
        if (presence != CheckpointPresence::None && !st.resume) {
            std::cerr << "brdftab: a checkpoint of "
                      << (presence == CheckpointPresence::InUse ? "a running" : "an interrupted")
                      << " run exists (" << checkpoint_directory(out_path)
                      << "); add --resume to continue it. This run starts from the beginning, "
                         "writes no checkpoint and leaves that one alone.\n";
        } else {
            checkpoint = std::make_unique<Checkpoint>(
                out_path, checkpoint_key(spec, settings, *backend, st.compute.kernel_dir),
                st.resume, st.checkpoint_interval);
            if (st.resume && presence == CheckpointPresence::None)
                std::cerr << "brdftab: no checkpoint to resume from; starting from the "
                             "beginning\n";
            else if (st.resume)
                std::cerr << "brdftab: resuming from " << checkpoint->directory() << ": "
                          << checkpoint->resumed_summary() << "\n";
        }
        std::unique_ptr<ProgressPrinter> printer;
        std::size_t current = static_cast<std::size_t>(-1);
        auto on_progress = [&](const GenerateEvent& e) {
            if (st.quiet) return;
            if (e.table_index != current) {
                if (printer) printer->finish();
                current = e.table_index;
                printer = std::make_unique<ProgressPrinter>(
                    "[" + std::to_string(e.table_index + 1) + "/" +
                    std::to_string(e.table_count) + "] " + e.table->name);
            }
            (*printer)(e.progress);
        };
        std::vector<GeneratedTable> tables = generate_tables(spec, *backend, settings, on_progress,
                                                             checkpoint.get());
        if (printer) printer->finish();
        std::vector<TableData> data;
        for (auto& t : tables) data.push_back(t.data);
        write_tables(out_path, data);
        std::cout << "wrote " << out_path << "\n";
        if (checkpoint) {
            const std::string why = checkpoint->remove();
            if (!why.empty())
                std::cerr << "brdftab: warning: cannot remove the checkpoint "
                          << checkpoint->directory() << ": " << why << "\n";
        }
        for (const auto& t : tables) {
            const TableData& d = t.data;
            double lo = d.value.empty() ? 0 : d.value[0], hi = lo;
            for (double v : d.value) lo = std::min(lo, v), hi = std::max(hi, v);
            std::cout << "  " << d.name << ": " << d.quantity << " [";
            for (std::size_t a = 0; a < d.axes.size(); ++a)
                std::cout << (a ? " x " : "") << d.axes[a].name << " " << d.axes[a].count;
            std::cout << "] = " << d.cell_count() << " cells, " << method_attribute(d);
            if (d.kind == TableKind::Computed &&
                (d.method == Method::MonteCarlo || d.method == Method::Rqmc ||
                 d.method == Method::Quadrature))
                std::cout << ", " << format_count(static_cast<double>(d.total_samples))
                          << " samples, max rel. stderr " << d.tolerance_achieved;
            std::cout << ", values in [" << lo << ", " << hi << "], "
                      << format_seconds(d.elapsed_seconds) << "\n";
            if (t.cells_unconverged)
                std::cout << "  warning: " << t.cells_unconverged
                          << " cell(s) reached max_samples before the tolerance\n";
            if (t.error) print_error_summary(*t.error, d);
        }
    });
}

}  // namespace brdftab::cli

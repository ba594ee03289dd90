// eval and generate: the commands that run the engine.  The work is done by
// host/engine/evaluate.h and host/generate/generate.h; this file parses and
// prints.

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <unistd.h>

#include "host/core/atomic_file.h"
#include "host/cli/cli_adaptive.h"
#include "host/cli/cli_common.h"
#include "host/cli/commands.h"
#include "host/core/error.h"
#include "host/core/text.h"
#include "host/engine/evaluate.h"
#include "host/engine/opencl_runtime.h"
#include "host/generate/checkpoint.h"
#include "host/generate/chunked.h"
#include "host/generate/generate.h"
#ifdef BRDFTAB_MPI
#include "host/generate/distributed.h"
#endif
#include "host/io/point_file.h"
#include "host/plan/certify.h"
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
            if (r.method == Method::Quadrature)
                std::cout << " ± " << r.stderr_[0] << " (error estimate: accurate - coarse rule, quadrature)";
            else if (r.method != Method::ClosedForm)
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

// Refuses (InputError, exit 2) a run whose estimated memory or disk use
// exceeds what is available, before anything is computed.
void check_resources(const Spec& spec, const IntegrationSettings& settings,
                     const std::string& out_path, std::uint64_t max_memory,
                     std::size_t chunk_cells) {
    const ResourceEstimate need = estimate_resources(spec, settings, chunk_cells);
    const std::string cells = format_count(need.cells) + " cells (largest table " +
                              format_count(need.largest_cells) + ")";
    // --max-memory, when given, replaces MemAvailable as the limit (the
    // estimate is an upper bound, measured about 1.2x to 1.3x the real peak).
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

namespace {

struct GenerateArgs {
    std::string spec_path, output, max_memory;
    ComputeOptions compute;
    bool quiet = false;
    bool resume = false;
    double checkpoint_interval = 60;
    std::size_t chunk_cells = 0;
    // Certified generation (host/plan/certify.h, docs/planning.md).
    std::optional<double> accuracy, budget;
    bool absolute = false;
    std::string interpolation;  // empty: linear (and not given)
    std::optional<int> max_refinements;
    bool yes = false;  // accept a plan beyond the cost limits (approve_costly_plan)
    bool full_precision = false;  // --accuracy: no rounded storage
    AdaptiveCliOptions adaptive;  // --representation adaptive (cli_adaptive.h)
    bool certified() const { return accuracy || budget; }
};

void print_summary(const std::vector<GeneratedTable>& tables) {
    for (const auto& t : tables) {
        const TableData& d = t.data;
        std::cout << "  " << d.name << ": " << d.quantity << " [";
        for (std::size_t a = 0; a < d.axes.size(); ++a)
            std::cout << (a ? " x " : "") << d.axes[a].name << " " << d.axes[a].count;
        std::cout << "] = " << d.cell_count() << " cells, " << method_attribute(d);
        if (d.kind == TableKind::Computed &&
            (d.method == Method::MonteCarlo || d.method == Method::Rqmc ||
             d.method == Method::Quadrature))
        {
            // The per-cell maxima as they are, and the engine's stopping
            // metric, max stderr / max(|value|, floor), named as what it is
            // where it differs: with a floor the relative stderr can be far
            // larger.  A quadrature draws no samples: its error estimate is
            // the difference of its two rules.
            if (d.method == Method::Quadrature)
                std::cout << ", max error estimate (accurate - coarse rule) ";
            else
                std::cout << ", " << format_count(static_cast<double>(d.total_samples)) << " samples, max stderr ";
            std::cout << t.stderr_max_abs << " absolute, " << t.stderr_max_rel << " relative";
            if (std::fabs(d.tolerance_achieved - t.stderr_max_rel) >
                1e-9 * std::max(std::fabs(d.tolerance_achieved), std::fabs(t.stderr_max_rel)))
                std::cout << " (tolerance metric " << (d.method == Method::Quadrature ? "estimate" : "stderr")
                          << "/max(|value|, floor) " << d.tolerance_achieved << ")";
        }
        std::cout << ", values in [" << t.value_min << ", " << t.value_max << "], "
                  << format_seconds(d.elapsed_seconds) << "\n";
        if (t.cells_unconverged)
            std::cout << "  warning: " << t.cells_unconverged
                      << " cell(s) reached max_samples before the tolerance\n";
        if (t.error) print_error_summary(*t.error, d);
    }
}

// The setting-up shared by one process and every rank of an MPI run.
struct GenerateSetup {
    Spec spec;
    std::string out_path;
    IntegrationSettings settings;
    std::unique_ptr<Backend> backend;
};

// `writer`: the process that writes the output (checks it and the resources).
GenerateSetup set_up_generate(const GenerateArgs& st, bool writer,
                              const std::string& device_override) {
    GenerateSetup g;
    g.spec = parse_spec_file(st.spec_path);
    g.out_path = st.output.empty() ? g.spec.output.path : st.output;
    if (writer) check_output_writable(g.out_path);
    g.settings = st.compute.apply(g.spec.integration);
    check_settings(g.settings);
    if (writer)
        check_resources(g.spec, g.settings, g.out_path,
                        st.max_memory.empty() ? 0 : parse_byte_size(st.max_memory, "--max-memory"),
                        st.chunk_cells);
    if (device_override.empty()) {
        g.backend = st.compute.make_backend();
    } else {
        ComputeOptions c = st.compute;
        c.device = device_override;
        g.backend = c.make_backend();
    }
    return g;
}

void announce(const GenerateArgs& st, const GenerateSetup& g, int ranks) {
    const Spec& spec = g.spec;
    std::cerr << "brdftab: " << spec.model << ", " << spec.tables.size() << " table(s)";
    if (!spec.recombined.empty()) std::cerr << " + " << spec.recombined.size() << " recombined";
    if (!spec.errors.empty()) std::cerr << " + " << spec.errors.size() << " error table(s)";
    if (!spec.inverted.empty()) std::cerr << " + " << spec.inverted.size() << " inverted";
    std::cerr << " from " << st.spec_path << " on " << g.backend->device_name() << " ("
              << precision_name(g.backend->precision()) << ")";
    if (ranks > 1) std::cerr << " x " << ranks << " MPI ranks";
    std::cerr << "\n";
    std::cerr << "writing "
              << std::filesystem::absolute(g.out_path).lexically_normal().string() << "\n";
}

// Checkpoint (host/generate/checkpoint.h): one beside the output, unless an
// older one is there and --resume was not given.  `created`: whether this run
// made the directory (none was there before).
std::unique_ptr<Checkpoint> open_checkpoint(const GenerateArgs& st, const GenerateSetup& g,
                                            bool& created) {
    std::unique_ptr<Checkpoint> checkpoint;
    const CheckpointPresence presence = checkpoint_presence(g.out_path);
    created = presence == CheckpointPresence::None;
    if (presence != CheckpointPresence::None && !st.resume) {
        std::cerr << "brdftab: a checkpoint of "
                  << (presence == CheckpointPresence::InUse ? "a running" : "an interrupted")
                  << " run exists (" << checkpoint_directory(g.out_path)
                  << "); add --resume to continue it. This run starts from the beginning, "
                     "writes no checkpoint and leaves that one alone.\n";
    } else {
        checkpoint = std::make_unique<Checkpoint>(
            g.out_path, checkpoint_key(g.spec, g.settings, *g.backend, st.compute.kernel_dir),
            st.resume, st.checkpoint_interval);
        if (st.resume && presence == CheckpointPresence::None)
            std::cerr << "brdftab: no checkpoint to resume from; starting from the "
                         "beginning\n";
        else if (st.resume)
            std::cerr << "brdftab: resuming from " << checkpoint->directory() << ": "
                      << checkpoint->resumed_summary() << "\n";
    }
    return checkpoint;
}

// Chunking recorded in a checkpoint ("chunk_cells=<n> ranks=<r>"), so that
// a resumed run cuts the tables as the interrupted one did.
std::string layout_text(std::size_t chunk_cells, int ranks) {
    return "chunk_cells=" + std::to_string(chunk_cells) + " ranks=" + std::to_string(ranks);
}
bool parse_layout(const std::string& text, std::size_t& chunk_cells, int& ranks) {
    unsigned long long c = 0;
    int r = 0;
    if (std::sscanf(text.c_str(), "chunk_cells=%llu ranks=%d", &c, &r) != 2 || r < 1) return false;
    chunk_cells = static_cast<std::size_t>(c);
    ranks = r;
    return true;
}

// A run that stops on bad input found while computing (a cell the model
// refuses, e.g. a Phong alpha axis that reaches 1) leaves nothing worth
// resuming: the same spec stops at the same cell, and a corrected spec has
// another checkpoint key, which --resume refuses.  So the checkpoint this run
// created is removed before the error is reported; one it resumed holds an
// earlier run's work and is left alone.  Other failures (a kill, a device
// error, a full disk) keep the checkpoint for --resume.
template <typename Fn>
auto discarding_checkpoint_on_input_error(Checkpoint* checkpoint, bool created_here, Fn&& fn)
    -> decltype(fn()) {
    try {
        return fn();
    } catch (const InputError&) {
        if (checkpoint && created_here) checkpoint->remove();
        throw;
    }
}

void finish_output(const GenerateSetup& g, Checkpoint* checkpoint) {
    std::cout << "wrote " << g.out_path << "\n";
    if (checkpoint) {
        const std::string why = checkpoint->remove();
        if (!why.empty())
            std::cerr << "brdftab: warning: cannot remove the checkpoint "
                      << checkpoint->directory() << ": " << why << "\n";
    }
}

void run_generate(const GenerateArgs& st) {
    GenerateSetup g = set_up_generate(st, true, "");
    const OutputLock lock(g.out_path);  // one writer of the output (docs/spec.md)
    announce(st, g, 1);
    bool checkpoint_is_new = false;
    std::unique_ptr<Checkpoint> checkpoint = open_checkpoint(st, g, checkpoint_is_new);
    StreamOptions options;
    options.chunk_cells = st.chunk_cells;
    options.checkpoint = checkpoint.get();
    if (checkpoint) {
        int ranks = 1;
        if (!checkpoint->layout().empty() &&
            !parse_layout(checkpoint->layout(), options.chunk_cells, ranks))
            throw InputError("checkpoint '" + checkpoint->directory() +
                             "': unreadable layout '" + checkpoint->layout() + "'");
        options.ranks = ranks;
        if (checkpoint->layout().empty())
            checkpoint->record_layout(layout_text(options.chunk_cells, options.ranks));
    }
    TableProgress progress(st.quiet);
    progress.sampled = [&](const TableSpec& t) { return table_is_sampled(g.spec, t, g.settings.method); };
    std::vector<GeneratedTable> tables =
        discarding_checkpoint_on_input_error(checkpoint.get(), checkpoint_is_new, [&] {
            return generate_to_file(g.spec, *g.backend, g.settings, g.out_path,
                                    progress.callback(), options);
        });
    progress.finish();
    finish_output(g, checkpoint.get());
    print_summary(tables);
}

// "nodes 16x4x4, quadrature 1024, float16".
std::string plan_text(const Candidate& c) {
    std::string nodes;
    for (std::size_t i = 0; i < c.tables.size(); ++i) {
        if (i) nodes += "; ";
        for (std::size_t a = 0; a < c.tables[i].counts.size(); ++a)
            nodes += (a ? "x" : "") + std::to_string(c.tables[i].counts[a]);
    }
    return "nodes " + nodes + ", " + to_string(c.method) +
           (c.samples ? " " + std::to_string(c.samples) : std::string()) + ", " + stored_type_name(c.stored_type);
}

// A plan whose predicted cost is beyond the limits (excessive_plan_cost:
// 10 minutes, 100x the spec's cells and 10^6) is not started without --yes: the
// message names the cost, the cheaper plans and the flags that accept a
// cost.  On a terminal the user is asked; otherwise the run is refused
// (exit 2, nothing written).  A refinement round's plan is refused the
// same way, and the last round's file stands (exit 1: its certificate
// failed).
bool approve_costly_plan(const Candidate& plan, const std::vector<Candidate>& front, int round,
                         const Spec& spec, const PlanTarget& target) {
    const std::string why = excessive_plan_cost(plan, spec);
    if (why.empty()) return true;
    std::ostringstream m;
    m << (round == 0 ? "the plan for --accuracy " : "refinement round " + std::to_string(round) + " for --accuracy ")
      << sci_text(*target.accuracy) << " is beyond what a run starts unasked: " << why << "\n"
      << "  plan: " << plan_text(plan) << "; predicted max total error " << sci_text(plan.error_max)
      << ", time " << format_seconds(plan.seconds) << " (" << format_count(plan_cells(plan)) << " cells; the spec has "
      << format_count(spec_table_cells(spec)) << ")\n";
    // The most accurate plan within a few budgets (the front is sorted by
    // predicted time), and the cheapest one.
    m << "  cheaper plans (predicted):\n";
    std::size_t shown = 0;
    std::optional<std::size_t> last;
    for (double budget : {10.0, 60.0, 600.0}) {
        std::optional<std::size_t> best;
        for (std::size_t i = 0; i < front.size(); ++i)
            if (front[i].seconds <= budget && front[i].seconds < plan.seconds &&
                plan_cells(front[i]) < plan_cells(plan) && (!best || front[i].error_max < front[*best].error_max))
                best = i;
        if (!best || (last && *best == *last)) continue;
        last = best;
        const Candidate& c = front[*best];
        m << "    --budget " << number_text(budget, 6) << ": " << plan_text(c) << "; max total error "
          << sci_text(c.error_max) << ", " << format_seconds(c.seconds) << "\n";
        ++shown;
    }
    if (!shown) m << "    (none)\n";
    m << "  run it anyway with --yes; or --budget SECONDS for the most accurate plan within that time; "
         "or relax --accuracy";
    if (isatty(STDIN_FILENO) && isatty(STDERR_FILENO)) {
        std::cerr << "brdftab: " << m.str() << "\nstart it? [y/N] " << std::flush;
        std::string answer;
        std::getline(std::cin, answer);
        if (answer == "y" || answer == "Y" || answer == "yes") return true;
    } else if (round == 0) {
        throw InputError(m.str() + "\n  (not a terminal: refused; nothing computed or written)");
    } else {
        std::cerr << "brdftab: " << m.str() << "\n  (not a terminal: refused)\n";
    }
    if (round == 0) throw InputError("not started; nothing computed or written");
    return false;
}

// `generate SPEC --accuracy E | --budget T`: plan, generate (the streamed,
// checkpointed path of run_generate), certify, refine (host/plan/certify.h).
// The output is written under a temporary name and renamed over the target
// only once the last round's certificates are stored in it.  A final
// certificate that misses E still leaves a valid, certified-as-failed file
// (certificate_passed = 0) and ends with exit code 1.
// The options of certified generation, checked before anything runs (also
// before `--representation auto` compares plans).
PlanTarget check_certified_options(const GenerateArgs& st) {
    PlanTarget target;
    target.accuracy = st.accuracy;
    target.budget = st.budget;
    target.absolute = st.absolute;
    target.interpolation = st.interpolation == "cubic" ? Interpolation::Cubic : Interpolation::Linear;
    check_target(target);
    const int max_refinements = st.max_refinements.value_or(2);
    if (max_refinements < 0)
        throw InputError("--max-refinements must be an integer >= 0, got " + std::to_string(max_refinements));
    if (st.compute.samples_given || st.compute.tolerance_given || st.compute.max_samples_given ||
        !st.compute.method.empty())
        throw InputError("--samples, --tolerance, --max-samples and --method cannot be combined with "
                         "--accuracy/--budget: the plan chooses the method and the samples");
    if (st.compute.abs_floor == 0)
        throw InputError("--abs-floor must be > 0 with --accuracy/--budget (omit it for the automatic floor)");
    return target;
}

void run_certified_generate(const GenerateArgs& st) {
    const PlanTarget target = check_certified_options(st);
    const int max_refinements = st.max_refinements.value_or(2);
    const Spec spec = parse_spec_file(st.spec_path);
    const std::string out_path = st.output.empty() ? spec.output.path : st.output;
    check_output_writable(out_path);
    const OutputLock lock(out_path);  // one writer of the output (docs/spec.md)
    if (!spec.recombined.empty() || !spec.errors.empty() || !spec.inverted.empty())
        throw InputError(st.spec_path + ": --accuracy/--budget do not handle [[recombined]], [[errors]] or "
                         "[[inverted]] tables yet; generate a copy of the spec without them");
    const std::uint64_t max_memory =
        st.max_memory.empty() ? 0 : parse_byte_size(st.max_memory, "--max-memory");
    auto backend = st.compute.make_backend();
    std::cerr << "brdftab: " << spec.model << ", " << spec.tables.size() << " table(s) from "
              << st.spec_path << " on " << backend->device_name() << " ("
              << precision_name(backend->precision()) << "), certified: "
              << (target.accuracy ? "max total " + std::string(target.absolute ? "absolute" : "relative") +
                                        " error <= " + sci_text(*target.accuracy)
                                  : "time budget " + sci_text(*target.budget) + " s")
              << ", " << (st.interpolation.empty() ? "linear" : st.interpolation) << " interpolation\n";
    std::cerr << "writing " << std::filesystem::absolute(out_path).lexically_normal().string() << "\n";

    CertifiedGenerateOptions options;
    options.target = target;
    options.pilot.abs_floor = st.compute.abs_floor > 0 ? st.compute.abs_floor : 0;
    options.max_refinements = max_refinements;
    options.round_storage = !st.full_precision;
    options.spec_label = st.spec_path;
    options.verify_settings = [&st](const Spec& planned) { return st.compute.apply(planned.integration); };
    // --budget states the cost; --yes accepts any.
    if (target.accuracy && !st.yes)
        options.approve_plan = [&](const Candidate& plan, const std::vector<Candidate>& front, int round) {
            return approve_costly_plan(plan, front, round, spec, target);
        };

    AtomicOutput out(out_path);
    std::vector<GeneratedTable> tables;
    // One round's generation: exactly run_generate's path, into the
    // temporary file; the checkpoint lives beside the final output and is
    // removed when the round's file is complete.
    const GenerateToFn generate = [&](const Spec& planned, const std::string& path, int round) {
        const IntegrationSettings settings = st.compute.apply(planned.integration);
        check_settings(settings);
        check_resources(planned, settings, out_path, max_memory, st.chunk_cells);
        std::unique_ptr<Checkpoint> checkpoint;
        const CheckpointPresence presence = checkpoint_presence(out_path);
        if (presence == CheckpointPresence::None || st.resume)
            checkpoint = std::make_unique<Checkpoint>(
                out_path, checkpoint_key(planned, settings, *backend, st.compute.kernel_dir),
                st.resume && presence != CheckpointPresence::None, st.checkpoint_interval);
        StreamOptions stream;
        stream.chunk_cells = st.chunk_cells;
        stream.checkpoint = checkpoint.get();
        TableProgress progress(st.quiet, "round " + std::to_string(round) + ": ");
        progress.sampled = [&](const TableSpec& t) { return table_is_sampled(planned, t, settings.method); };
        tables = discarding_checkpoint_on_input_error(
            checkpoint.get(), presence == CheckpointPresence::None, [&] {
                return generate_to_file(planned, *backend, settings, path, progress.callback(), stream);
            });
        progress.finish();
        if (checkpoint) checkpoint->remove();
    };
    double last_shown = -1;
    const CertifyProgressFn progress = [&](const CertifyEvent& e) {
        if (st.quiet) return;
        if (!e.message.empty()) {
            std::cerr << "brdftab: " << e.message << "\n";
            last_shown = -1;
        } else if (e.progress.elapsed_seconds >= 2 && e.progress.elapsed_seconds - last_shown >= 5) {
            last_shown = e.progress.elapsed_seconds;
            std::cerr << "brdftab: " << e.stage << ": " << static_cast<int>(100 * e.progress.fraction) << "% "
                      << format_seconds(e.progress.elapsed_seconds) << "\n";
        }
    };
    const CertifiedResult result = certified_generate(spec, *backend, options, out.path(), generate, progress);
    out.commit();
    std::cout << "wrote " << out_path << "\n";
    print_summary(tables);
    const CertifiedRound& last = result.rounds.back();
    for (const Certificate& c : last.certificates) {
        std::cout << "  " << c.table << ": certificate " << (c.passed ? "passed" : "FAILED") << ": "
                  << certificate_error_text(c) << (c.mode == "budget" ? " (the plan's prediction)" : "") << ", predicted "
                  << sci_text(c.predicted_max) << "; " << c.probes << " probes, " << (c.interpolation == Interpolation::Cubic ? "cubic" : "linear")
                  << " interpolation";
        if (!c.absolute) std::cout << ", floor " << sci_text(c.abs_floor);
        if (c.reference_noise > 0) std::cout << ", reference noise " << sci_text(c.reference_noise);
        std::cout << "\n";
    }
    std::cout << "  certification: " << result.rounds.size() << " round(s) (" << (result.rounds.size() - 1)
              << " refinement(s)), pilot " << format_seconds(result.pilot_seconds) << ", total "
              << format_seconds(result.total_seconds) << "; ";
    if (result.stop == "passed")
        std::cout << "every certificate passed\n";
    else if (result.stop == "budget")
        std::cout << "a certificate missed the plan's prediction (--budget: no refinement)\n";
    else if (result.stop == "max-refinements")
        std::cout << "stopped after --max-refinements " << max_refinements << "\n";
    else if (result.stop == "cost")
        std::cout << "stopped: the next refinement's plan was beyond the cost limits (--yes accepts it)\n";
    else
        std::cout << "stopped: no plan is predicted to reach the target with the corrected error model\n";
    if (!result.passed && target.accuracy)
        throw Error("the certificate missed --accuracy " + sci_text(*target.accuracy) + " (" +
                    (result.stop == "max-refinements" ? "--max-refinements " + std::to_string(max_refinements) +
                                                            " reached"
                     : result.stop == "cost"         ? "the next refinement was beyond the cost limits"
                                                      : "no further refinement predicted to reach it") +
                    "); " + out_path + " was written with certificate_passed = 0; raise --max-refinements, "
                    "or relax --accuracy");
}

#ifdef BRDFTAB_MPI
// "cells per rank: 0: 120, 1: 392 (an even split: 256 each)".
void print_cells_per_rank(const std::vector<std::uint64_t>& cells) {
    std::uint64_t total = 0;
    for (std::uint64_t c : cells) total += c;
    std::cout << "  cells per rank:";
    for (std::size_t r = 0; r < cells.size(); ++r)
        std::cout << (r ? ", " : " ") << r << ": " << cells[r];
    std::cout << " (an even split: " << format_count(static_cast<double>(total) / cells.size())
              << " each)\n";
}

// The OpenCL device of a rank: --device or $BRDFTAB_DEVICE when given (the
// same for every rank, unless set per rank by a wrapper), otherwise the
// node's GPUs in turn by rank on the node (local rank k takes GPU k mod the
// number of GPUs), otherwise the default (first CPU device).  "" = default.
std::string rank_device(const GenerateArgs& st, int local_rank) {
    if (!st.compute.device.empty() || environment_setting("BRDFTAB_DEVICE")) return "";
    std::vector<DeviceInfo> gpus;
    try {
        for (const DeviceInfo& d : list_devices())
            if (d.is_gpu) gpus.push_back(d);
    } catch (const Error&) {
        return "";
    }
    if (gpus.empty()) return "";
    return std::to_string(gpus[static_cast<std::size_t>(local_rank) % gpus.size()].index);
}

int error_code(const std::exception& e) {
    return dynamic_cast<const InputError*>(&e) ? 2 : 1;
}

// `mpirun -n N brdftab generate` (host/generate/distributed.h).  A failure
// while setting up (bad spec, unwritable output, no device) is reported once
// and ends every rank with the same exit code; a failure while computing
// ends the job through MPI_Abort, after a message naming the rank.
void run_generate_mpi(const GenerateArgs& st) {
    MpiSession mpi;
    const int rank = mpi.rank(), size = mpi.size();
    const std::string who = "brdftab: rank " + std::to_string(rank) + ": ";
    GenerateSetup g;
    std::unique_ptr<OutputLock> lock;  // rank 0's: one writer of the output
    std::unique_ptr<Checkpoint> checkpoint;
    bool checkpoint_is_new = false;  // created by this run (rank 0)
    std::string layout;
    auto agree = [&](const std::function<void()>& step) {
        int code = 0;
        std::string message;
        try {
            step();
        } catch (const std::exception& e) {
            code = error_code(e);
            message = e.what();
        }
        const int rank0_code = mpi.broadcast(code), worst = mpi.max(code);
        if (worst == 0) return;
        // Every rank reads the same spec and options: rank 0 speaks for
        // them; a rank fails alone only on its own trouble (its device).
        if (code && (rank == 0 || rank0_code == 0))
            std::cerr << (rank == 0 ? std::string("brdftab: ") : who) << "error: " << message
                      << std::endl;
        checkpoint.reset();
        lock.reset();
        mpi.finalize();
        std::exit(worst);
    };
    agree([&] {
        g = set_up_generate(st, rank == 0, rank_device(st, mpi.local_rank()));
        if (rank == 0) lock = std::make_unique<OutputLock>(g.out_path);
        if (rank == 0) announce(st, g, size);
    });
    agree([&] {
        if (rank != 0) return;
        checkpoint = open_checkpoint(st, g, checkpoint_is_new);
        std::size_t chunk_cells = st.chunk_cells;
        int ranks = size;
        if (checkpoint && !checkpoint->layout().empty() &&
            !parse_layout(checkpoint->layout(), chunk_cells, ranks))
            throw InputError("checkpoint '" + checkpoint->directory() +
                             "': unreadable layout '" + checkpoint->layout() + "'");
        if (checkpoint && checkpoint->layout().empty())
            checkpoint->record_layout(layout_text(chunk_cells, ranks));
        layout = (checkpoint ? "checkpoint " : "none ") + layout_text(chunk_cells, ranks);
    });
    mpi.broadcast(layout);
    const bool with_checkpoint = layout.rfind("checkpoint ", 0) == 0;
    std::size_t chunk_cells = 0;
    int ranks = 1;
    parse_layout(layout.substr(layout.find(' ') + 1), chunk_cells, ranks);
    agree([&] {
        if (rank != 0 && with_checkpoint)
            checkpoint = std::make_unique<Checkpoint>(
                g.out_path, checkpoint_key(g.spec, g.settings, *g.backend, st.compute.kernel_dir),
                true, st.checkpoint_interval, true);
    });
    // Bit-identity across ranks needs one kind of device (docs/cluster.md).
    const std::vector<std::string> devices = mpi.gather(g.backend->device_name());
    for (std::size_t r = 1; r < devices.size(); ++r)
        if (devices[r] != devices[0])
            std::cerr << "brdftab: warning: rank " << r << " computes on '" << devices[r]
                      << "', rank 0 on '" << devices[0]
                      << "': values may differ in the last bits between them\n";

    const std::vector<CellChunk> plan = plan_chunks(g.spec, chunk_cells, ranks);
    try {
        if (rank == 0) {
            MpiChunkSharing sharing(mpi, plan);
            StreamOptions options;
            options.chunk_cells = chunk_cells;
            options.ranks = ranks;
            options.checkpoint = checkpoint.get();
            options.sharing = &sharing;
            options.temporary_created = remove_temporaries_on_termination;
            TableProgress progress(st.quiet);
            progress.sampled = [&](const TableSpec& t) { return table_is_sampled(g.spec, t, g.settings.method); };
            std::vector<GeneratedTable> tables =
                discarding_checkpoint_on_input_error(checkpoint.get(), checkpoint_is_new, [&] {
                    return generate_to_file(g.spec, *g.backend, g.settings, g.out_path,
                                            progress.callback(), options);
                });
            progress.finish();
            finish_output(g, checkpoint.get());
            print_summary(tables);
            print_cells_per_rank(sharing.cells_per_process());
            std::cout << "  " << sharing.statistics() << "\n";
        } else {
            ChunkComputer computer(g.spec, *g.backend, g.settings);
            run_chunk_worker(mpi, computer, plan, checkpoint.get());
        }
    } catch (const std::exception& e) {
        std::cerr << who << "error: " << e.what() << std::endl;
        mpi.abort(error_code(e));
    }
}
#endif

}  // namespace

void register_generate(CLI::App& app) {
    auto* cmd = app.add_subcommand(
        "generate",
        "compute every table of a TOML spec (see tables/ and docs/spec.md) and write them to "
        "one HDF5 file");
    auto state = std::make_shared<GenerateArgs>();  // owned by the callback
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
                  "tables are bit-identical to an uninterrupted run's (only the created and "
                  "elapsed_seconds attributes differ). Refused when the spec or "
                  "a setting that changes values differs. See docs/spec.md, \"Interrupted "
                  "runs\"");
    cmd->add_option("--checkpoint-interval", state->checkpoint_interval,
                    "seconds between checkpoints of a table in progress (default 60; 0: "
                    "checkpoint finished tables only)")
        ->check(number_in(0, true, 1e308, "seconds >= 0"));
    cmd->add_option("--chunk-cells", state->chunk_cells,
                    "cells per chunk: tables are computed and written to the file in chunks of "
                    "this many cells, and MPI ranks share them (default 0: automatic, "
                    "262144 cells, or about 8 chunks per rank under MPI; results do not "
                    "depend on it). See docs/cluster.md")
        ->check(number_in(0, true, 1e18, "cells >= 0 (0: automatic)"));
    cmd->add_option("--accuracy", state->accuracy,
                    "certified generation: plan the spec for a max total error <= E (what a "
                    "renderer sees between nodes: interpolation + integration + storage; relative "
                    "to max(|value|, --abs-floor F), F by default 1e-3 x the largest |value|; "
                    "absolute with --abs), generate it, measure the error with "
                    "off-grid probes, refine until the certificate passes (docs/planning.md, "
                    "\"Certified generation\"). Exit code 1 when the final certificate misses E "
                    "(the file is written, certificate_passed = 0)");
    cmd->add_option("--budget", state->budget,
                    "certified generation: the most accurate plan predicted to finish within "
                    "SECONDS, then certified (no refinement)");
    cmd->add_flag("--abs", state->absolute, "with --accuracy/--budget: absolute errors (default: relative)");
    cmd->add_option("--interpolation", state->interpolation,
                    "with --accuracy/--budget: the interpolation the tables will be read with: "
                    "linear (default) or cubic (Catmull-Rom)")
        ->check(CLI::IsMember({"linear", "cubic"}));
    cmd->add_flag("--yes", state->yes,
                  "with --accuracy: start a plan predicted to take more than 10 minutes or more than "
                  "100x the spec's cells (and 10^6 cells); otherwise such a run asks on a terminal, "
                  "and is refused, exit 2, elsewhere (docs/planning.md)");
    cmd->add_option("--max-refinements", state->max_refinements,
                    "with --accuracy: refinement rounds after the first certificate (default 2; 0: "
                    "certify only)");
    cmd->add_flag("--full-precision", state->full_precision,
                  "with --accuracy: keep every mantissa bit of the stored type (default: the values "
                  "keep only the bits E needs, rounding error <= 0.1 E, measured by the "
                  "certificate; docs/spec.md, round_to_accuracy)");
    add_adaptive_options(*cmd, state->adaptive);
    state->compute.add_to(*cmd);
    cmd->callback([state] {
        state->adaptive.full_precision = state->full_precision;
        state->adaptive.resume = state->resume;
        // tensor | adaptive | auto (cli_adaptive.h): auto compares the two
        // plans for the accuracy and generates the smaller one.
        std::string representation =
            generate_representation(state->spec_path, state->adaptive, state->accuracy.has_value());
        if (representation == "auto" && state->budget) {
            if (!state->adaptive.representation.empty())
                throw InputError("--representation auto compares plans for an accuracy: give --accuracy E, not "
                                 "--budget");
            std::cerr << "brdftab: representation: tensor (--budget plans tensor tables; an adaptive table is "
                         "refined to an accuracy)\n";
            representation = "tensor";
        }
        if (representation == "auto" && state->certified()) check_certified_options(*state);
        if (representation == "auto")
            representation = choose_generate_adaptive(state->spec_path, state->compute, state->accuracy,
                                                      state->absolute, state->interpolation == "cubic",
                                                      state->quiet, state->adaptive)
                                 ? "adaptive"
                                 : "tensor";
        if (representation == "adaptive" && state->budget)
            throw InputError("--budget plans tensor tables; an adaptive table is refined to an accuracy: give "
                             "--accuracy E, or --representation tensor");
        if (representation == "adaptive")
            return run_adaptive_generate(state->spec_path, state->output, state->compute, state->accuracy,
                                         state->absolute, state->quiet, state->adaptive);
        if (state->certified()) {
#ifdef BRDFTAB_MPI
            if (MpiSession::launched())
                throw InputError("--accuracy/--budget run in one process; not under mpirun");
#endif
            return run_certified_generate(*state);
        }
        if (state->absolute || !state->interpolation.empty() || state->max_refinements || state->yes)
            throw InputError("--abs, --interpolation, --max-refinements and --yes need --accuracy E or --budget SECONDS");
        if (state->full_precision) throw InputError("--full-precision needs --accuracy E");
#ifdef BRDFTAB_MPI
        if (MpiSession::launched()) return run_generate_mpi(*state);
#endif
        run_generate(*state);
    });
}

}  // namespace brdftab::cli

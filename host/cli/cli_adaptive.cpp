// cli_adaptive.cpp — `generate --representation adaptive` (cli_adaptive.h).
#include "host/cli/cli_adaptive.h"

#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "host/adaptive/adaptive_generate.h"
#include "host/adaptive/adaptive_io.h"
#include "host/core/atomic_file.h"
#include "host/core/error.h"
#include "host/core/text.h"
#include "host/engine/engine_tuning.h"
#include "host/generate/checkpoint.h"
#include "host/io/point_file.h"
#include "host/plan/adaptive_plan.h"
#include "host/plan/plan.h"
#include "host/plan/certify.h"
#include "host/spec/spec.h"
#ifdef BRDFTAB_MPI
#include "host/generate/distributed.h"
#endif

namespace brdftab::cli {

namespace {

// "NAME=X" -> (NAME, X); InputError naming the option otherwise.
std::pair<std::string, double> name_value(const std::string& s, const char* option) {
    const auto eq = s.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == s.size())
        throw InputError(std::string(option) + " '" + s + "': expected NAME=VALUE");
    try {
        std::size_t used = 0;
        const double v = std::stod(s.substr(eq + 1), &used);
        if (used != s.size() - eq - 1 || !std::isfinite(v)) throw std::invalid_argument("");
        return {s.substr(0, eq), v};
    } catch (const std::exception&) {
        throw InputError(std::string(option) + " '" + s + "': '" + s.substr(eq + 1) + "' is not a finite number");
    }
}

}  // namespace

void add_adaptive_options(CLI::App& cmd, AdaptiveCliOptions& o) {
    cmd.add_option("--representation", o.representation,
                   "tensor (one grid per table), adaptive (a k-d tree of small patches refined where "
                   "probes fail, docs/adaptive.md; needs an accuracy) or auto (the planner predicts both "
                   "and generates the one that stores fewer values). Default: the spec's [output] "
                   "representation, else auto with --accuracy and tensor without")
        ->check(CLI::IsMember({"tensor", "adaptive", "auto"}));
    cmd.add_option("--max-values", o.max_values,
                   "adaptive: stored values per table at most (default: the spec's [adaptive] max_values, "
                   "else 65536)")
        ->check(CLI::Range(std::size_t{2}, std::size_t{1} << 31));
    cmd.add_option("--patch-nodes", o.patch_nodes, "adaptive: nodes per axis of a patch: 3 (default), 5 or 9 (overrides the spec's patch_nodes)")
        ->check(CLI::IsMember({3, 5, 9}));
    cmd.add_option("--patch-order", o.patch_order,
                   "adaptive: interpolation inside a patch, per axis: 1 (default, linear between nodes) or 2 "
                   "(quadratic on consecutive node triples); overrides the spec's patch_order")
        ->check(CLI::IsMember({1, 2}));
    cmd.add_option("--refine-safety", o.safety,
                   "adaptive: a patch passes when its largest probe error is <= S x E (default 0.7 with "
                   "--patch-order 2, 0.5 with 1; docs/adaptive.md, \"Refinement\")")
        ->check(CLI::Range(0.01, 1.0));
    cmd.add_option("--breakpoint", o.breakpoints,
                   "adaptive: NAME=X puts patch faces on X of axis NAME (a known kink; repeatable). "
                   "A critical axis gets one on its critical node by itself. Replaces the spec's breakpoints");
    cmd.add_option("--jump", o.jumps,
                   "adaptive: NAME=X, a known jump of the function at X of axis NAME: no continuity "
                   "across it, each side keeps its own values (repeatable; replaces the spec's jumps)");
    cmd.add_option("--initial-level", o.initial_levels,
                   "adaptive: NAME=L starts with 2^L patches along axis NAME (default 0; repeatable; wins over "
                   "the spec's initial_level for that axis)");
}

namespace {

// The checkpoint key of an adaptive run: the tensor one's settings and every
// option that changes the refinement.
CheckpointKey adaptive_checkpoint_key(const Spec& spec, const IntegrationSettings& settings, const Backend& backend,
                                      const ComputeOptions& compute, double accuracy, bool absolute,
                                      const std::vector<AdaptiveGenerateOptions>& per_table) {
    CheckpointKey key = checkpoint_key(spec, settings, backend, compute.kernel_dir);
    auto exact = [](double v) {  // the shortest text that reads back as v
        char b[40];
        for (int digits = 1; digits <= 17; ++digits) {
            std::snprintf(b, sizeof b, "%.*g", digits, v);
            if (std::strtod(b, nullptr) == v) break;
        }
        return std::string(b);
    };
    std::ostringstream a;
    a << "accuracy " << exact(accuracy) << (absolute ? " absolute" : " relative") << " floor " << exact(compute.abs_floor);
    // Each table's resolved settings (spec keys and options together).
    for (std::size_t i = 0; i < per_table.size(); ++i) {
        const AdaptiveBuildOptions& b = per_table[i].build;
        a << " | table " << spec.tables[i].name << " max_values " << b.max_values << " patch_nodes " << b.patch_nodes
          << " patch_order " << b.patch_order << " safety " << exact(b.safety) << " initial_level";
        for (int l : b.initial_level) a << " " << l;
        for (const NamedBreakpoint& p : per_table[i].breakpoints)
            a << (p.jump ? " jump " : " breakpoint ") << p.axis << "=" << exact(p.x);
    }
    key.settings.emplace_back("representation", "adaptive");
    key.settings.emplace_back("adaptive", a.str());
    return key;
}

// The run's processes: one, or the ranks of an MPI job.
struct AdaptiveRun {
#ifdef BRDFTAB_MPI
    std::unique_ptr<MpiSession> mpi;
#endif
    bool root() const {
#ifdef BRDFTAB_MPI
        return !mpi || mpi->rank() == 0;
#else
        return true;
#endif
    }
    // Rank 0's bytes on every rank.
    void share(std::string& bytes) const {
#ifdef BRDFTAB_MPI
        if (mpi) mpi->broadcast(bytes);
#else
        (void)bytes;
#endif
    }
    AdaptiveEstimator estimator(Backend& backend) const {
#ifdef BRDFTAB_MPI
        if (mpi && mpi->size() > 1)
            return [this, &backend](const ModelInfo& m, const QuantityInfo& q, const std::vector<int>& opts,
                                    const std::vector<double>& points, const IntegrationSettings& s) {
                return estimate_at_shared(*mpi, backend, m, q, opts, points, s);
            };
#endif
        (void)backend;
        return nullptr;
    }
};

std::string doubles_bytes(const std::vector<double>& v) {
    return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(double));
}

// Returns the first table whose certificate misses, "" when all pass (and
// on ranks other than 0).
std::string run_adaptive(const Spec& spec, const std::string& spec_path, const std::string& output, const ComputeOptions& compute,
                         double accuracy, bool absolute, bool quiet, const AdaptiveCliOptions& o,
                         const AdaptiveRun& run) {
    const bool root = run.root();
    if (!spec.recombined.empty() || !spec.errors.empty() || !spec.inverted.empty())
        throw InputError(spec_path + ": --representation adaptive does not handle [[recombined]], [[errors]] "
                         "or [[inverted]] tables; generate a copy of the spec without them");
    const std::string out_path = output.empty() ? spec.output.path : output;
    std::unique_ptr<OutputLock> lock;
    if (root) {
        check_output_writable(out_path);
        lock = std::make_unique<OutputLock>(out_path);
    }
    const IntegrationSettings settings = compute.apply(spec.integration);
    check_settings(settings);
    auto backend = compute.make_backend();
    if (root)
        std::cerr << "brdftab: " << spec.model << ", " << spec.tables.size() << " adaptive table(s) from "
                  << spec_path << " on " << backend->device_name() << ", target max "
                  << (absolute ? "absolute" : "relative") << " error " << sci_text(accuracy) << "\n";

    // Every table's options: the defaults, [adaptive], the table's own
    // `adaptive`, then the command line (adaptive_generate_options).
    const AdaptiveSpecSettings cli = o.overrides();
    std::vector<AdaptiveGenerateOptions> per_table;
    for (std::size_t i = 0; i < spec.tables.size(); ++i) {
        AdaptiveGenerateOptions tgo = adaptive_generate_options(spec, i, cli, accuracy, absolute, compute.abs_floor);
        if (o.safety > 0) tgo.build.safety = o.safety;
        tgo.estimator = run.estimator(*backend);
        per_table.push_back(std::move(tgo));
    }

    // The checkpoint of the refinement rounds (rank 0's; the others get the
    // logs from it).  An older one is left alone without --resume.
    std::unique_ptr<Checkpoint> checkpoint;
    bool checkpoint_is_new = false;
    std::string use_checkpoint = "0";
    if (root) {
        const CheckpointPresence presence = checkpoint_presence(out_path);
        if (presence != CheckpointPresence::None && !o.resume) {
            std::cerr << "brdftab: a checkpoint of "
                      << (presence == CheckpointPresence::InUse ? "a running" : "an interrupted")
                      << " run exists (" << checkpoint_directory(out_path)
                      << "); add --resume to continue it. This run starts from the beginning, "
                         "writes no checkpoint and leaves that one alone.\n";
        } else {
            checkpoint_is_new = presence == CheckpointPresence::None;
            checkpoint = std::make_unique<Checkpoint>(
                out_path, adaptive_checkpoint_key(spec, settings, *backend, compute, accuracy, absolute, per_table),
                o.resume && presence != CheckpointPresence::None, 0.0);
            if (o.resume && presence == CheckpointPresence::None)
                std::cerr << "brdftab: no checkpoint to resume from; starting from the beginning\n";
            else if (o.resume)
                std::cerr << "brdftab: resuming from " << checkpoint->directory() << ": "
                          << checkpoint->resumed_summary() << "\n";
            use_checkpoint = "1";
        }
    }
    run.share(use_checkpoint);
    const std::string fingerprint =
        adaptive_checkpoint_key(spec, settings, *backend, compute, accuracy, absolute, per_table).fingerprint();
    long stop_after = -1;  // the test hook (cli_adaptive.h)
    if (const char* hook = environment_setting("BRDFTAB_TEST_ADAPTIVE_STOP")) stop_after = std::atol(hook);
    long rounds_stored = 0;

    std::vector<AdaptiveTable> tables;
    std::vector<Certificate> certs;
    std::vector<double> predicted;  // the refinements' largest probe errors
    // An input error (a breakpoint on no axis, ...) removes the checkpoint
    // this run created: a resume would meet the same error.
    try {
        for (std::size_t i = 0; i < spec.tables.size(); ++i) {
            const TableSpec& ts = spec.tables[i];
            AdaptiveGenerateOptions tgo = per_table[i];
            if (root)
                std::cerr << "  " << ts.name << ": at most " << tgo.build.max_values << " values, "
                          << tgo.build.patch_nodes << "-node patches of order " << tgo.build.patch_order << "\n";
            AdaptiveCheckpoint ck;
            if (use_checkpoint == "1") {
                ck.fingerprint = fingerprint;
                if (root) ck.stored = checkpoint->adaptive_log(i);
                run.share(ck.stored);
                ck.save = [&, i](const std::string& log) {
                    if (root) checkpoint->store_adaptive_log(i, log);
                    // Rank 0 only stops (the others then end with it): a rank
                    // that stopped first could end the job before rank 0 stored.
                    if (root && stop_after >= 0 && ++rounds_stored >= stop_after)
                        throw Error("BRDFTAB_TEST_ADAPTIVE_STOP: stopped after " + std::to_string(rounds_stored) +
                                    " stored refinement round(s); the checkpoint is kept");
                };
                tgo.checkpoint = &ck;
            }
            const AdaptiveGenerated g = generate_adaptive(spec, i, *backend, settings, tgo, [&](const AdaptiveBuildReport& r) {
                if (!quiet && root)
                    std::cerr << "  " << ts.name << ": round " << r.rounds << ", " << r.leaves << " patches, " << r.values
                              << " nodes, " << r.evaluations << " evaluations, largest probe error "
                              << sci_text(r.estimated_max) << "\n";
            });
            if (root)
                std::cerr << "  " << ts.name << ": " << g.report.stored() << " values in " << g.report.leaves << " patches ("
                          << g.report.hanging_nodes << " hanging nodes, " << g.report.evaluations << " evaluations, " << format_seconds(g.seconds)
                          << (ck.replayed_rounds ? ", " + std::to_string(ck.replayed_rounds) + " round(s) from the checkpoint"
                                                 : std::string())
                          << ")" << (g.report.budget_hit ? ", value budget reached" : "") << "\n";
            tables.push_back(g.table);
            // Stored values keep the bits the accuracy needs (rounding error
            // <= 0.1 E, as generate --accuracy does), unless the spec rounds or
            // --full-precision keeps the stored type's own rounding.
            AdaptiveTable& stored = tables.back();
            if (!(stored.data.round_accuracy > 0) && !o.full_precision) {
                stored.data.round_accuracy = accuracy;
                stored.data.round_absolute = absolute;
            }
            predicted.push_back(g.report.estimated_max);
        }
    } catch (const InputError&) {
        if (checkpoint && checkpoint_is_new) checkpoint->remove();
        throw;
    }
    // Written whole to the temporary file, read back and certified there (so
    // the certificate includes the storage rounding), the certificates
    // added, then renamed: a failure leaves no partial output.  Under MPI the
    // other ranks certify rank 0's read-back values with it.
    std::unique_ptr<AtomicOutput> out;
    if (root) {
        out = std::make_unique<AtomicOutput>(out_path);
        write_table_file(out->path(), {}, tables);
    }
    const AdaptiveEstimator estimator = run.estimator(*backend);
    for (std::size_t i = 0; i < tables.size(); ++i) {
        const std::string& name = tables[i].data.name;
        CertifyOptions co;
        co.target = accuracy;
        co.absolute = absolute;
        if (compute.abs_floor > 0) co.abs_floor = compute.abs_floor;
        AdaptiveTable written = root ? read_adaptive_table(out->path(), name) : tables[i];
        std::string values = root ? doubles_bytes(written.data.value) : std::string();
        run.share(values);
        if (!root) {
            written.data.value.resize(values.size() / sizeof(double));
            std::memcpy(written.data.value.data(), values.data(), values.size());
        }
        Certificate c = certify_adaptive(written, *backend, co, nullptr, estimator);
        c.predicted_max = predicted[i];
        if (root)
            std::cerr << "  " << name << ": certificate max " << sci_text(c.max_error) << ", RMS "
                      << sci_text(c.rms_error) << " over " << c.probes << " probes: "
                      << (c.passed ? "passed" : "FAILED") << " (" << format_seconds(c.seconds) << ")\n";
        certs.push_back(c);
    }
    if (!root) return "";
    for (const Certificate& c : certs) write_certificate(out->path(), c);
    out->commit();
    if (checkpoint) {
        const std::string why = checkpoint->remove();
        if (!why.empty())
            std::cerr << "brdftab: warning: cannot remove the checkpoint " << checkpoint->directory() << ": " << why
                      << "\n";
    }
    std::cout << "wrote " << out_path << "\n";
    for (std::size_t i = 0; i < tables.size(); ++i)
        std::cout << "  " << tables[i].data.name << ": adaptive, " << tables[i].stored_count() << " values, "
                  << tables[i].layout.leaf_count() << " patches; certificate max " << sci_text(certs[i].max_error)
                  << (certs[i].passed ? " (passed)" : " (FAILED)") << "\n";
    for (const Certificate& c : certs)
        if (!c.passed) return c.table;
    return "";
}

}  // namespace

void run_adaptive_generate(const std::string& spec_path, const std::string& output,
                           const ComputeOptions& compute, std::optional<double> accuracy, bool absolute,
                           bool quiet, const AdaptiveCliOptions& o) {
    const Spec spec = parse_spec_file(spec_path);
    if (!accuracy) accuracy = spec.adaptive.accuracy;
    if (!accuracy)
        throw InputError("--representation adaptive needs --accuracy E (the refinement's target), or "
                         "[adaptive] accuracy = E in " + spec_path);
    if (!(*accuracy > 0) || !std::isfinite(*accuracy))
        throw InputError("--accuracy must be a positive number");
    if (!absolute && spec.adaptive.absolute) absolute = *spec.adaptive.absolute;
    AdaptiveRun run;
    std::string missed;
#ifdef BRDFTAB_MPI
    if (MpiSession::launched()) run.mpi = std::make_unique<MpiSession>();
    if (run.mpi && run.mpi->size() > 1) {
        // A failure on one rank ends the job: the others would wait for it
        // in the next shared engine run.  Rank 0 reports input errors (every
        // rank reads the same spec and options), the others their own trouble.
        try {
            missed = run_adaptive(spec, spec_path, output, compute, *accuracy, absolute, quiet, o, run);
        } catch (const std::exception& e) {
            const bool input = dynamic_cast<const InputError*>(&e) != nullptr;
            if (run.mpi->rank() == 0 || !input)
                std::cerr << "brdftab: " << (run.mpi->rank() ? "rank " + std::to_string(run.mpi->rank()) + ": " : "")
                          << "error: " << e.what() << std::endl;
            run.mpi->abort(input ? 2 : 1);
        }
        run.mpi->finalize();
    } else
#endif
        missed = run_adaptive(spec, spec_path, output, compute, *accuracy, absolute, quiet, o, run);
    if (!missed.empty()) throw Error("certificate of '" + missed + "' misses --accuracy " + sci_text(*accuracy));
}

AdaptiveSpecSettings AdaptiveCliOptions::overrides() const {
    AdaptiveSpecSettings s;
    s.max_values = max_values;
    s.patch_nodes = patch_nodes;
    s.patch_order = patch_order;
    for (const std::string& b : breakpoints) s.breakpoints.push_back(name_value(b, "--breakpoint"));
    for (const std::string& j : jumps) s.jumps.push_back(name_value(j, "--jump"));
    s.breakpoints_given = !breakpoints.empty();
    s.jumps_given = !jumps.empty();
    for (const std::string& l : initial_levels) {
        const auto [name, lv] = name_value(l, "--initial-level");
        if (lv < 0 || lv > 16 || lv != std::floor(lv))
            throw InputError("--initial-level '" + l + "': the level must be an integer in [0, 16]");
        s.initial_level[name] = int(lv);
    }
    return s;
}

std::string generate_representation(const std::string& spec_path, const AdaptiveCliOptions& o,
                                    bool accuracy_given) {
    if (!o.representation.empty()) return o.representation;
    // A spec that does not parse is reported by the path it then takes (the
    // tensor one reports once for all the ranks of an MPI job).
    std::optional<Spec> parsed;
    try {
        parsed = parse_spec_file(spec_path);
    } catch (const InputError&) {
        return accuracy_given ? "auto" : "tensor";
    }
    const Spec& spec = *parsed;
    if (spec.output.representation != "tensor") return spec.output.representation;
    // [output] representation = "tensor" written out, or left out: the
    // parser cannot tell them apart in the Spec, so read the key itself.
    if (spec.output.representation_given) return "tensor";
    return accuracy_given ? "auto" : "tensor";
}

bool choose_generate_adaptive(const std::string& spec_path, const ComputeOptions& compute,
                              std::optional<double>& accuracy, bool& absolute, bool cubic, bool quiet,
                              const AdaptiveCliOptions& o) {
    const Spec spec = parse_spec_file(spec_path);
    if (!accuracy) accuracy = spec.adaptive.accuracy;
    if (!accuracy)
        throw InputError("--representation auto needs --accuracy E, or [adaptive] accuracy = E in " + spec_path);
    if (!absolute && spec.adaptive.absolute) absolute = *spec.adaptive.absolute;
    const std::string what = "brdftab: representation: ";
    if (!spec.recombined.empty() || !spec.errors.empty() || !spec.inverted.empty()) {
        std::cerr << what << "tensor: adaptive tables do not handle the spec's [[recombined]], [[errors]] or "
                     "[[inverted]] tables\n";
        return false;
    }
    const AdaptiveSpecSettings cli = o.overrides();
    auto backend = compute.make_backend();
    PlanTarget target;
    target.accuracy = accuracy;
    target.absolute = absolute;
    target.interpolation = cubic ? Interpolation::Cubic : Interpolation::Linear;
    check_target(target);
    std::optional<Candidate> tensor;
    std::vector<TablePilot> pilots;
    std::string tensor_note;
    try {
        PilotOptions po;
        if (compute.abs_floor > 0) po.abs_floor = compute.abs_floor;
        for (std::size_t i = 0; i < spec.tables.size(); ++i) pilots.push_back(run_pilot(spec, i, *backend, po));
        const std::vector<Candidate> front = pareto_front(make_candidates(pilots, target));
        if (const std::optional<std::size_t> c = choose_plan(front, target)) tensor = front[*c];
    } catch (const InputError& e) {
        tensor_note = std::string(" (not planned: ") + e.what() + ")";
    }
    std::string tensor_text;
    if (tensor) {
        for (std::size_t i = 0; i < tensor->tables.size(); ++i) {
            tensor_text += (i ? "; " : "") + tensor->tables[i].table + " ";
            for (std::size_t a = 0; a < tensor->tables[i].counts.size(); ++a)
                tensor_text += (a ? "x" : "") + std::to_string(tensor->tables[i].counts[a]);
        }
        std::cerr << what << "tensor plan " << tensor_text << ": " << format_count(plan_cells(*tensor))
                  << " cells, predicted max error " << sci_text(tensor->error_max) << ", time "
                  << format_seconds(tensor->seconds) << "\n";
    } else {
        std::cerr << what << "no tensor plan is predicted to reach " << sci_text(*accuracy) << tensor_note << "\n";
    }
    const IntegrationSettings settings = compute.apply(spec.integration);
    check_settings(settings);
    AdaptivePlanOptions ao;
    if (tensor) ao.stop_values = plan_cells(*tensor);
    const AdaptivePlan ap = predict_adaptive_plan(
        spec, *backend, settings, cli, *accuracy, absolute, compute.abs_floor, ao,
        [&](const std::string& table, const AdaptivePilotRun& r) {
            if (!quiet)
                std::cerr << what << "adaptive pilot '" << table << "' at " << sci_text(r.target) << ": " << r.values
                          << " values" << (r.budget_hit ? " (budget reached)" : "") << ", "
                          << format_seconds(r.seconds) << "\n";
        });
    std::cerr << what << "adaptive plan: " << (ap.tables.front().lower_bound ? "at least " : "about ")
              << format_count(ap.values) << " values";
    for (const AdaptiveTablePrediction& t : ap.tables)
        std::cerr << (ap.tables.size() > 1 ? "; " + t.table + " " + format_count(t.values) : std::string())
                  << (t.lower_bound ? "" : " (values ~ E^-" + number_text(t.exponent, 3) + ")");
    std::cerr << ", predicted time " << format_seconds(ap.seconds) << " (pilots " << format_seconds(ap.pilot_seconds)
              << ")\n";
    const RepresentationChoice ch = choose_representation(tensor, &ap);
    std::cerr << what << (ch.any ? "chose " : "") << ch.why << "\n";
    return ch.any && ch.adaptive;
}

namespace {

std::string full(double v) {
    char b[40];
    std::snprintf(b, sizeof b, "%.17g", v);
    return b;
}

// The axis values of a point, in axis order, from names; out-of-range
// values clamped (a warning on stderr) or, with `reject`, refused.
std::vector<double> axis_values(const AdaptiveTable& t, const std::map<std::string, double>& named,
                                bool reject, const std::string& where) {
    std::vector<double> x;
    std::string names;
    for (const Axis& a : t.data.axes) names += (names.empty() ? "" : ", ") + a.name;
    for (const auto& [k, v] : named)
        if (std::none_of(t.data.axes.begin(), t.data.axes.end(), [&](const Axis& a) { return a.name == k; }))
            throw InputError(where + ": '" + k + "' is not a coordinate of table '" + t.data.name +
                             "' (coordinates: " + names + ")");
    for (const Axis& a : t.data.axes) {
        const auto it = named.find(a.name);
        if (it == named.end())
            throw InputError(where + ": missing coordinate '" + a.name + "' (table '" + t.data.name +
                             "' needs " + names + ")");
        const double lo = std::min(a.min, a.max), hi = std::max(a.min, a.max);
        double v = it->second;
        if (v < lo || v > hi) {
            if (reject)
                throw InputError(where + ": " + a.name + " = " + full(v) + " outside [" + full(lo) + ", " +
                                 full(hi) + "]");
            std::cerr << "warning: " << where << ": " << a.name << " = " << v << " clamped to [" << lo << ", "
                      << hi << "]\n";
            v = std::clamp(v, lo, hi);
        }
        x.push_back(v);
    }
    return x;
}

}  // namespace

void print_adaptive_summary(const AdaptiveTable& t, bool values) {
    const TableData& d = t.data;
    std::cout << "  " << d.name << ": " << d.model << " " << d.quantity << " [" << d.units << "], adaptive: "
              << t.stored_count() << " values in " << t.layout.leaf_count() << " patches of " << t.layout.patch_nodes
              << "^" << d.axes.size() << " nodes ("
              << (t.layout.patch_order == 2 ? "piecewise quadratic" : "multilinear") << "), " << method_attribute(d) << ", " << stored_type_name(d.stored_type)
              << ", " << t.layout.hanging_leaf.size() << " hanging nodes interpolated\n";
    for (std::size_t a = 0; a < d.axes.size(); ++a) {
        const Axis& ax = d.axes[a];
        std::cout << "    " << ax.name << " [" << ax.min << ", " << ax.max << "] " << ax.unit << ", warp "
                  << spacing_name(ax.spacing) << (ax.dependent() ? " (following " + ax.depends_on + ")" : "");
        if (a < t.breakpoints_t.size() && !t.breakpoints_t[a].empty()) {
            std::cout << ", faces at t =";
            for (std::size_t k = 0; k < t.breakpoints_t[a].size(); ++k)
                std::cout << " " << t.breakpoints_t[a][k]
                          << (k < t.breakpoint_jump[a].size() && t.breakpoint_jump[a][k] ? " (jump)" : "");
        }
        std::cout << "\n";
    }
    std::cout << "    refined for max " << (t.absolute ? "absolute" : "relative") << " error " << sci_text(t.target)
              << " (largest probe error at the end " << sci_text(t.estimated_max) << ")\n";
    if (values && !d.value.empty()) {
        const auto [lo, hi] = std::minmax_element(d.value.begin(), d.value.end());
        std::cout << "    values in [" << *lo << ", " << *hi << "]\n";
    }
}

void run_adaptive_query(const std::string& file, const std::string& table,
                        const std::map<std::string, double>& fixed, bool cubic, bool reject,
                        const std::string& points_file, const std::string& output, bool json) {
    if (cubic)
        throw InputError("table '" + table + "' of '" + file +
                         "' is adaptive: it interpolates with its own patches (no --cubic)");
    const AdaptiveTable t = read_adaptive_table(file, table);
    const char* interp = t.layout.patch_order == 2 ? "quadratic" : "linear";
    const std::optional<StoredCertificate> cert = read_stored_certificate(file, table);
    if (points_file.empty()) {
        const std::vector<double> x = axis_values(t, fixed, reject, "arguments");
        const double v = t.eval(x.data());
        if (json) {
            nlohmann::json j = {{"table", t.data.name}, {"model", t.data.model}, {"quantity", t.data.quantity},
                                {"value", v}, {"units", t.data.units}, {"interpolation", interp},
                                {"representation", "adaptive"}};
            if (cert)
                j["certified_error"] = {{"max", cert->max_error}, {"rms", cert->rms_error},
                                        {"measure", cert->absolute ? "absolute" : "relative"},
                                        {"abs_floor", cert->abs_floor}, {"interpolation", cert->interpolation},
                                        {"target", cert->target}, {"passed", cert->passed}};
            std::cout << j.dump() << "\n";
        } else {
            std::cout << t.data.name << " = " << full(v) << " [" << t.data.units << "] (" << interp << ", adaptive)";
            if (cert)
                std::cout << "; certified max total error " << sci_text(cert->max_error)
                          << (cert->absolute ? " absolute" : " relative") << (cert->passed ? "" : " (missed its target)");
            std::cout << "\n";
        }
        return;
    }
    std::ostringstream rows;
    PointFileRules rules;
    rules.unique_columns = true;
    rules.column_problem = [&](const std::string& h) {
        for (const Axis& a : t.data.axes)
            if (a.name == h) return std::string();
        return "is not a coordinate of table '" + table + "'";
    };
    rules.on_row = [&](const PointFile& pf, const PointRow& row) {
        const std::vector<double> x = axis_values(t, pf.named(row, fixed), reject, pf.where(row));
        for (const auto& cell : row.cells) rows << cell << ",";
        rows << full(t.eval(x.data())) << "\n";
    };
    const PointFile pf = read_point_file(points_file, rules);
    std::ostringstream csv;
    for (const auto& h : pf.header) csv << h << ",";
    csv << "value\n" << rows.str();
    if (output.empty()) {
        std::cout << csv.str();
    } else {
        write_text_atomically(output, csv.str());
        std::cerr << "wrote " << pf.rows.size() << " rows to " << output << "\n";
    }
}

}  // namespace brdftab::cli

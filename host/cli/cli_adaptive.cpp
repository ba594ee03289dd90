// cli_adaptive.cpp — `generate --representation adaptive` (cli_adaptive.h).
#include "host/cli/cli_adaptive.h"

#include <filesystem>
#include <iostream>

#include "host/adaptive/adaptive_generate.h"
#include "host/adaptive/adaptive_io.h"
#include "host/core/atomic_file.h"
#include "host/core/error.h"
#include "host/plan/certify.h"
#include "host/spec/spec.h"

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
                   "tensor (default: one grid per table) or adaptive (a k-d tree of small patches "
                   "refined where probes fail, docs/adaptive.md); adaptive needs --accuracy E")
        ->check(CLI::IsMember({"tensor", "adaptive"}));
    cmd.add_option("--max-values", o.max_values,
                   "adaptive: stored values per table at most (default 65536)")
        ->check(CLI::Range(std::size_t{2}, std::size_t{1} << 31));
    cmd.add_option("--patch-nodes", o.patch_nodes, "adaptive: nodes per axis of a patch: 3 (default), 5 or 9")
        ->check(CLI::IsMember({3, 5, 9}));
    cmd.add_option("--breakpoint", o.breakpoints,
                   "adaptive: NAME=X puts patch faces on X of axis NAME (a known kink; repeatable). "
                   "A critical axis gets one on its critical node by itself");
    cmd.add_option("--jump", o.jumps,
                   "adaptive: NAME=X, a known jump of the function at X of axis NAME: no continuity "
                   "across it, each side keeps its own values (repeatable)");
    cmd.add_option("--initial-level", o.initial_levels,
                   "adaptive: NAME=L starts with 2^L patches along axis NAME (default 0; repeatable)");
}

void run_adaptive_generate(const std::string& spec_path, const std::string& output,
                           const ComputeOptions& compute, std::optional<double> accuracy, bool absolute,
                           bool quiet, const AdaptiveCliOptions& o) {
    if (!accuracy) throw InputError("--representation adaptive needs --accuracy E (the refinement's target)");
    if (!(*accuracy > 0) || !std::isfinite(*accuracy))
        throw InputError("--accuracy must be a positive number");
    const Spec spec = parse_spec_file(spec_path);
    if (!spec.recombined.empty() || !spec.errors.empty() || !spec.inverted.empty())
        throw InputError(spec_path + ": --representation adaptive does not handle [[recombined]], [[errors]] "
                         "or [[inverted]] tables; generate a copy of the spec without them");
    const std::string out_path = output.empty() ? spec.output.path : output;
    check_output_writable(out_path);
    const OutputLock lock(out_path);
    const IntegrationSettings settings = compute.apply(spec.integration);
    check_settings(settings);
    auto backend = compute.make_backend();
    std::cerr << "brdftab: " << spec.model << ", " << spec.tables.size() << " adaptive table(s) from " << spec_path
              << " on " << backend->device_name() << ", target max " << (absolute ? "absolute" : "relative")
              << " error " << sci_text(*accuracy) << ", at most " << o.max_values << " values each\n";

    AdaptiveGenerateOptions go;
    go.build.target = *accuracy;
    go.build.absolute = absolute;
    if (compute.abs_floor > 0) go.build.floor = compute.abs_floor;
    go.build.max_values = o.max_values;
    go.build.patch_nodes = o.patch_nodes;
    for (const std::string& s : o.breakpoints) {
        const auto [name, x] = name_value(s, "--breakpoint");
        go.breakpoints.push_back({name, x, false});
    }
    for (const std::string& s : o.jumps) {
        const auto [name, x] = name_value(s, "--jump");
        go.breakpoints.push_back({name, x, true});
    }
    std::vector<AdaptiveTable> tables;
    std::vector<Certificate> certs;
    for (std::size_t i = 0; i < spec.tables.size(); ++i) {
        const TableSpec& ts = spec.tables[i];
        AdaptiveGenerateOptions tgo = go;
        tgo.build.initial_level.assign(ts.axes.size(), 0);
        for (const std::string& s : o.initial_levels) {
            const auto [name, lv] = name_value(s, "--initial-level");
            std::size_t a = 0;
            while (a < ts.axes.size() && ts.axes[a].name != name) ++a;
            if (a == ts.axes.size()) throw InputError("--initial-level '" + s + "': table '" + ts.name + "' has no axis '" + name + "'");
            if (lv < 0 || lv > 16 || lv != std::floor(lv))
                throw InputError("--initial-level '" + s + "': the level must be an integer in [0, 16]");
            tgo.build.initial_level[a] = int(lv);
        }
        const AdaptiveGenerated g = generate_adaptive(spec, i, *backend, settings, tgo, [&](const AdaptiveBuildReport& r) {
            if (!quiet)
                std::cerr << "  " << ts.name << ": round " << r.rounds << ", " << r.leaves << " patches, " << r.values
                          << " values, " << r.evaluations << " evaluations, largest probe error "
                          << sci_text(r.estimated_max) << "\n";
        });
        std::cerr << "  " << ts.name << ": " << g.report.values << " values in " << g.report.leaves << " patches ("
                  << g.report.evaluations << " evaluations, " << format_seconds(g.seconds) << ")"
                  << (g.report.budget_hit ? ", value budget reached" : "") << "; certifying\n";
        CertifyOptions co;
        co.target = *accuracy;
        co.absolute = absolute;
        if (compute.abs_floor > 0) co.abs_floor = compute.abs_floor;
        Certificate c = certify_adaptive(g.table, *backend, co);
        c.predicted_max = g.report.estimated_max;
        std::cerr << "  " << ts.name << ": certificate max " << sci_text(c.max_error) << ", RMS "
                  << sci_text(c.rms_error) << " over " << c.probes << " probes: "
                  << (c.passed ? "passed" : "FAILED") << " (" << format_seconds(c.seconds) << ")\n";
        tables.push_back(g.table);
        certs.push_back(c);
    }
    // Written whole, then the certificates added (to the temporary file),
    // then renamed: a failure leaves no partial output.
    AtomicOutput out(out_path);
    write_table_file(out.path(), {}, tables);
    for (const Certificate& c : certs) write_certificate(out.path(), c);
    out.commit();
    std::cout << "wrote " << out_path << "\n";
    for (std::size_t i = 0; i < tables.size(); ++i)
        std::cout << "  " << tables[i].data.name << ": adaptive, " << tables[i].value_count() << " values, "
                  << tables[i].layout.leaf_count() << " patches; certificate max " << sci_text(certs[i].max_error)
                  << (certs[i].passed ? " (passed)" : " (FAILED)") << "\n";
    for (const Certificate& c : certs)
        if (!c.passed) throw Error("certificate of '" + c.table + "' misses --accuracy " + sci_text(*accuracy));
}

}  // namespace brdftab::cli

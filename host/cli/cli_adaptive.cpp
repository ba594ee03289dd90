// cli_adaptive.cpp — `generate --representation adaptive` (cli_adaptive.h).
#include "host/cli/cli_adaptive.h"

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "host/adaptive/adaptive_generate.h"
#include "host/adaptive/adaptive_io.h"
#include "host/core/atomic_file.h"
#include "host/core/error.h"
#include "host/io/point_file.h"
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
    cmd.add_option("--patch-order", o.patch_order,
                   "adaptive: interpolation inside a patch, per axis: 1 (default, linear between nodes) or 2 "
                   "(quadratic on consecutive node triples)")
        ->check(CLI::IsMember({1, 2}));
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
    go.build.patch_order = o.patch_order;
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
    std::vector<double> predicted;  // the refinements' largest probe errors
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
                          << " nodes, " << r.evaluations << " evaluations, largest probe error "
                          << sci_text(r.estimated_max) << "\n";
        });
        std::cerr << "  " << ts.name << ": " << g.report.stored() << " values in " << g.report.leaves << " patches ("
                  << g.report.hanging_nodes << " hanging nodes, " << g.report.evaluations << " evaluations, " << format_seconds(g.seconds) << ")"
                  << (g.report.budget_hit ? ", value budget reached" : "") << "\n";
        tables.push_back(g.table);
        // Stored values keep the bits the accuracy needs (rounding error
        // <= 0.1 E, as generate --accuracy does), unless the spec rounds or
        // --full-precision keeps the stored type's own rounding.
        AdaptiveTable& stored = tables.back();
        if (!(stored.data.round_accuracy > 0) && !o.full_precision) {
            stored.data.round_accuracy = *accuracy;
            stored.data.round_absolute = absolute;
        }
        predicted.push_back(g.report.estimated_max);
    }
    // Written whole to the temporary file, read back and certified there (so
    // the certificate includes the storage rounding), the certificates
    // added, then renamed: a failure leaves no partial output.
    AtomicOutput out(out_path);
    write_table_file(out.path(), {}, tables);
    for (std::size_t i = 0; i < tables.size(); ++i) {
        const std::string& name = tables[i].data.name;
        CertifyOptions co;
        co.target = *accuracy;
        co.absolute = absolute;
        if (compute.abs_floor > 0) co.abs_floor = compute.abs_floor;
        Certificate c = certify_adaptive_file(out.path(), name, *backend, co);
        c.predicted_max = predicted[i];
        std::cerr << "  " << name << ": certificate max " << sci_text(c.max_error) << ", RMS "
                  << sci_text(c.rms_error) << " over " << c.probes << " probes: "
                  << (c.passed ? "passed" : "FAILED") << " (" << format_seconds(c.seconds) << ")\n";
        certs.push_back(c);
    }
    for (const Certificate& c : certs) write_certificate(out.path(), c);
    out.commit();
    std::cout << "wrote " << out_path << "\n";
    for (std::size_t i = 0; i < tables.size(); ++i)
        std::cout << "  " << tables[i].data.name << ": adaptive, " << tables[i].stored_count() << " values, "
                  << tables[i].layout.leaf_count() << " patches; certificate max " << sci_text(certs[i].max_error)
                  << (certs[i].passed ? " (passed)" : " (FAILED)") << "\n";
    for (const Certificate& c : certs)
        if (!c.passed) throw Error("certificate of '" + c.table + "' misses --accuracy " + sci_text(*accuracy));
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

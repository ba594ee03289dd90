// cmd_certify.cpp — `brdftab certify FILE --table T --accuracy E`: the
// certificate of `generate --accuracy` (host/plan/certify.h) for a table that
// already exists, e.g. one generated from a hand-written spec.  Read-only
// unless --store, which writes the certificate attributes into a copy of the
// file and renames it over the original only when that succeeded.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "host/adaptive/adaptive_io.h"
#include "host/cli/cli_common.h"
#include "host/cli/commands.h"
#include "host/core/atomic_file.h"
#include "host/core/error.h"
#include "host/io/table_io.h"
#include "host/plan/certify.h"
#include "host/plan/layout_certify.h"
#include "host/plan/plan.h"
#include "host/spec/spec.h"

namespace brdftab::cli {

namespace {

struct CertifyArgs {
    std::string file, table, interpolation = "linear", layout;
    double accuracy = 0, abs_floor = 0, reference_nodes = 0;
    bool absolute = false, store = false, quiet = false, no_advice = false;
    ComputeOptions compute;
};

// The axis whose lines carry the largest error ("" when the worst probe is
// off every line, i.e. between them).
std::string worst_axis(const Certificate& c) {
    std::size_t worst = c.axis_max.size();
    for (std::size_t a = 0; a < c.axis_max.size(); ++a)
        if (std::isfinite(c.axis_max[a]) && (worst == c.axis_max.size() || c.axis_max[a] > c.axis_max[worst]))
            worst = a;
    return worst < c.axis_names.size() ? c.axis_names[worst] : std::string();
}

// After a missed target: which axis is responsible, and the plan the
// planner predicts would pass: a pilot of the table's own spec (stored in
// the file), its error model corrected by this certificate (as a refinement
// round of `generate --accuracy` corrects it), the fastest plan predicted to
// reach the target.  Printed to stdout; a step that cannot run says why.
void print_failure_advice(const Certificate& c, const CertifyArgs& st, Backend& backend) {
    std::cout << "  error along each axis (max over the probe lines along it):";
    for (std::size_t a = 0; a < c.axis_names.size() && a < c.axis_max.size(); ++a)
        std::cout << (a ? ", " : " ") << c.axis_names[a] << " " << sci_text(c.axis_max[a]);
    std::cout << "\n";
    const std::string axis = worst_axis(c);
    if (!axis.empty())
        std::cout << "  the axis responsible: " << axis << " (its lines reach "
                  << sci_text(*std::max_element(c.axis_max.begin(), c.axis_max.end())) << ", target "
                  << sci_text(c.target) << ")\n";
    const TableData d = read_table(st.file, st.table);
    const std::string options = std::string(" --accuracy ") + sci_text(st.accuracy) + (st.absolute ? " --abs" : "") +
                                (st.interpolation == "cubic" ? " --interpolation cubic" : "");
    if (d.spec_text.empty()) {
        std::cout << "  no spec stored with the table: plan one with `brdftab plan SPEC --table " << st.table << options
                  << "`\n";
        return;
    }
    const std::string spec_name = d.spec_file.empty() ? std::string("SPEC") : d.spec_file;
    try {
        const Spec spec = parse_spec_string(d.spec_text, st.file + " (stored spec " + spec_name + ")");
        std::size_t index = spec.tables.size();
        for (std::size_t i = 0; i < spec.tables.size(); ++i)
            if (spec.tables[i].name == st.table) index = i;
        if (index == spec.tables.size()) throw InputError("the stored spec has no table '" + st.table + "'");
        PlanTarget target;
        target.accuracy = st.accuracy;
        target.absolute = st.absolute;
        target.interpolation = c.interpolation;
        PilotOptions po;
        po.abs_floor = c.absolute ? 0 : c.abs_floor;
        std::vector<TablePilot> pilots = {run_pilot(spec, index, backend, po)};
        std::string why;
        if (const std::optional<Candidate> as_is = predict_as_written(spec, pilots, target, {}, why))
            correct_error_model(pilots, target, *as_is, {&c});
        const std::vector<Candidate> front = pareto_front(make_candidates(pilots, target));
        const std::optional<std::size_t> choice = choose_plan(front, target);
        if (!choice) {
            std::cout << "  no plan the planner considers is predicted to reach " << sci_text(st.accuracy)
                      << " on this table's domain (up to 65536 nodes per axis); relax the target or narrow the "
                         "axes' ranges\n";
            return;
        }
        const Candidate& plan = front[*choice];
        std::cout << "  a plan predicted to pass (the planner's pilot of this table, corrected by this "
                     "certificate): nodes ";
        for (std::size_t a = 0; a < plan.tables[0].counts.size(); ++a)
            std::cout << (a ? " x " : "") << pilots[0].axes[a].name << " " << plan.tables[0].counts[a];
        std::cout << " (now";
        for (std::size_t a = 0; a < d.axes.size(); ++a) std::cout << (a ? " x " : " ") << d.axes[a].count;
        std::cout << "), " << to_string(plan.method) << (plan.samples ? " " + std::to_string(plan.samples) : "")
                  << ", " << stored_type_name(plan.stored_type) << "; predicted max total error "
                  << sci_text(plan.error_max) << ", generation about " << format_seconds(plan.seconds) << "\n";
        std::cout << "  plan and verify it: brdftab plan " << spec_name << " --table " << st.table << options
                  << "\n";
    } catch (const std::exception& e) {
        std::cout << "  no plan suggested: " << e.what() << "\n";
    }
}

// "a,b" -> {a, b}.
std::vector<std::string> split_list(const std::string& s) {
    std::vector<std::string> out;
    for (std::size_t start = 0;;) {
        const std::size_t c = s.find(',', start);
        out.push_back(s.substr(start, c == std::string::npos ? std::string::npos : c - start));
        if (c == std::string::npos) return out;
        start = c + 1;
    }
}

// --layout: the certificate in a renderer's own interpolation (layout_certify.h),
// of each table of a comma-separated --table list, on one device.
void run_layout_certify(const CertifyArgs& st) {
    auto backend = st.compute.make_backend();
    std::vector<LayoutCertificate> done;
    for (const std::string& table : split_list(st.table)) {
        std::unique_ptr<ProgressPrinter> printer;
        if (!st.quiet) printer = std::make_unique<ProgressPrinter>("certify " + table + " (" + st.layout + ")");
        done.push_back(certify_layout(read_table(st.file, table), parse_renderer_layout(st.layout), *backend,
                                      st.reference_nodes, [&](const Progress& p) { if (printer) (*printer)(p); }));
        if (printer) printer->finish();
        std::cout << st.file << " table " << table << " in " << st.layout
                  << "'s interpolation: " << layout_certificate_text(done.back()) << ", "
                  << sci_text(done.back().seconds) << " s\n";
    }
    if (st.store) {
        AtomicOutput out(st.file);
        std::filesystem::copy_file(st.file, out.path(), std::filesystem::copy_options::overwrite_existing);
        for (const LayoutCertificate& c : done) write_layout_certificate(out.path(), c);
        out.commit();
        std::cout << "stored the certificate" << (done.size() > 1 ? "s" : "") << " in " << st.file << "\n";
    }
}

void run_certify(const CertifyArgs& st) {
    if (!st.layout.empty()) return run_layout_certify(st);
    if (st.accuracy == 0) throw InputError("certify needs --accuracy E (or --layout cycles|filament|ue4)");
    if (!(st.accuracy > 0) || !std::isfinite(st.accuracy))
        throw InputError("--accuracy must be a finite number > 0 (got " + sci_text(st.accuracy) + ")");
    if (st.abs_floor < 0 || !std::isfinite(st.abs_floor))
        throw InputError("--abs-floor must be a finite number >= 0");
    if (!std::filesystem::is_regular_file(st.file)) throw InputError(st.file + ": no such file");
    CertifyOptions o;
    o.target = st.accuracy;
    o.absolute = st.absolute;
    o.abs_floor = st.abs_floor;
    o.interpolation = st.interpolation == "cubic" ? Interpolation::Cubic : Interpolation::Linear;
    auto backend = st.compute.make_backend();
    std::unique_ptr<ProgressPrinter> printer;
    if (!st.quiet) printer = std::make_unique<ProgressPrinter>("certify " + st.table);
    const ProgressFn progress = [&](const Progress& p) {
        if (printer) (*printer)(p);
    };
    const Certificate c = certify_file_table(st.file, st.table, *backend, o, progress);
    if (printer) printer->finish();
    std::cout << st.file << " table " << c.table << ": certificate " << (c.passed ? "passed" : "FAILED")
              << ": " << certificate_error_text(c) << "; " << c.probes << " probes, " << st.interpolation << " interpolation";
    if (!c.absolute) std::cout << ", floor " << sci_text(c.abs_floor);
    std::cout << ", reference " << c.reference_method;
    if (c.reference_noise > 0) std::cout << " (noise " << sci_text(c.reference_noise) << ")";
    std::cout << ", " << sci_text(c.seconds) << " s\n";
    if (st.store) {
        AtomicOutput out(st.file);
        std::filesystem::copy_file(st.file, out.path(), std::filesystem::copy_options::overwrite_existing);
        write_certificate(out.path(), c);
        out.commit();
        std::cout << "stored the certificate in " << st.file << "\n";
    }
    // The advice plans a tensor table; an adaptive one is refined by generate.
    if (!c.passed && !st.no_advice && !is_adaptive_table(st.file, st.table)) print_failure_advice(c, st, *backend);
    if (!c.passed)
        throw Error("the certificate missed --accuracy " + sci_text(st.accuracy) + ": max total error " +
                    sci_text(c.max_error));
}

}  // namespace

void register_certify(CLI::App& app) {
    auto* cmd = app.add_subcommand(
        "certify",
        "measure a written table's total error between nodes (what a renderer sees: interpolation "
        "+ integration + storage) with off-grid probes against direct evaluation, and compare it "
        "with a target; exit code 1 when it misses (docs/planning.md, \"Certified generation\")");
    auto st = std::make_shared<CertifyArgs>();
    cmd->add_option("FILE", st->file, "table file (HDF5)")->required();
    cmd->add_option("--table", st->table, "table (group) name in FILE (with --layout: a comma-separated list)")
        ->required();
    auto* accuracy = cmd->add_option("--accuracy", st->accuracy,
                                     "the target E: max total error, relative to max(|value|, floor) by "
                                     "default, absolute with --abs");
    cmd->add_option("--layout", st->layout,
                    "instead: measure the error in a renderer's own interpolation (cycles, filament, ue4: "
                    "its node coordinates, multilinear; docs/renderer-luts.md)")
        ->check(CLI::IsMember({"cycles", "filament", "ue4"}))
        ->excludes(accuracy);
    cmd->add_option("--reference-nodes", st->reference_nodes,
                    "with --layout: quadrature nodes of the direct values (default: the table's own)");
    cmd->add_flag("--abs", st->absolute, "absolute errors (default: relative)");
    cmd->add_option("--abs-floor", st->abs_floor,
                    "relative errors divide by max(|value|, floor); default 1e-3 x the table's "
                    "largest |value|");
    cmd->add_option("--interpolation", st->interpolation,
                    "the interpolation a renderer reads the table with: linear (default) or cubic")
        ->check(CLI::IsMember({"linear", "cubic"}));
    cmd->add_flag("--store", st->store,
                  "write the certificate into FILE's table attributes (certificate_*, "
                  "docs/format.md); the file is replaced only when that succeeded");
    cmd->add_flag("--no-advice", st->no_advice,
                  "on a miss, skip the advice (the axis responsible and the plan predicted to pass, "
                  "from a planner pilot of the table's stored spec: a few seconds)");
    cmd->add_flag("-q,--quiet", st->quiet, "no progress display");
    st->compute.add_to(*cmd, false);
    cmd->callback([st] { run_certify(*st); });
}

}  // namespace brdftab::cli

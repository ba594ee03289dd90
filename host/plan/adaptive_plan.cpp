// adaptive_plan.cpp — adaptive plans predicted from pilot refinements, and the
// choice of representation (adaptive_plan.h).
#include "host/plan/adaptive_plan.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "host/core/error.h"
#include "host/core/text.h"
#include "host/plan/certify.h"

namespace brdftab {

namespace {

std::string sci(double v) { return scientific_text(v, 3); }

std::string count_text(double v) {
    std::ostringstream s;
    s.precision(0);
    s << std::fixed << v;
    return s.str();
}

}  // namespace

AdaptiveGenerateOptions adaptive_generate_options(const Spec& spec, std::size_t table,
                                                  const AdaptiveSpecSettings& cli, double accuracy,
                                                  bool absolute, double abs_floor) {
    const TableSpec& ts = spec.tables.at(table);
    const AdaptiveSpecSettings* layers[] = {&spec.adaptive, &ts.adaptive, &cli};
    AdaptiveGenerateOptions go;
    go.build.target = accuracy;
    go.build.absolute = absolute;
    if (abs_floor > 0) go.build.floor = abs_floor;
    go.build.max_values = kAdaptiveDefaultMaxValues;
    go.build.patch_nodes = 3;
    go.build.patch_order = 1;
    go.build.initial_level.assign(ts.axes.size(), 0);
    const std::vector<std::pair<std::string, double>>*breaks = nullptr, *jumps = nullptr;
    for (const AdaptiveSpecSettings* s : layers) {
        if (s->max_values) go.build.max_values = *s->max_values;
        if (s->patch_nodes) go.build.patch_nodes = *s->patch_nodes;
        if (s->patch_order) go.build.patch_order = *s->patch_order;
        if (s->breakpoints_given) breaks = &s->breakpoints;
        if (s->jumps_given) jumps = &s->jumps;
        for (const auto& [name, level] : s->initial_level) {
            std::size_t a = 0;
            while (a < ts.axes.size() && ts.axes[a].name != name) ++a;
            // [adaptive] may name an axis of another table only.
            if (a == ts.axes.size()) {
                if (s == &cli)
                    throw InputError("--initial-level " + name + "=" + std::to_string(level) + ": table '" + ts.name +
                                     "' has no axis '" + name + "'");
                continue;
            }
            go.build.initial_level[a] = level;
        }
    }
    auto has_axis = [&](const std::string& name) {
        return std::any_of(ts.axes.begin(), ts.axes.end(), [&](const Axis& a) { return a.name == name; });
    };
    // Spec-level positions apply to the tables that have the axis; the
    // command line's to every table (generate_adaptive names a missing axis).
    auto add = [&](const std::vector<std::pair<std::string, double>>* list, bool jump) {
        if (!list) return;
        for (const auto& [name, x] : *list)
            if (list == &cli.breakpoints || list == &cli.jumps || has_axis(name))
                go.breakpoints.push_back({name, x, jump});
    };
    add(breaks, false);
    add(jumps, true);
    // A leaf passes at probe error <= safety x E.  Measured (docs/adaptive.md,
    // "Refinement"): the certificate lands at up to 1.26 x safety x E with
    // order 2 and 1.48 x with order 1.
    go.build.safety = go.build.patch_order == 2 ? 0.7 : 0.5;
    return go;
}

AdaptiveTablePrediction extrapolate_adaptive(const std::string& table, const std::vector<AdaptivePilotRun>& runs,
                                             double accuracy, std::size_t max_values,
                                             const AdaptivePlanOptions& options) {
    AdaptiveTablePrediction p;
    p.table = table;
    p.runs = runs;
    p.max_values = max_values;
    if (runs.empty()) return p;
    // p: least squares of log values on log target over the runs (every
    // run: the loosest alone are pre-asymptotic, the tightest alone noisy),
    // anchored at the tightest run.
    const AdaptivePilotRun& last = runs.back();
    std::vector<double> x, y;
    for (const AdaptivePilotRun& r : runs) {
        x.push_back(r.target);
        y.push_back(double(r.values));
    }
    const PowerFit fit = fit_power_law(x, y);
    double exponent = fit.valid ? -fit.p : options.min_exponent;
    exponent = std::clamp(exponent, options.min_exponent, options.max_exponent);
    p.exponent = exponent;
    const double scale = last.target > accuracy ? std::pow(last.target / accuracy, exponent) : 1.0;
    p.values = double(last.values) * scale;
    p.evaluations = double(last.evaluations) * scale;
    p.seconds = last.seconds * scale;
    // A pilot that stopped at its budget already: the table at E would too.
    p.within_budget = !last.budget_hit && p.values <= double(max_values);
    return p;
}

AdaptivePlan predict_adaptive_plan(const Spec& spec, Backend& backend, const IntegrationSettings& settings,
                                   const AdaptiveSpecSettings& cli, double accuracy, bool absolute,
                                   double abs_floor, const AdaptivePlanOptions& options,
                                   const AdaptivePilotProgressFn& progress) {
    if (!spec.recombined.empty() || !spec.errors.empty() || !spec.inverted.empty())
        throw InputError(spec.file + ": adaptive tables do not handle [[recombined]], [[errors]] or [[inverted]] "
                         "tables");
    if (!(accuracy > 0) || !std::isfinite(accuracy)) throw InputError("the adaptive plan needs an accuracy > 0");
    AdaptivePlan plan;
    plan.accuracy = accuracy;
    plan.absolute = absolute;
    plan.error_max = accuracy;
    const std::size_t n = spec.tables.size();
    std::vector<std::vector<AdaptivePilotRun>> runs(n);
    std::vector<std::size_t> budgets(n);
    std::vector<double> factors = options.factors;
    std::sort(factors.begin(), factors.end(), std::greater<double>());
    bool stopped = false;
    for (std::size_t f = 0; f < factors.size() && !stopped; ++f) {
        double values = 0;
        for (std::size_t i = 0; i < n; ++i) {
            const double target = factors[f] * accuracy;
            AdaptiveGenerateOptions go = adaptive_generate_options(spec, i, cli, target, absolute, abs_floor);
            budgets[i] = go.build.max_values;
            const AdaptiveGenerated g = generate_adaptive(spec, i, backend, settings, go);
            AdaptivePilotRun r;
            r.target = target;
            r.values = g.report.stored();  // hanging nodes are not stored
            r.evaluations = g.report.evaluations;
            r.leaves = g.report.leaves;
            r.seconds = g.seconds;
            r.estimated_max = g.report.estimated_max;
            r.budget_hit = g.report.budget_hit;
            plan.pilot_seconds += g.seconds;
            runs[i].push_back(r);
            values += double(r.values);
            if (progress) progress(spec.tables[i].name, r);
        }
        // Values only grow as the target tightens: past the bound, or at a
        // table's budget, a tighter pilot tells nothing the choice needs.
        const bool at_budget = std::any_of(runs.begin(), runs.end(), [](const auto& r) { return r.back().budget_hit; });
        if (f + 1 < factors.size() && ((options.stop_values > 0 && values >= options.stop_values) || at_budget))
            stopped = true;
    }
    plan.meets = true;
    for (std::size_t i = 0; i < n; ++i) {
        AdaptiveTablePrediction t = extrapolate_adaptive(spec.tables[i].name, runs[i], accuracy, budgets[i], options);
        t.lower_bound = stopped;
        if (stopped) {  // the last run's values: the table at E stores at least as many
            const AdaptivePilotRun& last = runs[i].back();
            t.values = double(last.values);
            t.evaluations = double(last.evaluations);
            t.seconds = last.seconds;
        }
        plan.values += t.values;
        plan.seconds += t.seconds;
        if (!t.within_budget) {
            plan.meets = false;
            plan.why += (plan.why.empty() ? "" : "; ") + std::string("table '") + t.table + "' needs about " +
                        count_text(t.values) + " values, above its max_values " + std::to_string(t.max_values) +
                        (t.runs.back().budget_hit ? " (its pilot at " + sci(t.runs.back().target) +
                                                        " stopped at the budget)"
                                                  : "");
        }
        plan.tables.push_back(std::move(t));
    }
    if (stopped && plan.meets) {
        plan.meets = false;
        plan.why = "the pilots at " + sci(factors.front() * accuracy) + " .. " + sci(plan.tables.front().runs.back().target) +
                   " already store " + count_text(plan.values) + " values, at least the tensor plan's " +
                   count_text(options.stop_values) + " cells: no tighter pilot was run";
    }
    return plan;
}

RepresentationChoice choose_representation(const std::optional<Candidate>& tensor, const AdaptivePlan* adaptive) {
    RepresentationChoice c;
    const bool a = adaptive && adaptive->meets;
    const double cells = tensor ? plan_cells(*tensor) : 0;
    if (!tensor && !a) {
        c.why = "neither a tensor nor an adaptive plan is predicted to meet the target" +
                (adaptive ? " (adaptive: " + adaptive->why + ")" : std::string());
        return c;
    }
    c.any = true;
    if (tensor && !a) {
        c.why = "tensor: " + count_text(cells) + " cells; " +
                (adaptive ? "the adaptive plan " + (adaptive->why.empty() ? std::string("does not meet the target")
                                                                          : "does not qualify: " + adaptive->why)
                          : std::string("no adaptive plan was predicted"));
        return c;
    }
    if (!tensor) {
        c.adaptive = true;
        c.why = "adaptive: about " + count_text(adaptive->values) +
                " values; no tensor plan is predicted to meet the target";
        return c;
    }
    c.adaptive = adaptive->values < cells;
    const double ratio = c.adaptive ? cells / adaptive->values : adaptive->values / cells;
    std::ostringstream s;
    s.precision(3);
    s << (c.adaptive ? "adaptive" : "tensor") << ": about " << count_text(adaptive->values)
      << " adaptive values against " << count_text(cells) << " tensor cells (" << ratio << "x "
      << (c.adaptive ? "fewer" : "more") << " values " << (c.adaptive ? "adaptive" : "for adaptive") << ")";
    c.why = s.str();
    return c;
}

std::string large_plan_warning(const Candidate& plan, const std::vector<TablePilot>& pilots) {
    const double cells = plan_cells(plan);
    if (!(cells > kLargePlanCells)) return "";
    std::size_t worst = 0;
    double worst_cells = -1;
    for (std::size_t i = 0; i < plan.tables.size(); ++i) {
        double c = 1;
        for (std::size_t n : plan.tables[i].counts) c *= double(n);
        if (c > worst_cells) worst_cells = c, worst = i;
    }
    const TablePlan& t = plan.tables[worst];
    std::size_t axis = 0;
    for (std::size_t a = 1; a < t.counts.size(); ++a)
        if (t.counts[a] > t.counts[axis]) axis = a;
    const std::string name = worst < pilots.size() && axis < pilots[worst].axes.size()
                                 ? pilots[worst].axes[axis].name
                                 : "#" + std::to_string(axis);
    std::string others;
    for (std::size_t a = 0; a < t.counts.size(); ++a) {
        if (a == axis) continue;
        const std::string an = worst < pilots.size() && a < pilots[worst].axes.size() ? pilots[worst].axes[a].name
                                                                                       : "#" + std::to_string(a);
        others += (others.empty() ? "" : ", ") + an + " " + std::to_string(t.counts[a]);
    }
    std::ostringstream s;
    s.precision(3);
    s << "the plan has " << cells << " cells, above 1e+08: table '" << t.table << "' holds " << worst_cells
      << " of them, and its axis '" << name << "' needs the most nodes (" << t.counts[axis]
      << (others.empty() ? "" : "; " + others) << "). A tensor grid pays for that axis' finest feature "
      << "everywhere; the adaptive representation (generate --representation adaptive, docs/adaptive.md) puts nodes "
         "only where the error needs them";
    return s.str();
}

std::string large_plan_warning(const Spec& spec) {
    Candidate c;
    std::vector<TablePilot> names;
    for (const TableSpec& ts : spec.tables) {
        TablePlan t;
        t.table = ts.name;
        for (const Axis& a : ts.axes) t.counts.push_back(a.count);
        c.tables.push_back(t);
        TablePilot p;
        p.axes = ts.axes;
        names.push_back(p);
    }
    return large_plan_warning(c, names);
}

}  // namespace brdftab

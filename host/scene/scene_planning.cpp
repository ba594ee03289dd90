// scene_planning.cpp — the planner's resolution for a scene table set.
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "host/core/text.h"
#include "host/core/error.h"
#include "host/lookup/lookup.h"
#include "host/plan/certify.h"
#include "host/plan/plan.h"
#include "host/scene/scene.h"
#include "host/spec/spec.h"

namespace brdftab {

namespace {
std::string sci(double v) { return scientific_text(v, 3); }
// The set's marginal cost per cell and fixed cost under a plan (the
// computed tables only: pilots[i] is c.tables[i]).
void record_cost(SceneTableSet& set, const std::vector<TablePilot>& pilots, const Candidate& c) {
    double cells = 0, work = 0, fixed = 0;
    for (std::size_t i = 0; i < pilots.size() && i < c.tables.size(); ++i) {
        const double f = pilots[i].startup_seconds + pilots[i].overhead_seconds;
        cells += c.tables[i].cells;
        work += std::max(0.0, c.tables[i].seconds - f);
        fixed += f;
    }
    set.seconds_per_cell = cells > 0 ? work / cells : 0;
    set.fixed_seconds = fixed;
}

// A closed-form set no joint plan reaches (one table with an unresolvable
// feature, e.g. the rough-dielectric transmission lobe's edge, a jump where
// the refraction half-vector reaches the horizon): each table planned on its
// own, node counts only (closed forms have no other spec-wide knob; stored
// as float32), and a table no plan reaches keeps its template counts.  False
// (nothing changed) when not a closed-form set or no table can be planned.
bool plan_tables_separately(SceneTableSet& set, const Spec& spec, const std::vector<TablePilot>& pilots,
                            const PlanTarget& target) {
    for (const TablePilot& p : pilots)
        if (p.kind != QuantityKind::ClosedForm) return false;
    Candidate combined;
    combined.method = Method::ClosedForm;
    combined.stored_type = StoredType::Float32;
    std::vector<std::size_t> indices;
    std::string kept;
    double planned_error = 0;
    std::size_t planned_tables = 0;
    for (std::size_t i = 0; i < pilots.size(); ++i) {
        indices.push_back(i);
        std::vector<Candidate> own;
        for (Candidate& c : make_candidates({pilots[i]}, target))
            if (c.stored_type == StoredType::Float32) own.push_back(std::move(c));
        const std::vector<Candidate> front = pareto_front(own);
        const std::optional<std::size_t> choice = choose_plan(front, target);
        if (choice) {
            combined.tables.push_back(front[*choice].tables.front());
            planned_error = std::max(planned_error, combined.tables.back().error_max);
            set.table_predicted_error[pilots[i].table] = combined.tables.back().error_max;
            ++planned_tables;
        } else {
            std::vector<std::size_t> counts;
            for (const Axis& a : pilots[i].axes) counts.push_back(a.count);
            combined.tables.push_back(
                predict_table(pilots[i], target, counts, Method::ClosedForm, 0, StoredType::Float32));
            double best = std::numeric_limits<double>::infinity();
            for (const Candidate& c : front) best = std::min(best, c.error_max);
            kept += (kept.empty() ? "" : "; ") + pilots[i].table + " (best plan predicts " + sci(best) + ")";
        }
        combined.seconds += combined.tables.back().seconds;
    }
    if (planned_tables == 0) return false;
    combined.error_max = planned_error;
    record_cost(set, pilots, combined);
    const std::vector<std::string> header = {
        "Planned table by table by `brdftab scene` for a max total relative error <= " +
        sci(*target.accuracy) + ": predicted max error " + sci(planned_error) +
        " for the planned tables; kept at the template: " + (kept.empty() ? "none" : kept)};
    set.spec_text = planned_spec_text(spec, indices, combined, header);
    set.planned = true;
    set.predicted_error = planned_error;
    set.predicted_seconds = combined.seconds;
    if (!kept.empty())
        set.plan_note = "planned table by table; no plan is predicted to reach a max relative error of " +
                        sci(*target.accuracy) + " for " + kept +
                        ": the template's node counts are kept there";
    return true;
}

}  // namespace

void plan_table_set(SceneTableSet& set, Backend& backend, double accuracy, double budget_seconds,
                    const std::function<void(const std::string&, const Progress&)>& progress) {
    const Spec spec = parse_spec_string(set.spec_text, "<scene table set " + set.id + ">");
    PlanTarget target;
    if (budget_seconds > 0)
        target.budget = budget_seconds;
    else
        target.accuracy = accuracy;
    check_target(target);
    // Albedos lie in [0, 1] and renderers use them for energy bookkeeping:
    // their error is relative to max(|value|, 1), i.e. absolute.  BSDF values
    // (1/sr, unbounded) keep the planner's default floor (1e-3 of the
    // largest value the pilot sees).
    PilotOptions options;
    if (set.purpose == "albedo") options.abs_floor = 1.0;
    std::vector<TablePilot> pilots;
    std::vector<std::size_t> indices;
    try {
        for (std::size_t i = 0; i < spec.tables.size(); ++i) {
            pilots.push_back(run_pilot(spec, i, backend, options, progress));
            indices.push_back(i);
        }
    } catch (const InputError& e) {
        set.plan_note = std::string("not planned (") + e.what() + "); the template is used";
        return;
    }
    // Recombined sets (Oren-Nayar's rho): the terms share one node layout and
    // the recombined table's error is bounded at the worst rho (host/plan).
    const std::vector<RecombinedGroup> groups = recombined_groups(spec, indices);
    const std::vector<Candidate> front =
        pareto_front(make_recombined_candidates(pilots, target, groups));
    const std::optional<std::size_t> choice = choose_plan(front, target);
    if (!choice && target.accuracy && groups.empty() && plan_tables_separately(set, spec, pilots, target))
        return;
    if (!choice) {
        double best = front.empty() ? 0 : front.front().error_max;
        for (const Candidate& c : front) best = std::min(best, c.error_max);
        set.plan_note = target.accuracy
                            ? "no plan is predicted to reach a max relative error of " +
                                  sci(accuracy) + " (the best predicts " + sci(best) +
                                  "); the template is used"
                            : "no plan is predicted to finish within " + sci(budget_seconds) +
                                  " s; the template is used";
        return;
    }
    const Candidate& c = front[*choice];
    const std::vector<std::string> header = {
        "Planned by `brdftab scene` for " +
        (target.accuracy ? "a max total relative error <= " + sci(accuracy)
                         : "a time budget of " + sci(budget_seconds) + " s") +
        ": predicted max error " + sci(c.error_max) + ", predicted time " + sci(c.seconds) + " s"};
    set.spec_text = planned_spec_text(spec, indices, c, header);
    set.planned = true;
    set.predicted_error = c.error_max;
    set.predicted_seconds = c.seconds;
    for (const TablePlan& t : c.tables) set.table_predicted_error[t.table] = t.error_max;
    record_cost(set, pilots, c);
}

void certify_table_set(SceneTableSet& set, const std::string& file, Backend& backend, double target,
                       const std::function<void(const std::string&, const Progress&)>& progress) {
    const Spec spec = parse_spec_string(set.spec_text, "<scene table set " + set.id + ">");
    CertifyOptions options;
    options.target = target;
    // As the planner's measure for the set: albedos absolute (floor 1).
    if (set.purpose == "albedo") options.abs_floor = 1.0;
    set.certificates.clear();
    std::map<std::string, SceneTableSet::TableCertificate> by_table;
    for (const TableSpec& ts : spec.tables) {
        ProgressFn stage;
        if (progress) stage = [&progress, name = ts.name](const Progress& p) { progress(name + ": certify", p); };
        const Certificate c = certify_file_table(file, ts.name, backend, options, stage);
        write_certificate(file, c);
        SceneTableSet::TableCertificate out;
        out.table = ts.name;
        out.max_error = c.max_error, out.rms_error = c.rms_error;
        out.target = target;
        out.floor = c.abs_floor;
        out.passed = c.passed;
        out.how = "measured";
        for (std::size_t a = 0; a < c.axis_names.size() && a < c.max_at.size(); ++a)
            out.max_at[c.axis_names[a]] = c.max_at[a];
        by_table[ts.name] = out;
        set.certificates.push_back(out);
    }
    // Recombined tables: the planner's bound with the certified term errors
    // in place of the predicted ones (same measure, same rules for signs and
    // floors), the terms' signs and largest values read from the file.
    std::vector<std::size_t> all(spec.tables.size());
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
    for (const RecombinedGroup& g : recombined_groups(spec, all)) {
        std::vector<TablePilot> pilots(spec.tables.size());
        std::vector<TablePlan> terms;
        for (std::size_t t : g.terms) {
            const TableData d = LookupTable::open(file, spec.tables[t].name).table();
            TablePilot& p = pilots[t];
            p.signed_min = d.value.empty() ? 0 : *std::min_element(d.value.begin(), d.value.end());
            for (double v : d.value) p.max_value = std::max(p.max_value, std::fabs(v));
            p.rel_floor = options.abs_floor > 0 ? options.abs_floor : options.rel_floor_factor * p.max_value;
            TablePlan tp;
            tp.table = spec.tables[t].name;
            tp.error_max = by_table[tp.table].max_error;
            terms.push_back(tp);
        }
        PlanTarget measure;  // relative with the floors above
        const TablePlan bound = predict_recombined(g, pilots, terms, measure);
        SceneTableSet::TableCertificate out;
        out.table = g.name;
        out.max_error = bound.error_max;
        out.target = target;
        out.passed = bound.error_max <= target;
        out.how = "bound from the terms' certificates";
        set.certificates.push_back(out);
    }
}

}  // namespace brdftab

// scene_planning.cpp — the planner's resolution for a scene table set.
#include <algorithm>
#include <cmath>
#include <sstream>

#include "host/core/error.h"
#include "host/plan/plan.h"
#include "host/scene/scene.h"
#include "host/spec/spec.h"

namespace brdftab {

namespace {
std::string sci(double v) {
    std::ostringstream s;
    s.precision(3);
    s << std::scientific << v;
    return s.str();
}
}  // namespace

void plan_table_set(SceneTableSet& set, Backend& backend, double accuracy, double budget_seconds,
                    const std::function<void(const std::string&, const Progress&)>& progress) {
    const Spec spec = parse_spec_string(set.spec_text, "<scene table set " + set.id + ">");
    if (!spec.recombined.empty()) {
        set.plan_note = "not planned: its tables are recombined (rho factored out), which needs "
                        "shared nodes the planner does not impose yet; the template is used";
        return;
    }
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
    const std::vector<Candidate> front = pareto_front(make_candidates(pilots, target));
    const std::optional<std::size_t> choice = choose_plan(front, target);
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
}

}  // namespace brdftab

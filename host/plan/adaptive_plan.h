// adaptive_plan.h — the planner's prediction of an adaptive plan and the
// choice between tensor and adaptive representations (docs/adaptive.md,
// "Choosing the representation").
//
// An adaptive table's size at a target E is not given by a per-axis fit: it
// depends on where the function is sharp.  The prediction therefore runs the
// real refinement (generate_adaptive) at a few looser targets f E (16E, 8E,
// 4E by default, loosest first), fits values(E') = c E'^-p per table by least
// squares over the runs, and extrapolates values, evaluations and time from
// the tightest run to E.
// The pilots are cheap next to the table itself: with p about 1 to 1.5 the
// three runs together make about a quarter of the values at E.
//
// Library code: no printing.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "host/adaptive/adaptive_generate.h"
#include "host/plan/plan.h"
#include "host/spec/spec.h"

namespace brdftab {

// ------------------------------------------------------------ settings

// Default adaptive settings (the command line's defaults, cli_adaptive.h).
constexpr std::size_t kAdaptiveDefaultMaxValues = 65536;

// The options of spec table `table` for generate_adaptive: the defaults,
// then [adaptive] (spec.adaptive), then the table's own `adaptive` key, then
// `cli` (each field given there wins; its breakpoints and jumps replace the
// spec's when given).  The target, its measure and floor are the caller's.
AdaptiveGenerateOptions adaptive_generate_options(const Spec& spec, std::size_t table,
                                                  const AdaptiveSpecSettings& cli, double accuracy,
                                                  bool absolute, double abs_floor);

// ------------------------------------------------------------ prediction

// One pilot refinement of one table.
struct AdaptivePilotRun {
    double target = 0;
    std::size_t values = 0, evaluations = 0, leaves = 0;
    double seconds = 0;
    double estimated_max = 0;  // largest probe error at the end
    bool budget_hit = false;
};

struct AdaptiveTablePrediction {
    std::string table;
    std::vector<AdaptivePilotRun> runs;  // loosest first
    double exponent = 0;                 // values ∝ target^-exponent
    double values = 0, evaluations = 0, seconds = 0;
    std::size_t max_values = 0;          // the table's budget
    bool within_budget = true;           // predicted values <= max_values
    // The pilots stopped before the tightest target (AdaptivePlanOptions::
    // stop_values): `values` is then a lower bound, that of the last run.
    bool lower_bound = false;
};

struct AdaptivePlan {
    double accuracy = 0;
    bool absolute = false;
    std::vector<AdaptiveTablePrediction> tables;
    double values = 0, seconds = 0;
    // The refinement's target: every leaf's probes end within 0.5 E, and the
    // certificate after generation measures the table against E.
    double error_max = 0;
    double pilot_seconds = 0;
    bool meets = false;      // every table predicted within its budget, no lower bound
    std::string why;         // when not `meets`
};

struct AdaptivePlanOptions {
    std::vector<double> factors = {16, 8, 4};  // pilot targets factor x E, loosest first
    // > 0: after a pilot target whose values (summed over the tables) reach
    // this many, no tighter target is run (values only grow as the target
    // tightens; the tensor plan's cells, when it meets E already).
    double stop_values = 0;
    double min_exponent = 0, max_exponent = 6;  // bounds of the fitted p
};

// The fit and extrapolation of one table's runs to `accuracy` (pure: the
// tests give it synthetic runs).  With two or more runs of distinct targets
// p is the least-squares slope of log values against log target (within the
// options' bounds); with one, p = the lower bound.  values(E) = values of the
// tightest run x (its target / E)^p; time and evaluations scale with the
// values, at the tightest run's ratios.
AdaptiveTablePrediction extrapolate_adaptive(const std::string& table, const std::vector<AdaptivePilotRun>& runs,
                                             double accuracy, std::size_t max_values,
                                             const AdaptivePlanOptions& options = {});

using AdaptivePilotProgressFn = std::function<void(const std::string& table, const AdaptivePilotRun&)>;

// Runs the pilots of every table of `spec` on `backend` and predicts the
// adaptive plan at `accuracy`.  Throws InputError for specs generate_adaptive
// cannot handle (derived tables), as run_adaptive_generate does.
AdaptivePlan predict_adaptive_plan(const Spec& spec, Backend& backend, const IntegrationSettings& settings,
                                   const AdaptiveSpecSettings& cli, double accuracy, bool absolute,
                                   double abs_floor, const AdaptivePlanOptions& options = {},
                                   const AdaptivePilotProgressFn& progress = nullptr);

// ------------------------------------------------------------ the choice

struct RepresentationChoice {
    bool adaptive = false;
    bool any = false;  // false: neither plan is predicted to meet the target
    std::string why;
};

// The plan that meets the target with fewer stored values: a tensor plan
// meets it when `tensor` is set (choose_plan found one); an adaptive plan
// when adaptive.meets.  Ties go to the tensor plan (its lookups are cheaper).
RepresentationChoice choose_representation(const std::optional<Candidate>& tensor, const AdaptivePlan* adaptive);

// ------------------------------------------------------------ large plans

// A plan above this many cells is flagged: `plan` warns, `scene` refuses it
// without --tabulate-closed-forms (docs/planning.md).
constexpr double kLargePlanCells = 1e8;

// Empty when the plan has at most kLargePlanCells cells; otherwise a sentence
// naming its cells, the table with the most and that table's axis with the
// most nodes (the one responsible; names from `pilots`, which hold the
// plan's computed tables in order), and suggesting the adaptive representation.
std::string large_plan_warning(const Candidate& plan, const std::vector<TablePilot>& pilots);
// The same for a spec's tables at their own node counts (a scene's sets).
std::string large_plan_warning(const Spec& spec);

}  // namespace brdftab

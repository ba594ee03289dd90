// plan.h — the speed/accuracy planner (`brdftab plan`, docs/planning.md).
//
// A table's total error between nodes, as a renderer sees it, is modelled as
//   total = interpolation + integration + storage rounding
// each measured by a cheap pilot on the chosen backend and extrapolated with
// a fitted convergence law:
//   interpolation  per axis a: E_a(h_a) = C_a h_a^p_a, h_a = 1/(count_a - 1)
//                  the node step in the axis' warped coordinate t;
//   integration    per cell: stderr(N) = c N^-q (q fitted for RQMC, 0.5 for
//                  MC); quadrature: the two-rule difference, no sample knob;
//   storage        float32: 2^-24 |value|, float16: 2^-11 |value| (with its
//                  subnormal and overflow limits), float64: 2^-53 |value|.
// The planner then enumerates candidate plans (nodes per axis balanced so
// each axis contributes the same predicted error, method, samples, stored
// type), predicts their error (max and RMS over the domain) and time, keeps
// the Pareto front and picks one for an accuracy target or a time budget.
// The chosen plan is written as a normal spec.
//
// Library code: no printing.  Pure pieces (fits, storage rounding, Pareto
// choice, 1-D probes) are separate so tests can check them on synthetic
// data with a known answer; certified generation (certify.h, generate
// --accuracy) calls make_pilot() / make_candidates() / choose_plan() directly.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/core/grid.h"
#include "host/core/table.h"
#include "host/engine/engine.h"
#include "host/lookup/lookup.h"
#include "host/plan/node_placement.h"
#include "host/spec/spec.h"

namespace brdftab {

// ------------------------------------------------------------ convergence fits

// y = c x^p fitted by least squares on (log x, log y).  Points with x <= 0 or
// y <= 0 (an exact interpolation, an error below the noise) are left out;
// with fewer than two usable points `valid` is false and c, p stay 0.
struct PowerFit {
    double c = 0, p = 0;
    bool valid = false;
    std::size_t points = 0;
    double eval(double x) const;  // c x^p (0 when not valid)
};
PowerFit fit_power_law(const std::vector<double>& x, const std::vector<double>& y);
// The same with the exponent fixed (e.g. q = 0.5 for plain Monte Carlo): c is
// the geometric mean of y / x^p.
PowerFit fit_power_law_fixed(const std::vector<double>& x, const std::vector<double>& y, double p);

// ------------------------------------------------------------ interpolation probes

// Where the probes sit inside each node interval, as fractions s of the step:
// 1/4, 1/2 and 3/4.  Midpoints alone would hide Catmull-Rom's leading error:
// at s = 1/2 its weights (-1, 9, 9, -1)/16 are those of the 4-point Lagrange
// cubic, whose error is O(h^4), while elsewhere in the interval the error is
// O(h^3) (docs/planning.md, tests/test_plan.cpp measure both).
inline constexpr double kProbeFractions[] = {0.25, 0.5, 0.75};

// The probe positions (warped coordinate t in [0, 1]) of an axis with `count`
// nodes: count - 1 intervals x kProbeFractions.
std::vector<double> probe_positions(std::size_t count);

// Interpolated values at `probes` (t values) of a 1-D table over `axis`
// (re-made with `count` nodes and the same spacing) whose node values are
// `node_values`, with the renderer-side library (host/lookup).
std::vector<double> interpolate_line(const Axis& axis, const std::vector<double>& node_values,
                                     const std::vector<double>& probes, Interpolation interp);

// Errors of one interpolation at one pilot resolution, over all probes.
struct LevelErrors {
    std::size_t count = 0;  // nodes
    double h = 0;           // 1 / (count - 1)
    double max_abs = 0, rms_abs = 0, max_rel = 0, rms_rel = 0;
    double noise = 0;       // largest reference stderr among the probes and nodes (0: closed form)
    // The same four measures with the pilot's noise taken out of each
    // probe's error d: sqrt(max(0, d^2 - sigma^2)), sigma^2 the probe's
    // stderr^2 plus the line's largest node stderr^2 (E[d^2] = e^2 + sigma^2):
    // what is left once the noise that the integration term already counts is
    // removed.  Used only where no fit exists (explicit axes, every level
    // below 3 x noise) and the level itself is noise_dominated(); equal to
    // the raw measures for closed forms and quadrature, and where the
    // integration pilot saw no variance (TablePilot::variance_unseen).
    double denoised_max_abs = 0, denoised_rms_abs = 0, denoised_max_rel = 0, denoised_rms_rel = 0;
};

// A level whose maximum error is below 3 x its reference's noise: what it
// measured is mostly that noise.  Such a level is left out of the fits
// (fit_axis), and where it is all an axis has, its noise-free measures
// stand for it (LevelErrors::denoised_*).
inline bool noise_dominated(const LevelErrors& l) { return l.noise > 0 && l.max_abs < 3 * l.noise; }

// The fitted interpolation error of one axis for one interpolation:
// error(h) = C h^p for each of the four measures.  A level whose maximum
// error is below 3 x its reference noise is left out of the fits.
struct AxisFit {
    std::string axis;
    bool planned = true;  // false: explicit axis, its nodes are kept
    std::vector<LevelErrors> levels;
    PowerFit max_abs, rms_abs, max_rel, rms_rel;
};

// Fits the four measures over the levels (noise rule above).  With
// max_exponent > 0, p is the slope between the two finest usable levels
// (the closest to the asymptotic regime; least squares over all levels is
// biased by the coarse, pre-asymptotic ones), capped (the interpolation's order:
// 2 for linear, 3 for Catmull-Rom), so that a pre-asymptotic steep decrease
// is not extrapolated beyond what the method can deliver.  C is then set so
// the law passes through the finest usable level: extrapolation starts from
// the best measurement, not from the coarse levels' average.
void fit_axis(AxisFit& fit, double max_exponent = 0);

// The median of the largest |error| over `cells` cells whose errors are
// independent normal with the standard deviations `sigma` (a sample of the
// table's cells, each standing for cells / sigma.size() of them): the x with
// prod_k (1 - erfc(x / (sigma_k sqrt 2)))^(cells / K) = 1/2.
double expected_max_error(const std::vector<double>& sigma, double cells);

// The exponent of `f` limited to [p_min, p_max] and its c re-anchored so
// that f(x_anchor) = y_anchor.
PowerFit anchored_fit(const PowerFit& f, double x_anchor, double y_anchor, double p_min, double p_max);

// --------------------------------------------------------------- storage rounding

// Worst-case rounding of a stored value v: |round(v) - v| <= max(rel |v|, abs)
// (round to nearest: half an ulp; float16 values below 2^-14 are subnormal,
// spaced 2^-24, so their error is at most abs = 2^-25).  `max_value` = largest finite
// stored magnitude (65504 for float16).
struct StorageRounding {
    double rel = 0, abs = 0, max_value = 0;
};
StorageRounding storage_rounding(StoredType type);

// --------------------------------------------------------------- pilot

// What the pilot measures for one computed table.
struct IntegrationFit {
    Method method = Method::ClosedForm;
    std::vector<std::uint64_t> samples;  // pilot budgets per cell
    std::vector<double> max_abs, rms_abs, max_rel, rms_rel;  // stderr over pilot cells, per budget
    std::vector<double> seconds;         // engine time per budget
    PowerFit fit_max_abs, fit_rms_abs, fit_max_rel, fit_rms_rel;  // stderr(N) = c N^-q
    // Per pilot cell at the largest budget (quadrature: its difference).
    std::vector<double> cell_abs, cell_rel;
    std::vector<double> cell_value;      // |value| per pilot cell (the adaptive prediction's targets)
    double seconds_per_sample = 0;       // from the largest budget
    double seconds_per_cell = 0;         // closed form / quadrature
    // PoCL's second kernel variant, for launches of kLargeGridWorkItems or
    // more (plan.cpp, large_grid_pilot): loading it in a fresh process (from
    // the cache the pilot's own large launch filled), and, for MC / RQMC,
    // the fixed cost of one work item beyond its samples (seconds_per_sample
    // comes from the pilot's work items of 128-4096 samples; 2 samples per
    // cell are 4 one-sample work items per cell).  0 where not measured (the
    // launch would have cost more than kLargeLaunchPilotSeconds).
    double large_grid_load_seconds = 0;
    double item_overhead_seconds = 0;
    bool large_grid_measured = false;
    // Quadrature: the node count of the finer rule the errors above were
    // measured against (the rule's own error); 0: they are the stored
    // two-rule difference (plan.cpp, finer_rule_nodes).
    double reference_nodes = 0;
};

struct TablePilot {
    std::string table, quantity;
    QuantityKind kind = QuantityKind::ClosedForm;
    std::vector<Axis> axes;        // as the spec has them
    double max_value = 0;          // largest |value| seen by the pilot
    std::map<std::string, double> max_at;  // where (model inputs); the floor hint of verify_plan
    double min_value = 0;          // smallest |value| seen by the pilot
    double signed_min = 0, signed_max = 0;  // smallest and largest value (signed): recombined bounds
    double rel_floor = 0;          // relative errors divide by max(|value|, rel_floor)
    std::vector<AxisFit> linear, cubic;  // per axis
    std::vector<IntegrationFit> integration;  // closed form: one entry with the cost per cell
    // A Monte Carlo budget of the integration pilot saw no variance in any
    // cell although the values are not all 0: too few events for the
    // stderrs to measure the noise (plan.cpp; the line errors keep it).
    bool variance_unseen = false;
    double overhead_seconds = 0;   // fixed cost of one engine run (one launch)
    double startup_seconds = 0;    // the first run: kernel build or cache load, which
                                   // a `generate` process pays again: part of the prediction
                                   // (with PilotOptions::fresh_backend: the cache load)
    double process_seconds = 0;    // PilotOptions::process_seconds, paid once per generate
    // The spec's [output] choices the write cost depends on (write_seconds).
    int compression = 6;
    bool keep_stderr = true;
    std::string kernel;  // model, quantity and options: with the method, the kernel program
    std::size_t preferred_slab = 1u << 17;  // the backend's largest launch (engine_launch_sizes)
    // Per axis: the finest level's lines (linear pilot), for --place-nodes
    // (node_placement.h); empty for explicit axes.
    std::vector<std::vector<PlacementLine>> placement_lines;
    double pilot_seconds = 0;      // wall time of this table's pilot
    std::size_t pilot_evaluations = 0;  // direct evaluations made
};

struct PilotOptions {
    std::size_t lines = 8;              // random lines per axis (other coordinates at nodes)
    // Base count of the levels b, 2b - 1, 4b - 3 at most (17, 33, 65 nodes):
    // pilot_counts(count, max_base).
    std::size_t max_base = 17;
    // Integrals pay reference_samples per probe: fewer lines and coarser
    // levels (base count at most 9: levels 9, 17, 33).
    std::size_t integral_lines = 4;
    std::size_t integral_max_base = 9;
    std::size_t cells = 32;             // random cells for the integration pilot
    std::uint64_t reference_samples = 1u << 14;  // per reference point of integrals
    std::vector<std::uint64_t> integration_samples = {1024, 4096, 16384};
    std::uint64_t seed = 1;
    // Relative errors divide by max(|value|, floor): abs_floor when > 0,
    // otherwise 1e-3 x the largest |value| the pilot saw (validate's default).
    double abs_floor = 0;
    double rel_floor_factor = 1e-3;
    // A `generate` run after `plan` finds the kernels in PoCL's disk cache,
    // which the pilot's first run filled: its startup is a cache load, not
    // the build the pilot's first run may have paid.  When set, the startup
    // is measured again on a fresh backend (a new context, so the process'
    // own program map misses and the disk cache answers).
    std::function<std::unique_ptr<Backend>()> fresh_backend;
    // Fixed cost of a generate process (device initialisation, measured by
    // the caller), added once per candidate plan.
    double process_seconds = 0;
};

// Progress of a pilot stage (the caller decides whether to show it).
using PilotProgressFn = std::function<void(const std::string& stage, const Progress&)>;

// The pilot counts of an axis with `count` nodes in the spec: three nested
// resolutions b, 2b - 1, 4b - 3 (halving h), b = clamp((count + 1) / 2, 4, max_base).
std::vector<std::size_t> pilot_counts(std::size_t count, std::size_t max_base = 17);

// Runs the pilot of spec table `table_index` on `backend`.  Throws InputError
// for tables the planner cannot handle.
TablePilot run_pilot(const Spec& spec, std::size_t table_index, Backend& backend,
                     const PilotOptions& options, const PilotProgressFn& progress = nullptr);

// --------------------------------------------------------------- cost model terms

// How `estimate` (host/engine/estimate.cpp) lays out a run of `samples` per cell
// (non-adaptive, or the first round of an adaptive one): work items per cell
// and samples per work item.  Closed form: 1 x 1; quadrature: 2 x 1 (the
// accurate and the coarse rule); MC: batches of min(N, 4096); RQMC: batches
// of floor_pow2(N / 8) within [1, 8192], at least 4 of them.
struct WorkShape {
    double items_per_cell = 1;
    double samples_per_item = 1;
};
WorkShape work_shape(Method method, std::uint64_t samples);

// The launch sizes (work items) `estimate` makes for `work_items` items of
// `seconds_per_item` each plus `seconds_per_launch`, with automatic slabs:
// the first 256, then each full launch resized towards 0.5 s (at most 4x up
// or down, whole multiples of 256, within [256, max_slab]).  Mirrors
// estimate.cpp's resize_slab; the sizes sum to work_items.  Once a full launch
// leaves the slab unchanged every later one does too: the count is then
// worked out, not simulated, so tables of 2^32 cells cost nothing to predict.
struct EngineLaunches {
    double count = 0;                 // launches
    std::size_t largest = 0;          // work items of the largest
    std::vector<std::size_t> first;   // the sizes of the first (up to 32) launches
};
EngineLaunches engine_launch_sizes(double work_items, double seconds_per_item, double seconds_per_launch,
                                   std::size_t max_slab);

// PoCL (CPU device) builds a kernel's work-group function for "small grids"
// and, at the first launch whose global size reaches this many work items
// (measured: 65472 small, 65536 not, in groups of 64), a second, general one:
// 2-8 s of compiling on the 2-core machine when its cache lacks it.
constexpr std::size_t kLargeGridWorkItems = 65536;
// Whether the largest launch's global size (rounded up to groups of 64, as
// estimate.cpp does) reaches kLargeGridWorkItems.
bool reaches_large_grid(const EngineLaunches& launches);

// Predicted seconds of one table's engine run (a non-adaptive `estimate`):
// the kernel load (startup), one run's overhead, the launches' work, and the
// large-grid variant's load when a launch reaches kLargeGridWorkItems.
// `large_grid`, when given, is set to whether the load was counted.
double engine_seconds(const TablePilot& pilot, const IntegrationFit& fit, double cells,
                      std::uint64_t samples, bool* large_grid = nullptr);

// Seconds to write one table of `cells` to HDF5 (host/io/table_io.cpp): the
// value dataset in the stored type, and for sampled and quadrature tables the
// stderr (same type, when kept) and samples (uint32) datasets, deflate +
// shuffle when compression > 0.  Per stored value, measured on the 2-core
// machine (docs/planning.md, "How good are the predictions").
double write_seconds(double cells, StoredType type, int compression, bool with_stderr, bool with_samples);

// Fixed cost of a `generate` process beyond its device set-up: exec, loading
// the libraries and exit, and creating, closing and renaming the output file.
double process_fixed_seconds();

struct TablePlan;
// One `generate` process builds (or loads) each kernel program once, however
// many tables run it, while each table's seconds count a load: of the tables
// with the same TablePlan::kernel, every load but the costliest is one too
// many.  Returns their sum (seconds), to subtract from the tables' sum.
double shared_kernel_saving(const std::vector<TablePlan>& tables);

// --------------------------------------------------------------- candidates

struct PlanTarget {
    bool absolute = false;        // errors are absolute (else relative with the floor)
    Interpolation interpolation = Interpolation::Linear;  // what the renderer uses
    std::optional<double> accuracy;  // E
    std::optional<double> budget;    // T, seconds
};

// Throws InputError: both given, E <= 0 or not finite, T <= 0 or not finite.
void check_target(const PlanTarget& target);

struct TablePlan {
    std::string table;
    std::vector<std::size_t> counts;  // per axis
    // Per axis: explicit nodes placed by --place-nodes (empty: the spec's
    // spacing with counts[a] nodes); planned_spec_text writes them.
    std::vector<std::vector<double>> explicit_values;
    double cells = 0;
    double interpolation_max = 0, interpolation_rms = 0;
    double integration_max = 0, integration_rms = 0;
    double storage_max = 0;
    double error_max = 0, error_rms = 0;
    double seconds = 0;
    // The kernel program the table runs (model, quantity, options, method)
    // and what loading it cost in `seconds`: tables of one process with the
    // same program load it once (shared_kernel_saving).
    std::string kernel;
    double kernel_load_seconds = 0, large_grid_load_seconds = 0;
};

struct Candidate {
    Method method = Method::ClosedForm;  // the spec-wide integration method (ClosedForm: none needed)
    std::uint64_t samples = 0;           // per cell; 0 = no sampling
    StoredType stored_type = StoredType::Float32;
    double interpolation_target = 0;     // the per-table interpolation error aimed at
    std::vector<TablePlan> tables;
    double error_max = 0, error_rms = 0;  // worst table
    double seconds = 0;                   // all tables
    double bytes = 0;                     // stored values
};

// Node counts of one table for an interpolation error `target` (max, in the
// target's measure), split evenly over the planned axes: count_a = 1 +
// ceil((C_a / (target / D))^(1 / p_a)), within [4, 65536]; axes with no
// valid fit keep their spec count.
std::vector<std::size_t> balanced_counts(const TablePilot& pilot, const PlanTarget& target,
                                         double interpolation_target);

// Predicted errors and time of one table under a plan.
TablePlan predict_table(const TablePilot& pilot, const PlanTarget& target,
                        const std::vector<std::size_t>& counts, Method method,
                        std::uint64_t samples, StoredType stored_type);

// The candidate set: interpolation targets 2^-1 .. 2^-26 (each a balanced
// node layout), for each the methods the pilots measured and sample budgets
// 2^8 .. 2^22 (powers of 4) for sampled methods, and float16 / float32.
// Candidates above 2^32 - 1 cells per table are left out.
std::vector<Candidate> make_candidates(const std::vector<TablePilot>& pilots,
                                       const PlanTarget& target);

// The candidates no other beats on all of (seconds, error_max, bytes),
// sorted by seconds.
std::vector<Candidate> pareto_front(const std::vector<Candidate>& candidates);

// The choice: with an accuracy E, the fastest candidate with error_max <= E
// (ties within 1 % of the time: fewer bytes, then smaller error); with a
// budget T, the smallest error_max among those with seconds <= T (ties: the
// faster).  nullopt when none qualifies or no target is set.
std::optional<std::size_t> choose_plan(const std::vector<Candidate>& candidates,
                                       const PlanTarget& target);

// --------------------------------------------------------------- recombined tables

// A [[recombined]] table R(x; p) = sum_t c_t(p) T_t(x) over piloted terms
// (Oren-Nayar's brdf = rho brdf_direct + rho^2 brdf_interreflection).
// Its terms must share one node layout, so a plan gives every term of a group
// the same counts: per axis the largest that any term needs.
struct RecombinedGroup {
    std::string name;
    std::vector<std::size_t> terms;           // indices into the pilots
    std::vector<std::vector<double>> coeffs;  // per term: coefficients of p^0, p^1, ...
    double lo = 1, hi = 1;                    // range of p the prediction covers
};

// The groups of spec.recombined whose terms are all among the piloted
// `table_indices` (pilots[k] is table table_indices[k]); p's range is the
// entry's `range`, else the model's range of that parameter, else stored_at.
// Throws InputError when the terms' axes differ in names, ranges or spacing.
std::vector<RecombinedGroup> recombined_groups(const Spec& spec,
                                               const std::vector<std::size_t>& table_indices);

// The shared layout: per axis the largest count of the group's terms.
std::vector<std::size_t> shared_counts(const RecombinedGroup& group,
                                       const std::vector<std::vector<std::size_t>>& counts);

// Predicted error of the recombined table from its terms' predictions
// (`term_plans[k]` for group.terms[k], all at the shared counts, predicted
// in the target's measure), at the worst p of the range (129 points and the
// ends):
//   absolute:  |dR| <= sum_t |c_t(p)| E_t   (triangle inequality);
//   relative:  when every c_t(p) >= 0 and every term >= 0 (the pilots' signed
//              values), R >= c_t T_t for each t, so
//              |dR| / R <= sum_t c_t e_t T_t / sum_t c_t T_t <= max_t e_t:
//              the largest term error, whatever p (values above the floor);
//              when the floor is at or above every term's values (albedos
//              with floor 1) the relative errors are absolute ones over one
//              floor and add as above.  Terms or coefficients of
//              mixed sign can cancel: no relative bound (infinite error,
//              the candidate is dropped; plan with --abs).
// Time is the terms' (the recombination itself is free); cells those of one term.
TablePlan predict_recombined(const RecombinedGroup& group, const std::vector<TablePilot>& pilots,
                             const std::vector<TablePlan>& term_plans, const PlanTarget& target);

// make_candidates() for specs with recombined tables: the same candidate
// set, with every group's terms on their shared layout; each candidate's
// tables are the pilots' (in order) followed by one entry per group (its
// counts the shared ones), and its error is the worst of all of them.
std::vector<Candidate> make_recombined_candidates(const std::vector<TablePilot>& pilots,
                                                  const PlanTarget& target,
                                                  const std::vector<RecombinedGroup>& groups);

// --------------------------------------------------------------- quadrature reference

struct ModelInfo;
struct QuantityInfo;

// A quadrature whose rule size the model exposes (a `nodes` parameter: the
// rough-dielectric albedos) is measured against a finer rule: twice the
// nodes, at least 24, within the parameter's range.  Returns that rule's
// node count, or 0 where there is none (not a quadrature, no such parameter
// or no `nodes` in `fixed`, or no finer rule in range).  The certificate's
// reference (certify.cpp) and the planner's pilot (plan.cpp) both use it.
double finer_rule_nodes(const ModelInfo& model, const QuantityInfo& quantity,
                        const std::map<std::string, double>& fixed);

// --------------------------------------------------------------- the spec as written

// The prediction for the spec's own plan, nothing chosen (`plan --as-written`,
// scripts/plan-check.py): every piloted table at its spec node counts, the
// spec's [integration] method (per table resolved as `generate` does it),
// samples (0: the engine's default 4096) and [output] type.  With a
// tolerance (adaptive sampling) each pilot cell is given the budget at which
// its fitted stderr(N) reaches max(tolerance |value|, abs_floor), within
// [samples, max_samples], and the time and errors follow from those budgets
// (predict_adaptive).  `why` is set and nullopt returned when a table's
// method was not piloted (e.g. rqmc asked of a quadrature quantity).
std::optional<Candidate> predict_as_written(const Spec& spec, const std::vector<TablePilot>& pilots,
                                            const PlanTarget& target,
                                            const std::vector<RecombinedGroup>& groups,
                                            std::string& why);

// --------------------------------------------------------------- output

// The spec text with the plan applied: every planned table gets its own
// [[tables.axes]] with the planned counts, [integration] gets the method and
// fixed `samples` (its `tolerance` removed), [output] gets the stored type
// (and spec.output's rounding, round_to_accuracy and round_measure, when set).
// Comments of the original are not kept (the TOML is re-serialised); every
// other key is.  `header` lines are prefixed with "# ".  The result parses
// with parse_spec_string.
std::string planned_spec_text(const Spec& spec, const std::vector<std::size_t>& table_indices,
                              const Candidate& plan, const std::vector<std::string>& header);

// The spec text for an adaptive plan (`plan -o` when the adaptive plan is
// chosen): the spec as it is, with [output] representation = "adaptive" and
// [adaptive] accuracy and measure set, so that a plain `generate` of it
// refines every table to `accuracy`.  Parses with parse_spec_string.
std::string adaptive_spec_text(const Spec& spec, double accuracy, bool absolute,
                               const std::vector<std::string>& header);

// JSON of pilots, candidates and choice (`brdftab plan --json`).
nlohmann::json pilot_json(const TablePilot& pilot);
nlohmann::json candidate_json(const Candidate& c, const std::vector<TablePilot>& pilots);

}  // namespace brdftab

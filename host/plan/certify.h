// certify.h — certified generation (`brdftab generate --accuracy E | --budget T`,
// docs/planning.md "Certified generation").
//
// A certificate is a measurement of a written table's total error, as a
// renderer sees it: the stored values (so storage rounding is included),
// interpolated with the renderer-side library (host/lookup) in the table's
// warped coordinates, against the model evaluated directly (closed form, or
// the quantity's default method with a reference quieter than the target) at
// off-grid probes.  Random points miss the worst places (the edges and the
// first nodes, docs/planning.md), so the probe set is:
//   - lines along every axis with the other coordinates at nodes (spread from
//     the first to the last node, so the domain's edges are among them),
//     probed at 1/4, 1/2 and 3/4 of every interval: the planner's own design;
//   - random points, uniform in every axis' warped coordinate (cross terms,
//     and the RMS over the domain);
//   - integrals: random nodes, where the interpolation error is zero and the
//     difference is the table's integration noise plus rounding;
//   - then a local search: the cells around the worst probes so far, probed
//     inside at every combination of 1/4, 1/2, 3/4 per axis (a narrow peak's
//     error can be largest inside a cell, off every line).
// The certificate's max is over all probes; its RMS over the random points
// only (the lines over-sample edges).
//
// certified_generate() runs plan -> generate -> certify -> refine: the
// library planner (plan.h) chooses a plan for the target, a caller-supplied
// function writes the planned spec's tables (so the CLI keeps its streamed,
// checkpointed path), every table is certified, and when a certificate
// misses the target the planner's error model is corrected by the measured /
// predicted ratios (per axis for interpolation, for integration from the
// node probes) and a new plan is made, until the certificates pass or
// max_refinements rounds are spent.
//
// Library code: no printing.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "host/core/table.h"
#include "host/io/table_io.h"
#include "host/engine/engine.h"
#include "host/lookup/lookup.h"
#include "host/plan/plan.h"
#include "host/spec/spec.h"

namespace brdftab {

struct CertifyOptions {
    bool absolute = false;   // absolute errors (else relative with a floor)
    // Relative errors divide by max(|reference|, floor): abs_floor when > 0,
    // otherwise rel_floor_factor x the largest |value| of the table (the
    // floor of `validate` and `plan`).
    double abs_floor = 0;
    double rel_floor_factor = 1e-3;
    Interpolation interpolation = Interpolation::Linear;
    // The target E, in the measure above; > 0.  It sets `passed` (max <= E)
    // and how quiet the reference of an integral must be.
    double target = 0;
    std::size_t lines = 8;              // lines per axis (closed forms)
    std::size_t integral_lines = 4;     // lines per axis (integrals)
    std::size_t random_points = 1000;   // closed forms
    std::size_t integral_random_points = 256;
    std::size_t node_points = 64;       // integrals only
    // Second stage (local search): the cells around the `local_worst` worst
    // probes of the first stage (and their neighbours, when that fits in the
    // cap) probed inside at every combination of 1/4, 1/2, 3/4 per axis.
    std::size_t local_worst = 8, integral_local_worst = 4;
    std::size_t local_probe_cap = 65536, integral_local_probe_cap = 4096;
    // Integrals: the reference runs under a tolerance so that its standard
    // error is at most reference_noise_fraction x E (relative measure: of
    // max(|value|, floor)), with at most reference_max_samples samples per
    // probe (the engine's adaptive rule, engine.h).
    double reference_noise_fraction = 0.2;
    std::uint64_t reference_max_samples = std::uint64_t{1} << 20;
    std::uint64_t seed = 1;
};

// The measured total error of one table (stored as HDF5 attributes
// `certificate_*` on the table's group, docs/format.md).
struct Certificate {
    std::string table;
    std::string mode = "accuracy";  // "accuracy" | "budget" (target = the plan's prediction)
    double target = 0;
    bool absolute = false;
    double abs_floor = 0;           // the floor F used (table units); 0 when absolute
    Interpolation interpolation = Interpolation::Linear;
    double max_error = 0, rms_error = 0;  // total error, in the measure
    std::vector<std::string> axis_names;
    std::vector<double> max_at;     // coordinates of the max, one per axis
    std::size_t probes = 0, line_probes = 0, random_probes = 0, node_probes = 0, local_probes = 0;
    std::vector<double> axis_max;   // per axis: max over the lines along it
    double node_max = 0;            // max over the node probes (integrals; 0 otherwise)
    double reference_noise = 0;     // largest reference stderr, in the measure (0: closed form)
    std::string reference_method;   // "closed-form", "rqmc", ...
    bool passed = false;            // max_error <= target
    int refinements = 0;            // refinement rounds before this table
    // The planner's prediction for the table as generated (NaN: not planned).
    double predicted_max = std::numeric_limits<double>::quiet_NaN();
    double predicted_rms = std::numeric_limits<double>::quiet_NaN();
    double seconds = 0;             // the certification's own wall time
};

// Certifies one table (stored values, as read back from a file) on `backend`.
// Throws InputError for tables without a model quantity of their own (error,
// inverted, recombined) and for bad options (target <= 0 or not finite).
Certificate certify_table(const TableData& table, Backend& backend, const CertifyOptions& options,
                          const ProgressFn& progress = nullptr);
// The same for table `table` of the file `path`.
Certificate certify_file_table(const std::string& path, const std::string& table, Backend& backend,
                               const CertifyOptions& options, const ProgressFn& progress = nullptr);

// ------------------------------------------------------------ sparse certificate

// The certificate of a table that is not generated (docs/planning.md
// "Verified plans").  certify_table() reads a table's stored values only at
// the cells in the interpolation stencils of its probes (up to 2 nodes per
// axis for linear, 4 for Catmull-Rom; in t on a dependent axis), so those
// cells are all it needs: before each batch of probes is interpolated the
// missing ones are computed with the engine exactly as `generate` computes
// them (a ChunkComputer over runs of consecutive cells: the same cell
// numbers in the random streams, the same seed, method, samples, tolerance
// and rule) and rounded to the stored type as the file writer rounds them.
// The result is the certificate certify_table() gives on the generated file,
// bit for bit (same options and seed), at the cost of the touched cells.
// Exceptions: the automatic relative floor (CertifyOptions::abs_floor = 0)
// is rel_floor_factor x the largest value among the cells the first stage
// reads, the nodes of the table's edges (every axis but one at one of its
// ends; the 2^D corners among them; they count towards the cells touched)
// and the cells around the floor hints (the table's largest value whenever
// that cell is among them, else smaller: larger relative errors);
// and for a quadrature without a finer reference rule the added rule error
// is the largest stored two-rule difference over the computed cells only.
struct SparseCertifyOptions {
    // Refuse (verified = false) when the cells the probes would touch (stage
    // 1 counted, the local search bounded from above) exceed this fraction
    // of the table's cells: generating the table would then cost about as
    // much and give the exact certificate.
    double max_touched_fraction = 0.25;
    // verify_plan() only: a table whose planned generation is predicted to
    // take at most this many seconds is verified whatever fraction of its
    // cells the probes touch (up to all of them): the exact certificate then
    // costs about one generation of a cheap table.  0 (the default): off;
    // `brdftab plan` sets 5 s.  (Not `generate --accuracy`: it generates and
    // certifies the plan anyway.)
    double cheap_table_seconds = 0;
    // Refuse above this many cells: the values are held in memory as the
    // lookup library reads them (8 bytes per cell, three copies).
    std::size_t max_table_cells = std::size_t(1) << 24;
    // Runs of touched cells closer than this are computed as one engine run
    // (the cells between are computed too: fewer, larger runs).
    std::size_t merge_gap_closed_form = 8, merge_gap_sampled = 2;
    // Points (model-input names, the table's axis values) whose linear
    // interpolation cells join the cells that set the automatic relative
    // floor.  verify_plan() passes where the table's pilot saw its largest
    // value: a largest value inside the table, off the probes' cells and the
    // table's edges, otherwise leaves the floor low and the relative errors
    // too large.  A point missing an axis is ignored, and so are all of them
    // on a table with dependent axes.
    std::vector<std::map<std::string, double>> floor_hints;
};

struct SparseCertificate {
    bool verified = false;     // false: not run (`why`); the certificate is empty
    std::string why;
    Certificate certificate;
    std::size_t table_cells = 0;
    std::size_t planned_cells = 0;   // the refusal test's count (stage 1 + stage 2's bound)
    std::size_t touched_cells = 0;   // cells the probes' stencils read
    std::size_t computed_cells = 0;  // cells computed (touched, and the gaps merged into runs)
    std::size_t engine_runs = 0;
    double compute_seconds = 0;      // engine time on those cells
    double seconds = 0;              // wall time of everything
};

// The sparse certificate of table `table_index` of `spec`, computed with
// `settings` (what `generate` would use: the spec's [integration] with the
// command line's overrides).  Throws InputError for bad options (as
// certify_table) and when the relative floor is not given.
SparseCertificate certify_spec_table(const Spec& spec, std::size_t table_index, Backend& backend,
                                     const IntegrationSettings& settings, const CertifyOptions& options,
                                     const SparseCertifyOptions& sparse = {},
                                     const ProgressFn& progress = nullptr);

// The sparse certificate of recombined table `recombined_index` of
// spec.recombined: the cells its probes read are computed from its terms (each
// term's cells as generate computes them, recombined at stored_at as generate
// recombines them, rounded to the stored type), and it is certified against
// the model quantity of its name, as `certify` takes a generated recombined
// table: the same certificate, bit for bit.
SparseCertificate certify_spec_recombined(const Spec& spec, std::size_t recombined_index, Backend& backend,
                                          const IntegrationSettings& settings, const CertifyOptions& options,
                                          const SparseCertifyOptions& sparse = {},
                                          const ProgressFn& progress = nullptr);

// ------------------------------------------------------------ verified plans

// A plan checked by sparse certificates of its tables before anything is
// generated (`brdftab plan`, docs/planning.md "Verified plans").
struct PlanVerification {
    // One per piloted table (plan.tables[i] for i < pilots.size()).
    std::vector<SparseCertificate> tables;
    // One per recombined entry after them (plan.tables[pilots.size() + k]):
    // its own sparse certificate (certify_spec_recombined) where it verifies;
    // else its bound (predict_recombined: docs/planning.md "Recombined
    // tables") recomputed from its terms' errors, each term's verified max
    // and RMS where that term was verified and its fitted ones elsewhere
    // (from_verified_terms: every term was verified).
    struct Recombined {
        std::string table;
        double max = 0, rms = 0;
        double fitted_max = 0, fitted_rms = 0;
        bool verified = false;  // max, rms: its own certificate's
        bool from_verified_terms = false;
        SparseCertificate sparse;
    };
    std::vector<Recombined> recombined;
    double fitted_max = 0, fitted_rms = 0;   // the fitted model's prediction (the candidate's)
    // The plan's error: per table the certificate's max (RMS) where it was
    // verified, the fitted prediction elsewhere; the worst table's.
    double error_max = 0, error_rms = 0;
    std::size_t verified = 0;                // tables verified
    std::size_t touched_cells = 0, computed_cells = 0, table_cells = 0;
    double seconds = 0;                      // wall time of the verification
};

// Verifies `plan` (chosen among candidates for `pilots`, the spec's tables
// `table_indices`) on `planned`, the spec with the plan applied
// (planned_spec_text, or the spec itself for its own plan), generating with
// `settings` as `generate` would.  Each table's certificate measures in the
// target's measure, relative errors with the floor `abs_floor` (0: the
// automatic one, as `certify` takes it, from the computed cells); its target (which sets an
// integral's reference noise, 0.2 x target) is E with an accuracy target,
// else the table's fitted max.
PlanVerification verify_plan(const Spec& planned, const std::vector<std::size_t>& table_indices,
                             const Candidate& plan, const std::vector<TablePilot>& pilots,
                             Backend& backend, const IntegrationSettings& settings, const PlanTarget& target,
                             double abs_floor, const SparseCertifyOptions& sparse = {},
                             const ProgressFn& progress = nullptr);

// The refinement's correction of the fitted error model from certificates
// that missed their target (certified_generate, and `plan --accuracy` after
// a failed verification): per axis whose lines exceeded the target, the
// interpolation law x measured / predicted (times the excess off the lines,
// at least 1.5); node probes above half the target scale the integration
// law the same way; only off-line probes failed: every axis' law x measured /
// predicted.  `certificates[i]` is pilots[i]'s (null: none).  Each
// correction is reported through `say` (one line each).
void correct_error_model(std::vector<TablePilot>& pilots, const PlanTarget& target, const Candidate& plan,
                         const std::vector<const Certificate*>& certificates,
                         const std::function<void(const std::string&)>& say = nullptr);

// Stores `c` as attributes of its table's group in `path` (replacing any
// earlier certificate); reads it back (nullopt: the table has none).
void write_certificate(const std::string& path, const Certificate& c);
std::optional<Certificate> read_certificate(const std::string& path, const std::string& table);
// The same from a file already open for reading (`brdftab info`: the tables
// and their certificates from one open file, even while it is replaced).
std::optional<Certificate> read_certificate(const TableReader& reader, const std::string& table);

// ------------------------------------------------------------ the whole loop

struct CertifiedGenerateOptions {
    PlanTarget target;              // accuracy E or budget T, measure, interpolation
    PilotOptions pilot;             // pilot.abs_floor: the relative floor (0: automatic)
    CertifyOptions certify;         // target, absolute, abs_floor, interpolation are set from the above
    int max_refinements = 2;        // >= 0; budget mode never refines
    std::string spec_label;         // file name the planned specs are parsed under
    // Accuracy mode: verify the first plan with sparse certificates before
    // generating it (verify_plan), and when the verification misses E
    // correct the model and choose again, at most 2 times ("Verified plans").
    bool verify = true;
    SparseCertifyOptions verify_sparse;
    // The settings `generate` computes the planned spec with (null: its
    // [integration] as written).
    std::function<IntegrationSettings(const Spec&)> verify_settings;
    // Called with each round's plan before anything of it is computed (in
    // round 0 before the verification too, and again should the verification
    // change the plan), with the Pareto front it was chosen from (sorted by
    // predicted time).  Returning false stops the loop: in round 0 nothing is
    // generated and certified_generate() throws InputError with `why`; in a
    // refinement round the last generated round stands (stop = "cost").  The
    // caller may throw instead.  Null: every plan is accepted.
    std::function<bool(const Candidate& plan, const std::vector<Candidate>& front, int round)> approve_plan;
    // Accuracy mode: the planned specs store their values rounded for the
    // target (round_to_accuracy = E in E's measure, host/io/bit_rounding.h),
    // so the certificates measure the rounded values.  A spec that sets its
    // own round_to_accuracy ([output] or a table's) keeps it.  Budget mode:
    // the spec's own setting.
    bool round_storage = true;
};

// Whether a plan's predicted cost is beyond what a run without an explicit
// budget should start (`generate --accuracy` asks for --yes or --budget):
// predicted time above max_seconds, or more cells than max_cell_factor x the
// spec's own tables and than min_cells (a small spec may grow 100x at no
// cost; the cell count guards against a time prediction that is off).
// Returns the reasons, in words ("" when neither holds).
struct PlanCostLimits {
    double max_seconds = 600;
    double max_cell_factor = 100;
    double min_cells = 1e6;
};
std::string excessive_plan_cost(const Candidate& plan, const Spec& spec, const PlanCostLimits& limits = {});
// Cells of every table of a plan, and of the spec's [[tables]] as written.
double plan_cells(const Candidate& plan);
double spec_table_cells(const Spec& spec);

struct CertifyEvent {
    std::string stage;   // "pilot", "plan", "generate", "certify", "refine"
    int round = 0;       // 0: the first plan; k: after k refinements
    std::string message; // one line for a log (the caller decides whether to show it)
    Progress progress;   // of the stage's current engine run, when it has one
};
using CertifyProgressFn = std::function<void(const CertifyEvent&)>;

// Writes every table of `planned` to `path` (replacing it): the caller's
// generate path (host/generate/chunked.h generate_to_file, with checkpoints).
using GenerateToFn = std::function<void(const Spec& planned, const std::string& path, int round)>;

struct CertifiedRound {
    int round = 0;
    Candidate plan;                  // as generated (counts may exceed the planner's choice)
    std::string spec_text;           // the planned spec generated in this round
    std::vector<Certificate> certificates;  // one per table
    double generate_seconds = 0, certify_seconds = 0;  // wall time
    bool passed = false;
};

struct CertifiedResult {
    std::vector<TablePilot> pilots;
    std::vector<PlanVerification> verifications;  // of the first plan, before generating (verify)
    std::vector<CertifiedRound> rounds;  // the last one is what `path` holds
    bool passed = false;
    // Why the loop ended: "passed", "max-refinements", "no-plan" (the corrected
    // model predicts no plan reaching E), "budget" (budget mode: no refinement),
    // "cost" (approve_plan refused a refinement round's plan).
    std::string stop;
    double pilot_seconds = 0, total_seconds = 0;
};

// Plans `spec` (every table; no [[recombined]]/[[errors]]/[[inverted]]),
// generates with `generate` into `path`, certifies and refines (see top).
// Certificates are written into `path` after each round.  Throws InputError
// for bad targets and specs the planner cannot handle, and Error when no
// candidate is predicted to reach the target in the first round (nothing is
// generated then).
CertifiedResult certified_generate(const Spec& spec, Backend& backend,
                                   const CertifiedGenerateOptions& options, const std::string& path,
                                   const GenerateToFn& generate,
                                   const CertifyProgressFn& progress = nullptr);

}  // namespace brdftab

// certify.h — certified generation (`brdftab generate --accuracy E | --budget T`,
// issue 13 item 3, docs/planning.md "Certified generation").
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
};

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
    std::vector<CertifiedRound> rounds;  // the last one is what `path` holds
    bool passed = false;
    // Why the loop ended: "passed", "max-refinements", "no-plan" (the corrected
    // model predicts no plan reaching E), "budget" (budget mode: no refinement).
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

// adaptive_generate.h — adaptive tables computed by the engine and
// certified (docs/adaptive.md): `generate --representation adaptive`,
// `certify` on an adaptive table.  Library code: no printing.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "host/adaptive/adaptive_table.h"
#include "host/engine/engine.h"
#include "host/plan/certify.h"
#include "host/spec/spec.h"

namespace brdftab {

// A declared breakpoint in axis units (`--breakpoint NAME=X`, `--jump NAME=X`).
struct NamedBreakpoint {
    std::string axis;
    double x = 0;
    bool jump = false;
};

// One engine run over kernel points, with estimate_at's arguments
// (evaluate.h): by default estimate_at on the backend given; a distributed
// run shares the points among its processes (host/generate/distributed.h,
// estimate_at_shared).  A point's value depends only on the point and on its
// number, settings.cell_base + its index, so a split run gives the same bits.
using AdaptiveEstimator = std::function<EstimateResult(
    const ModelInfo& model, const QuantityInfo& quantity, const std::vector<int>& options,
    const std::vector<double>& kernel_points, const IntegrationSettings& settings)>;

// Checkpoint of one table's refinement: the log of every round's points (in
// t) and engine results.  The refinement is deterministic, so a run given the
// log of an interrupted one replays those rounds without the engine (each
// round must ask for the very points logged: InputError otherwise) and goes
// on from the first round not logged; the table is bit-identical to an
// uninterrupted run's.  `save` receives the whole log after each computed
// round (atomically stored by the caller, host/generate/checkpoint.h).
struct AdaptiveCheckpoint {
    std::string stored;       // a log an earlier run saved ("": start from nothing)
    std::string fingerprint;  // the settings the log belongs to (checkpoint.h CheckpointKey)
    std::function<void(const std::string& log)> save;
    std::size_t replayed_rounds = 0;  // set by generate_adaptive
};

struct AdaptiveGenerateOptions {
    AdaptiveBuildOptions build;  // target, measure, budget, patch size, start levels
    std::vector<NamedBreakpoint> breakpoints;
    // A critical axis (spacing "critical", grid.h) gets a kink breakpoint at
    // its critical node's t, where the warp puts the TIR edge for every eta.
    bool critical_breakpoints = true;
    AdaptiveEstimator estimator;             // empty: estimate_at on the backend
    AdaptiveCheckpoint* checkpoint = nullptr;  // none: nothing stored or replayed
};

struct AdaptiveGenerated {
    AdaptiveTable table;
    AdaptiveBuildReport report;
    double seconds = 0;
};

// Table `table` of `spec` (its axes' ranges and warps; counts ignored) as an
// adaptive table: each refinement round's new points in one engine run
// (IntegrationSettings::cell_base numbering them after the previous rounds',
// so every point draws its own random numbers).  Throws InputError (an
// unknown axis in a breakpoint, one outside the axis' open range).
AdaptiveGenerated generate_adaptive(const Spec& spec, std::size_t table, Backend& backend,
                                    const IntegrationSettings& settings,
                                    const AdaptiveGenerateOptions& options,
                                    const AdaptiveRoundFn& round = nullptr);

// The certificate of an adaptive table, in the form and measure of
// certify_table (certify.h), with probes made for leaves: random points
// uniform in t; in every leaf (up to options.local_probe_cap of them) its
// centre and a random point; then the local search: the 3^d points at 1/4,
// 1/2, 3/4 of the leaves of the worst probes so far.  Every probe compares
// the table's own interpolation (AdaptiveLayout::eval, its patch_order)
// with the reference, certify_table's.
// `estimator` (empty: estimate_at on `backend`) runs the reference.
Certificate certify_adaptive(const AdaptiveTable& table, Backend& backend, const CertifyOptions& options,
                             const ProgressFn& progress = nullptr, const AdaptiveEstimator& estimator = nullptr);
// The same for table `table` of the file `path`.
Certificate certify_adaptive_file(const std::string& path, const std::string& table, Backend& backend,
                                  const CertifyOptions& options, const ProgressFn& progress = nullptr);

}  // namespace brdftab

// engine.h — the integration engine: runs a model's estimator over many cells
// on a backend (OpenCL device or the host serial reference), with a fixed
// sample budget or an adaptive per-cell tolerance.
//
// Estimators:
//   closed-form  one evaluation per cell, stderr 0.
//   mc           Philox-4x32-10 pseudo-random samples; stderr from the sample
//                variance (batches merged with Chan's formula).
//   rqmc         Owen-scrambled Sobol points; each batch is an independently
//                scrambled copy of the first batch_size points, so batch means
//                are i.i.d. and the stderr is that of their mean (needs >= 2
//                batches; at least 4 are always run).
// Determinism: every random number depends only on (seed, cell, batch, sample,
// dimension) and the per-cell stopping rule only on that cell's batches, so
// tables are bit-identical for any slab size on the same device.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "host/core/vocabulary.h"
#include "host/engine/engine_tuning.h"
#include "host/models/registry.h"

namespace brdftab {

enum class Precision { Double, Float };
const char* precision_name(Precision p);
Precision parse_precision(const std::string& s);  // throws InputError

struct IntegrationSettings {
    Method method = Method::Auto;     // Auto: the quantity's default (resolve_method)
    std::uint64_t samples = 0;        // fixed budget per cell (0 = default 4096) unless tolerance > 0
    double tolerance = 0;             // > 0: adaptive, relative
    double abs_floor = 1e-6;          // a cell is done when stderr <= max(tolerance*|mean|, abs_floor)
    std::uint64_t max_samples = 1u << 22;  // cap under --tolerance
    std::uint64_t seed = 1;
    std::uint32_t batch_size = 0;     // 0 = automatic
    std::size_t slab_work_items = 0;  // 0 = automatic; work items per device launch
    // Number of the run's first cell in the random streams: cell c of the
    // run draws the samples of cell cell_base + c, so a chunk of a table
    // computes its cells exactly as the whole table would (cell_base +
    // cell count must stay below 2^32).
    std::uint64_t cell_base = 0;
};

// The largest per-cell sample count (and max_samples) the engine accepts:
// per-cell counts are stored as uint32 in the tables.
constexpr std::uint64_t kMaxSampleCount = 0xFFFFFFFFull;
// The allowed range of samples and max_samples, as messages state it (inline:
// the spec parser, which does not link the engine, uses it too).
inline std::string sample_count_range_text() {
    return "integers in [1, " + std::to_string(kMaxSampleCount) + "]";
}

// Throws InputError naming the setting ("samples", "max_samples",
// "tolerance", "abs_floor") and its allowed range when a setting is out of
// range.  samples = 0 and tolerance = 0 mean "not set" here (the defaults).
// estimate() calls it first; the CLI and the spec parser check their own
// values earlier so that their messages name the argument or file:line:key.
void check_settings(const IntegrationSettings& settings);

// One launch: `n_work` work items, each a (cell, batch) pair with its point.
struct BatchLaunch {
    const ModelInfo* model = nullptr;
    int quantity = 0;
    std::vector<int> options;
    std::uint32_t method = 0;  // BT_METHOD_* from kernels/common/sampler.h
    std::uint32_t key0 = 0, key1 = 0;
    std::size_t stride = 0;
    std::vector<double> points;  // n_work * stride
    std::vector<std::uint32_t> cells, batches;
    std::uint32_t batch_size = 1;
    // false: the caller reads no m2 (the direct path of closed forms and
    // quadratures, whose one-sample batches have m2 = 0), and a backend
    // may leave the m2 vector as it is (not even resized).
    bool need_m2 = true;
    // true: the caller built the launch's points, cells and batches
    // (staged_items work items) in the memory Backend::stage() gave it, and
    // the three vectors above stay empty.
    bool staged = false;
    std::size_t staged_items = 0;
    // Where the means go (work_items() doubles), instead of the `mean`
    // vector, which then stays untouched: the direct path of closed forms
    // reads them straight into the result array.  Null: into `mean`.
    double* mean_out = nullptr;
    std::size_t work_items() const { return staged ? staged_items : cells.size(); }
};

// Memory for one launch's inputs that a backend lends its caller
// (Backend::stage): work item w's point at points + w * stride, its cell and
// batch at cells[w], batches[w].
struct LaunchStaging {
    double* points = nullptr;
    std::uint32_t* cells = nullptr;
    std::uint32_t* batches = nullptr;
};

class Backend {
public:
    virtual ~Backend() = default;
    virtual std::string device_name() const = 0;
    virtual Precision precision() const = 0;
    // Fills mean[w], m2[w] for every work item.
    virtual void run(const BatchLaunch& launch, std::vector<double>& mean,
                     std::vector<double>& m2) = 0;
    // The same in two steps, so that the caller can build its next launch
    // while the device computes this one: start() begins a launch, finish()
    // completes the oldest launch started and not yet finished, leaving its
    // results in the vectors given to start().  At most two launches are
    // started and unfinished at a time; their BatchLaunch and vectors must
    // stay untouched until finished.  abandon() waits for whatever is
    // started and drops it (for error paths; it never throws).  Results are
    // those of run().  The default runs the launch inside start().
    virtual void start(const BatchLaunch& launch, std::vector<double>& mean,
                       std::vector<double>& m2) {
        run(launch, mean, m2);
    }
    virtual void finish() {}
    virtual void abandon() noexcept {}
    // Memory in which the caller may build the inputs of the launch it
    // starts next (`launch` as it will be started, `items` work items at
    // most), instead of in BatchLaunch's vectors: it sets launch.staged and
    // launch.staged_items and leaves the memory untouched until the launch
    // is finished.  The backend reads the inputs there without a copy where
    // it can (PoCL's CPU device: the launch's buffers are this memory).
    // Returns false where it lends none (this backend, or this launch's
    // kind): the caller fills the vectors.  The default lends none.
    virtual bool stage(const BatchLaunch& launch, std::size_t items, LaunchStaging& staging) {
        (void)launch;
        (void)items;
        (void)staging;
        return false;
    }
    // Suggested work items per launch.
    virtual std::size_t preferred_slab() const = 0;
    // The launch knobs (engine_tuning.h) of the launches started from now
    // on; results do not depend on them.  The host backends have none.
    virtual void set_tuning(const EngineTuning& tuning) { (void)tuning; }
    virtual EngineTuning tuning() const { return EngineTuning{}; }
};

// "host" selects the serial C++ reference; "host-threads" the same code on one
// std::thread per core ("host-threads:N": N threads), bit-identical to "host";
// anything else selects an OpenCL device (index or name substring; empty =
// $BRDFTAB_DEVICE or first CPU), whose launches follow `tuning`.
std::unique_ptr<Backend> make_backend(const std::string& device_selector,
                                      Precision precision,
                                      const std::string& kernel_dir = "",
                                      const EngineTuning& tuning = environment_tuning());

// Sample-parallel launches (OpenCL backend only): a Monte Carlo / RQMC batch
// of batch_size samples runs as batch_size work items of a sample kernel, one
// sample each, and one work item of a reduce kernel that merges them in
// sample order (kernels/common/estimator.h, sample_parallel.cl),
// instead of one work item looping over the samples; results are bit-identical
// either way.  By default only where the quantity declares it
// (QuantityInfo::sample_parallel, measured faster: docs/benchmarks.md);
// EngineTuning::sample_parallel On forces it for every Monte Carlo / RQMC
// launch of more than one sample per batch, Off turns it off.  Where the
// quantity declares a fixed-step solver (QuantityInfo::fixed_step_solver)
// the sample kernels come from a build whose visible-normal searches take a
// fixed number of steps, with a redo kernel for the samples whose search had
// not ended (EngineTuning::fixed_solver_steps_x/y set other step counts).
// EngineTuning::sample_parallel_scratch_samples caps a sub-launch (default
// 2^22 samples; a batch larger than the cap runs the usual kernel).
// Quadratures have their own switch, EngineTuning::node_parallel
// (node-parallel launches, below).
struct SampleParallelCase {
    std::string model, quantity;
    Method method;       // MonteCarlo or Rqmc
    // Only with every listed option set to its choice (none: any options).
    std::vector<std::pair<std::string, std::string>> options;
};
// Every model's declared sample-parallel defaults, as one list.
const std::vector<SampleParallelCase>& sample_parallel_default_cases();
// Whether a launch of `quantity` of `model` by `method` with these option
// indices (resolve_options) runs sample-parallel by default.
bool sample_parallel_by_default(const ModelInfo& model, const QuantityInfo& quantity,
                                Method method, const std::vector<int>& options);

// Walk-parallel launches (OpenCL backend only, kernels/common/walk_parallel.h):
// a random-walk quantity that names its walk functions
// (QuantityInfo::walk_parallel) runs its Monte Carlo batches on a kernel
// that advances every work item's walk one collision per round and starts a
// batch's next sample as soon as a walk ends, bit-identical to the usual
// kernel.  EngineTuning::walk_parallel false runs the usual kernel instead.
// state, setup, begin, step, value: the model's names (kernel header) for the walk.
struct WalkParallelCase {
    std::string model, quantity;
    std::string state, setup, begin, step, value;
};
// Every model's declared walk-parallel quantities, as one list.
const std::vector<WalkParallelCase>& walk_parallel_cases();

// Node-parallel quadrature (OpenCL backend only): a quantity that names node
// functions (QuantityInfo::node_parallel, host/models/registry.h; flat sums,
// optionally with split terms, or nested sums over groups of nodes) runs its
// quadrature batches as one work item per node of a node kernel and one
// work item per batch of a sum kernel that adds the terms in node order
// (kernels/common/node_parallel.h), instead of one work item looping over
// the nodes; results are bit-identical either way.  On by default where
// node_parallel_by_default() says so (measured, docs/benchmarks.md
// "Node-parallel quadrature"); EngineTuning::node_parallel Off turns it off,
// On forces it on.  EngineTuning::node_parallel_scratch_nodes = N caps a
// sub-launch at N nodes (default 2^22; nested sums: N/16 nodes per
// sub-launch, blocks of at most N/64 groups and N/256 work items, each with
// a reduce kernel per group); EngineTuning::node_layout_cap = N (tests) lays
// out at most N nodes per batch, the sum kernel computing the rest.
bool node_parallel_by_default();

struct Progress {
    std::size_t cells_total = 0;
    std::size_t cells_done = 0;      // converged or budget exhausted
    std::uint64_t samples_done = 0;
    double elapsed_seconds = 0;
    double fraction = 0;             // best estimate of work fraction done, 0..1
};
using ProgressFn = std::function<void(const Progress&)>;

struct EstimateResult {
    std::vector<double> value, stderr_;
    std::vector<std::uint32_t> samples;
    Method method = Method::ClosedForm;  // the resolved method, never Auto
    std::uint64_t total_samples = 0;
    // max over cells of stderr / max(|value|, F), F = abs_floor / tolerance
    // under a tolerance (so a cell that met its target scores <= tolerance),
    // F = abs_floor for fixed budgets
    double tolerance_achieved = 0;
    // cells that hit max_samples before meeting the tolerance (adaptive runs)
    std::size_t cells_unconverged = 0;
    double elapsed_seconds = 0;
};

// Supplies the kernel point of a cell (stride = model.point_stride()).
using PointFn = std::function<void(std::size_t cell, double* point)>;
// Supplies the kernel points of `count` consecutive cells from first_cell
// on: cell first_cell + k's point at points + k * model.point_stride().
// estimate() asks for whole launches' worth of cells at a time where it can
// (closed forms without a checkpoint: every launch's cells in one call), so
// a caller that holds its points in one array copies them with one copy per
// launch instead of a call and a copy per cell (docs/benchmarks.md, "Closed
// forms: the engine's host work"); elsewhere it asks for one cell at a time.  The same cells get the
// same points either way, so results do not depend on which form is used.
using PointsFn = std::function<void(std::size_t first_cell, std::size_t count, double* points)>;

// Running statistics of one cell across batches (merged in batch order).
struct CellState {
    double first_batch = 0, second_batch = 0;  // quadrature: accurate, coarse rule
    std::uint64_t samples = 0;
    std::uint32_t batches = 0;
    double mean = 0, m2 = 0;              // sample level (Chan merge)
    double batch_mean = 0, batch_m2 = 0;  // batch-mean level (Welford)
    bool done = false;
};

// What estimate() needs to stop between two launches and continue later
// (host/generate/checkpoint.h stores it).  Work runs in rounds: every cell
// gets batches up to its round_target, then the stopping rule, which reads
// only that cell's state, sets the next target or marks it done.  A cell's
// batches are numbered from its merged count, so a continued run draws the
// same samples in the same order as an uninterrupted one.
struct EstimateState {
    std::vector<CellState> cells;               // one per cell
    std::vector<std::uint32_t> round_target;    // batches each cell is to have this round
    double elapsed_seconds = 0;                 // time spent before (and in) this run
};
struct EstimateCheckpoint {
    // Continue from here instead of from no samples (moved from; sizes
    // must equal the cell count, targets must not be below the merged counts).
    std::optional<EstimateState> resume;
    // Called after every launch (finished = false), and once when every cell
    // is done (finished = true); decides itself whether to store the state.
    std::function<void(const EstimateState&, bool finished)> save;
};

EstimateResult estimate(Backend& backend, const ModelInfo& model,
                        const QuantityInfo& quantity, const std::vector<int>& options,
                        std::size_t cell_count, const PointFn& point_of,
                        const IntegrationSettings& settings,
                        const ProgressFn& progress = nullptr,
                        EstimateCheckpoint* checkpoint = nullptr);
// The same with the points supplied a span of cells at a time (PointsFn);
// the form above asks its point_of for each cell of every span in turn.
EstimateResult estimate(Backend& backend, const ModelInfo& model,
                        const QuantityInfo& quantity, const std::vector<int>& options,
                        std::size_t cell_count, const PointsFn& points_of,
                        const IntegrationSettings& settings,
                        const ProgressFn& progress = nullptr,
                        EstimateCheckpoint* checkpoint = nullptr);

}  // namespace brdftab

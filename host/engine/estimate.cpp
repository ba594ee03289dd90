// estimate.cpp — estimate() (engine.h): the checks and the set-up every run
// shares, then one of two pipelines: the direct one for closed forms and
// quadratures without a checkpoint (each launch's results straight into the
// result arrays), or the per-cell loop in rounds with its stopping rule
// (sampled methods, adaptive budgets, checkpoints).
#include <algorithm>
#include <chrono>
#include <cmath>

#if defined(__linux__)
#include <sys/mman.h>
#endif

#include "kernels/common/estimator.h"
#include "host/core/error.h"
#include "host/engine/engine.h"

namespace brdftab {

namespace {

// Cells per points_of call of the check pass before a run (prepare_run()):
// a span of points small enough to stay in cache; not tuned, results do not
// depend on it.
constexpr std::size_t kCheckSpan = 1024;
// The adaptive stopping rule's next request (next_round()): the total that
// should meet the target by the 1/sqrt(batches) law, 10 % more, within
// [2x, 16x] the batches so far, so that a noisy early estimate can neither
// stall a cell nor explode its budget.  A safeguard by design, not a
// measured optimum; every figure of docs/ was measured with it.
constexpr double kRoundMargin = 1.1;
constexpr double kRoundMinGrowth = 2.0, kRoundMaxGrowth = 16.0;

void merge_batch(CellState& c, double mean, double m2, std::uint32_t batch_size) {
    // Chan, Golub & LeVeque: combine (n_a, mean_a, M2_a) with (n_b, mean_b, M2_b).
    if (c.batches == 0) c.first_batch = mean;
    if (c.batches == 1) c.second_batch = mean;
    const double na = static_cast<double>(c.samples), nb = batch_size;
    const double n = na + nb;
    const double delta = mean - c.mean;
    c.mean += delta * nb / n;
    c.m2 += m2 + delta * delta * na * nb / n;
    c.samples += batch_size;
    // Welford over batch means (the RQMC error estimate).
    c.batches += 1;
    const double d = mean - c.batch_mean;
    c.batch_mean += d / c.batches;
    c.batch_m2 += d * (mean - c.batch_mean);
}

double cell_stderr(const CellState& c, bool rqmc) {
    if (rqmc) {
        if (c.batches < 2) return INFINITY;
        return std::sqrt(c.batch_m2 / (c.batches - 1) / c.batches);
    }
    if (c.samples < 2) return INFINITY;
    return std::sqrt(c.m2 / static_cast<double>(c.samples - 1) / static_cast<double>(c.samples));
}

// v = n copies of `fill`, for the result arrays of large runs: where the
// kernel allows, the fresh memory is asked to be backed by transparent huge
// pages first (madvise), so that filling it takes a page fault per 2 MiB
// instead of per 4 KiB.  Measured on 4 M closed-form cells: the faults of the
// three result arrays took about a sixth of the process's time (411 page
// faults per run instead of 18 700).  Only the mapping changes, not a value.
template <typename T>
void assign_large(std::vector<T>& v, std::size_t n, T fill) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    constexpr std::size_t kHuge = std::size_t{2} << 20;
    if (n * sizeof(T) >= 2 * kHuge && v.capacity() < n) {
        std::vector<T>().swap(v);
        // Allocated, not yet touched; 2 MiB more, so that the huge page
        // holding the array's end lies inside the allocation.
        v.reserve(n + kHuge / sizeof(T));
        const auto begin = reinterpret_cast<std::uintptr_t>(v.data());
        const std::uintptr_t first = (begin + kHuge - 1) / kHuge * kHuge;
        const std::uintptr_t last = (begin + n * sizeof(T) + kHuge - 1) / kHuge * kHuge;
        if (last > first)
            madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);  // a hint
    }
#endif
    v.assign(n, fill);
}

// Continue from `from`: each cell's next batch index is its merged count and
// its remaining work this round is what its target still lacks.  Returns the
// time spent before.  Throws Error on a state that cannot have come from a
// run of this table.
double restore_state(EstimateState& state, EstimateState&& from,
                     std::vector<std::uint32_t>& wanted, std::vector<std::uint32_t>& issued) {
    const std::size_t n = state.cells.size();
    if (from.cells.size() != n || from.round_target.size() != n)
        throw Error("stored estimator state has " + std::to_string(from.cells.size()) +
                    " cells, the table " + std::to_string(n));
    for (std::size_t c = 0; c < n; ++c) {
        const CellState& s = from.cells[c];
        if (from.round_target[c] < s.batches || (s.done && from.round_target[c] != s.batches))
            throw Error("stored estimator state of cell " + std::to_string(c) +
                        " is inconsistent (batches beyond the round's target)");
        issued[c] = s.batches;
        wanted[c] = from.round_target[c] - s.batches;
    }
    state.cells = std::move(from.cells);
    return from.elapsed_seconds;
}

// What both pipelines share: the run's inputs, its resolved method and
// budget, the launch template and the launch sizes.
struct EstimateRun {
    Backend& backend;
    const ModelInfo& model;
    const QuantityInfo& quantity;
    const std::vector<int>& options;
    std::size_t cell_count;
    const PointsFn& points_of;
    const IntegrationSettings& settings;
    const ProgressFn& progress;

    Method method = Method::ClosedForm;  // resolved
    bool quadrature = false, closed = false, rqmc = false, adaptive = false;
    // Closed forms without a checkpoint check each cell's point as it is
    // built for its launch (check_cells) instead of in a pass before.
    bool check_while_building = false;
    BatchLaunch launch = {};
    std::size_t stride = 0;  // launch.stride
    CellDerivation derivation = {};
    std::uint32_t cell_base = 0;
    std::uint32_t batch_size = 1, first_batches = 1, max_batches = 1;
    // Launch size.  A fixed --slab is kept as given.  Otherwise launches start
    // small and grow towards kLaunchSeconds each (next_launch_size,
    // engine_tuning.h, which the planner's engine_launch_sizes follows too).
    // Results do not depend on the launch size.
    bool fixed_slab = false;
    std::size_t max_slab = 1, slab = 1;
    std::chrono::steady_clock::time_point start = {};
    Progress prog = {};

    double elapsed() const {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    void resize_slab(std::size_t items, double seconds) {
        if (fixed_slab || items < slab) return;  // a short tail launch says little
        slab = next_launch_size(items, seconds, slab, max_slab);
    }
    // The check of `count` cells' points (point k at points + k * pitch):
    // the model's fast form first (ModelInfo::cells_pass), and its message-
    // building check_cell, cell by cell, only where that refuses the span,
    // so the first refused cell is reported as a check of every cell would.
    void check_cells(const double* points, std::size_t count, std::size_t pitch) const {
        if (model.cells_pass && model.cells_pass(quantity, points, count, pitch, options)) return;
        for (std::size_t k = 0; k < count; ++k) {
            const std::string problem = model.check_cell(quantity, points + k * pitch, options);
            if (!problem.empty()) throw InputError(problem);
        }
    }
    // A launch's work items `items`, `items + 1`, ... for batches first_batch,
    // first_batch + 1, ... (take of them) of one cell: its point is built
    // straight into the first item's slot and copied to the others.  Both
    // pipelines fill their launches with it.  The inputs are written through
    // `to`: a launch's vectors, or memory the backend lends (Backend::stage).
    void add_items_to(const LaunchStaging& to, std::size_t cell, std::uint32_t first_batch,
                      std::uint32_t take, std::size_t& items) const {
        double* const first_point = to.points + items * stride;
        points_of(cell, 1, first_point);
        if (check_while_building && model.check_cell) check_cells(first_point, 1, stride);
        if (derivation.slots > 0) derivation.fill(first_point);
        for (std::uint32_t k = 0; k < take; ++k, ++items) {
            if (k) std::copy_n(first_point, stride, to.points + items * stride);
            to.cells[items] = cell_base + static_cast<std::uint32_t>(cell);
            to.batches[items] = first_batch + k;
        }
    }
    static LaunchStaging vectors_of(BatchLaunch& l) {
        LaunchStaging to;
        to.points = l.points.data();
        to.cells = l.cells.data();
        to.batches = l.batches.data();
        return to;
    }
    // The figures every pipeline derives from the per-cell results in the
    // same way: the worst relative error, unconverged cells, the last
    // progress.  errors_all_zero: every stderr is 0 (closed forms), so every
    // cell's relative error is 0 or NaN (0 / 0), which std::max below
    // ignores: the worst is 0, and the loop and its divisions are skipped.
    void finish(EstimateResult& result, double elapsed_before_run, bool errors_all_zero) {
        double worst = 0;
        std::size_t unconverged = 0;
        // Relative error with the absolute floor folded in: under a tolerance
        // a cell whose stderr met abs_floor scores at most `tolerance`, so the
        // figure is comparable with the requested tolerance.
        const double floor_value =
            adaptive ? settings.abs_floor / settings.tolerance : settings.abs_floor;
        for (std::size_t c = 0; c < cell_count && !(errors_all_zero && !adaptive); ++c) {
            const double rel = result.stderr_[c] / std::max(std::fabs(result.value[c]), floor_value);
            worst = std::max(worst, rel);
            if (adaptive && result.stderr_[c] > std::max(settings.tolerance * std::fabs(result.value[c]),
                                                         settings.abs_floor))
                ++unconverged;
        }
        result.tolerance_achieved = worst;
        result.cells_unconverged = unconverged;
        result.elapsed_seconds = elapsed_before_run + elapsed();
        if (progress) {
            prog.cells_done = cell_count;
            prog.fraction = 1.0;
            prog.elapsed_seconds = result.elapsed_seconds;
            prog.samples_done = result.total_samples;
            progress(prog);
        }
    }
};

// The checks before anything runs (settings, cell numbers, every cell's
// point unless they are checked as they are built) and the set-up both
// pipelines share.
void prepare_run(EstimateRun& run, const EstimateCheckpoint* checkpoint) {
    const ModelInfo& model = run.model;
    const QuantityInfo& quantity = run.quantity;
    const IntegrationSettings& settings = run.settings;
    const std::size_t cell_count = run.cell_count;
    if (!model.host_fn) throw Error("model '" + model.name + "' has no sample function");
    check_settings(settings);
    if (cell_count > 0xFFFFFFFFull)
        throw InputError("table has " + std::to_string(cell_count) +
                         " cells; at most 2^32 - 1 are supported");
    if (settings.cell_base > 0xFFFFFFFFull - cell_count)
        throw InputError("cells " + std::to_string(settings.cell_base) + " + " +
                         std::to_string(cell_count) + " reach past cell 2^32 - 1");
    // The model's cross-checks of parameters and options (ModelInfo::
    // check_cell) on every cell before anything runs: one point per cell, far
    // cheaper than the kernel, and no launch computes a cell that is invalid.
    // Closed forms without a checkpoint (the direct pipeline) check each
    // cell's point as it is built for its launch instead: there the separate
    // pass built every point twice and cost about as much as the kernel
    // (bench/bench_engine_closed_form), and a launch of closed forms is cheap
    // enough that a bad cell still stops the run before any long work.
    run.method = resolve_method(quantity, settings.method);
    run.check_while_building = run.method == Method::ClosedForm &&
                               !(checkpoint && (checkpoint->save || checkpoint->resume));
    if (model.check_cell && !run.check_while_building) {
        const std::size_t pitch = model.point_stride();
        std::vector<double> span_points(std::min(cell_count, kCheckSpan) * pitch);
        for (std::size_t first = 0; first < cell_count; first += kCheckSpan) {
            const std::size_t count = std::min(kCheckSpan, cell_count - first);
            run.points_of(first, count, span_points.data());
            run.check_cells(span_points.data(), count, pitch);
        }
    }
    run.start = std::chrono::steady_clock::now();

    run.quadrature = run.method == Method::Quadrature;
    // Quadrature runs like a closed form with two one-sample batches.
    run.closed = run.method == Method::ClosedForm || run.quadrature;
    run.rqmc = run.method == Method::Rqmc;
    run.adaptive = !run.closed && settings.tolerance > 0;  // < 1: check_settings

    BatchLaunch& launch = run.launch;
    launch.model = &model;
    launch.quantity = quantity.id;
    launch.options = run.options;
    launch.method = run.quadrature ? BT_METHOD_QUADRATURE
                    : run.closed   ? BT_METHOD_CLOSED
                    : run.rqmc     ? BT_METHOD_RQMC
                                   : BT_METHOD_MC;
    launch.key0 = static_cast<std::uint32_t>(settings.seed);
    launch.key1 = static_cast<std::uint32_t>(settings.seed >> 32);
    launch.stride = model.point_stride();
    // The quantity's per-cell invariants (ModelInfo::derive), computed here
    // once per cell and appended to its point.
    run.derivation = model.derive ? model.derive(quantity, run.options) : CellDerivation{};
    const CellDerivation& derivation = run.derivation;
    if (derivation.slots > 0) {
        launch.stride += static_cast<std::size_t>(derivation.slots);
        if (launch.stride > BT_MAX_POINT || !derivation.fill)
            throw Error("model '" + model.name + "', quantity '" + quantity.name + "': " +
                        std::to_string(derivation.slots) +
                        " derived slots need a fill function and at most BT_MAX_POINT (" +
                        std::to_string(BT_MAX_POINT) + ") point slots in all");
    }
    run.stride = launch.stride;
    // The kernels see cell numbers from cell_base on (random streams); the
    // per-cell state here is indexed from 0.
    run.cell_base = static_cast<std::uint32_t>(settings.cell_base);

    // Budget: the batch policy the planner shares (first_round_batches,
    // engine_tuning.h).
    const BatchLayout first_round = first_round_batches(run.method, settings.samples, settings.batch_size);
    run.batch_size = static_cast<std::uint32_t>(first_round.batch_size);
    run.first_batches = static_cast<std::uint32_t>(first_round.batches);
    const std::uint64_t max_samples =
        run.adaptive ? std::max<std::uint64_t>(settings.max_samples,
                                               static_cast<std::uint64_t>(run.first_batches) * run.batch_size)
                     : static_cast<std::uint64_t>(run.first_batches) * run.batch_size;
    run.max_batches = static_cast<std::uint32_t>(
        std::min<std::uint64_t>(max_samples / run.batch_size, 0xFFFFFFFFu));
    launch.batch_size = run.batch_size;

    run.fixed_slab = settings.slab_work_items != 0;
    run.max_slab = std::max<std::size_t>(
        1, run.fixed_slab ? settings.slab_work_items : run.backend.preferred_slab());
    run.slab = run.fixed_slab ? run.max_slab : std::min(run.max_slab, kFirstLaunch);
    run.prog.cells_total = cell_count;
}

// The adaptive stopping rule after a round: marks the cells that are done
// (every cell of a non-adaptive run; a cell at max_batches or whose stderr
// met its target) and sets each other cell's batches for the next round in
// `wanted`.  Reads only each cell's own state.  Returns the next round's
// work items; `done` counts the cells done.
std::uint64_t next_round(const EstimateRun& run, std::vector<CellState>& cells,
                         std::vector<std::uint32_t>& wanted, std::size_t& done) {
    const IntegrationSettings& settings = run.settings;
    const bool adaptive = run.adaptive, rqmc = run.rqmc;
    const std::uint32_t max_batches = run.max_batches;
    const std::size_t cell_count = run.cell_count;
    std::uint64_t next_work = 0;
    done = 0;
    for (std::size_t c = 0; c < cell_count; ++c) {
        CellState& s = cells[c];
        wanted[c] = 0;
        if (s.done) {
            ++done;
            continue;
        }
        if (!adaptive || s.batches >= max_batches) {
            s.done = true;
            ++done;
            continue;
        }
        const double se = cell_stderr(s, rqmc);
        const double target = std::max(settings.tolerance * std::fabs(s.mean), settings.abs_floor);
        if (se <= target) {
            s.done = true;
            ++done;
            continue;
        }
        // The error falls as 1/sqrt(batches): ask for the total that should
        // meet the target (kRoundMargin, kRoundMinGrowth, kRoundMaxGrowth).
        const double ratio = se / target;
        double need = std::ceil(s.batches * ratio * ratio * kRoundMargin);
        need = std::clamp(need, kRoundMinGrowth * s.batches, kRoundMaxGrowth * s.batches);
        const std::uint32_t more = static_cast<std::uint32_t>(
            std::min<double>(need, max_batches) - s.batches);
        wanted[c] = more;
        next_work += more;
    }
    return next_work;
}

// Closed forms and quadratures without a checkpoint: every cell runs its
// fixed one (closed form) or two (quadrature: accurate and coarse rule)
// one-sample batches and nothing else, so the per-cell estimator state, the
// work lists and the stopping rule are not needed: each launch's results go
// straight into the result arrays.  Measured: the state alone (72 bytes per
// cell, fresh memory on every call) cost more page faults and memory traffic
// than the closed-form kernel (`perf record` of bench_engine_closed_form).
// The values are those the per-cell pipeline (run_rounds) computes.
EstimateResult run_direct(EstimateRun& run) {
    Backend& backend = run.backend;
    const ModelInfo& model = run.model;
    const std::size_t cell_count = run.cell_count;
    const PointsFn& points_of = run.points_of;
    const ProgressFn& progress = run.progress;
    const bool quadrature = run.quadrature, check_while_building = run.check_while_building;
    const std::uint32_t first_batches = run.first_batches, cell_base = run.cell_base;
    const std::size_t stride = run.stride, max_slab = run.max_slab;
    const std::size_t& slab = run.slab;
    const BatchLaunch& launch = run.launch;
    const CellDerivation& derivation = run.derivation;
    Progress& prog = run.prog;
    auto elapsed = [&] { return run.elapsed(); };
    EstimateResult result;
    result.method = run.method;
    assign_large(result.value, cell_count, 0.0);
    assign_large(result.stderr_, cell_count, 0.0);
    assign_large(result.samples, cell_count, 1u);
    std::size_t cell_cursor = 0;
    std::uint32_t batch_cursor = 0;  // next batch of cell_cursor
    std::uint64_t work_done = 0;
    const std::uint64_t total_work = static_cast<std::uint64_t>(cell_count) * first_batches;
    // Two launches in turn (Backend::start/finish): once the launches
    // have grown to the backend's largest, the next one's points are
    // built here while the device computes one, so the host's share of
    // a closed form's cost overlaps the kernel's instead of adding to it.
    // Launches are merged in the order they were built, so the results
    // do not depend on it.
    struct Slot {
        BatchLaunch launch;
        std::vector<double> mean, m2;
        double started = 0;
        std::size_t items = 0, cells_complete = 0;
        std::size_t first_cell = 0;       // the launch's first work item's
        std::uint32_t first_batch = 0;    // cell and batch
    };
    Slot slots[2];
    for (Slot& slot : slots) {
        slot.launch = launch;
        slot.launch.need_m2 = false;  // one-sample batches: m2 = 0
    }
    // Unfinished launches read and write the slots: on any exception they
    // are waited for and dropped before the slots go away.
    struct AbandonOnUnwind {
        Backend& backend;
        bool armed = true;
        ~AbandonOnUnwind() {
            if (armed) backend.abandon();
        }
    } abandon_guard{backend};
    std::size_t unfinished = 0, oldest = 0, next = 0;
    double last_finish = 0;
    auto merge_oldest = [&] {
        Slot& slot = slots[oldest];
        backend.finish();
        --unfinished;
        oldest ^= 1;
        const double now = elapsed();
        // The device's time for this launch: from its start or the end of
        // the one before it, whichever came later.
        run.resize_slab(slot.items, now - std::max(slot.started, last_finish));
        last_finish = now;
        if (!quadrature) {
            // One work item per cell, in cell order; the means are in
            // the result array already (BatchLaunch::mean_out).
            // merge_batch's first merge: 0 + (x - 0) * 1 / 1, which
            // turns -0 into +0; the rest of it is exact.
            double* const value = result.value.data() + slot.first_cell;
            for (std::size_t w = 0; w < slot.items; ++w) value[w] = 0.0 + value[w];
        } else {
            // Work items (cell, batch) in order from the launch's first.
            std::size_t c = slot.first_cell;
            std::uint32_t b = slot.first_batch;
            for (std::size_t w = 0; w < slot.items; ++w) {
                const double x = slot.mean[w];
                if (b == 0) {
                    result.value[c] = x;  // the accurate rule, taken as it is
                } else {
                    // Batch 0 of this cell came first (same or earlier launch).
                    result.stderr_[c] = std::fabs(result.value[c] - x);
                }
                if (++b == first_batches) {
                    ++c;
                    b = 0;
                }
            }
        }
        work_done += slot.items;
        if (progress) {
            // A cell is finished once its last batch is merged.
            prog.cells_done = slot.cells_complete;
            prog.samples_done = work_done;
            prog.elapsed_seconds = now;
            prog.fraction = std::min(1.0, static_cast<double>(work_done) /
                                              static_cast<double>(std::max<std::uint64_t>(
                                                  total_work, 1)));
            progress(prog);
        }
    };
    while (cell_cursor < cell_count) {
        Slot& slot = slots[next];
        BatchLaunch& l = slot.launch;
        slot.first_cell = cell_cursor;
        slot.first_batch = batch_cursor;
        // Built where the backend reads it (no copy on PoCL's CPU
        // device), or in the launch's vectors.
        LaunchStaging to;
        l.staged = false;
        l.mean_out = nullptr;
        if (backend.stage(l, slab, to)) {
            l.staged = true;
            l.cells.clear();
            l.batches.clear();
            l.points.clear();
        } else {
            l.cells.resize(slab);
            l.batches.resize(slab);
            l.points.resize(slab * stride);
            to = EstimateRun::vectors_of(l);
        }
        std::size_t items = 0;
        if (first_batches == 1 && derivation.slots == 0) {
            // Closed forms: one work item per cell (add_items_to, without
            // its per-cell loop over batches), the launch's points asked
            // for in one call and checked as one span (the stride is the
            // model's: no derived slots).
            const std::size_t count = std::min(cell_count - cell_cursor, slab);
            points_of(cell_cursor, count, to.points);
            if (check_while_building && model.check_cell) run.check_cells(to.points, count, stride);
            const std::uint32_t first = cell_base + static_cast<std::uint32_t>(cell_cursor);
            for (std::size_t w = 0; w < count; ++w) {
                to.cells[w] = first + static_cast<std::uint32_t>(w);
                to.batches[w] = 0;
            }
            cell_cursor += count;
            items = count;
        }
        while (cell_cursor < cell_count && items < slab) {
            const std::uint32_t take = static_cast<std::uint32_t>(
                std::min<std::size_t>(first_batches - batch_cursor, slab - items));
            run.add_items_to(to, cell_cursor, batch_cursor, take, items);
            batch_cursor += take;
            if (batch_cursor == first_batches) {
                ++cell_cursor;
                batch_cursor = 0;
            }
        }
        if (l.staged) {
            l.staged_items = items;
        } else {
            l.cells.resize(items);
            l.batches.resize(items);
            l.points.resize(items * stride);
        }
        if (!quadrature) l.mean_out = result.value.data() + slot.first_cell;
        slot.items = items;
        slot.cells_complete = cell_cursor;
        slot.started = elapsed();
        backend.start(l, slot.mean, slot.m2);
        ++unfinished;
        next ^= 1;
        // While the launches still grow (resize_slab), each one's time
        // sets the next one's size, so it is finished before the next is
        // built: the launch sizes are those of the general path (which
        // plan's cost model follows, tests/test_plan_cost.cpp).  At the
        // largest size one launch computes while the next is built.
        if (unfinished == 2 || slab < max_slab) merge_oldest();
    }
    while (unfinished > 0) merge_oldest();
    abandon_guard.armed = false;
    result.total_samples = total_work;  // batch_size is 1
    run.finish(result, 0.0, !quadrature);
    return result;
}

// The per-cell pipeline: work in rounds, every cell getting batches up to
// its round's target, then the stopping rule (next_round); checkpoints
// store the state between launches (EstimateCheckpoint).
EstimateResult run_rounds(EstimateRun& run, EstimateCheckpoint* checkpoint) {
    Backend& backend = run.backend;
    const ModelInfo& model = run.model;
    const std::size_t cell_count = run.cell_count;
    const PointsFn& points_of = run.points_of;
    const ProgressFn& progress = run.progress;
    const bool quadrature = run.quadrature, closed = run.closed, rqmc = run.rqmc;
    const bool adaptive = run.adaptive, check_while_building = run.check_while_building;
    const std::uint32_t first_batches = run.first_batches, cell_base = run.cell_base;
    const std::uint32_t batch_size = run.batch_size;
    const std::size_t stride = run.stride;
    const std::size_t& slab = run.slab;
    BatchLaunch& launch = run.launch;
    const CellDerivation& derivation = run.derivation;
    Progress& prog = run.prog;
    auto elapsed = [&] { return run.elapsed(); };
    auto add_items = [&](std::size_t cell, std::uint32_t first_batch, std::uint32_t take,
                         std::size_t& items) {
        run.add_items_to(EstimateRun::vectors_of(launch), cell, first_batch, take, items);
    };
    EstimateResult result;
    result.method = run.method;
    EstimateState state;
    std::vector<CellState>& cells = state.cells;
    std::vector<double> slab_mean, slab_m2;
    cells.resize(cell_count);
    // Per-cell batches wanted this round (0 = cell done).
    std::vector<std::uint32_t> wanted(cell_count, first_batches);
    // Batches handed out so far per cell: the next batch's index.  (A cell's
    // batches may straddle two slabs, so the merged count cannot serve.)
    std::vector<std::uint32_t> issued(cell_count, 0);
    std::uint64_t total_work_estimate = static_cast<std::uint64_t>(cell_count) * first_batches;
    std::uint64_t work_done = 0;
    double elapsed_before = 0;
    if (checkpoint && checkpoint->resume) {
        elapsed_before = restore_state(state, std::move(*checkpoint->resume), wanted, issued);
        checkpoint->resume.reset();
        total_work_estimate = 0;
        for (std::uint32_t w : wanted) total_work_estimate += w;
    }
    auto save_state = [&](bool finished) {
        if (!checkpoint || !checkpoint->save) return;
        state.elapsed_seconds = elapsed_before + elapsed();
        checkpoint->save(state, finished);
    };

    for (int round = 0;; ++round) {
        if (checkpoint) {
            state.round_target.resize(cell_count);
            for (std::size_t c = 0; c < cell_count; ++c)
                state.round_target[c] = issued[c] + wanted[c];
        }
        // Work list of this round, ordered by (cell, batch), so every cell
        // merges its batches in batch order whatever the slab size.
        std::size_t cell_cursor = 0;
        std::uint32_t batch_cursor = 0;
        auto advance_to_work = [&] {
            while (cell_cursor < cell_count && batch_cursor >= wanted[cell_cursor]) {
                ++cell_cursor;
                batch_cursor = 0;
            }
        };
        advance_to_work();
        // No early exit when the round has no work: continued from a stored
        // state, it may only lack the stopping rule below.
        while (cell_cursor < cell_count) {
            // The launch's arrays are written in place (they keep their
            // capacity from launch to launch).
            launch.cells.resize(slab);
            launch.batches.resize(slab);
            launch.points.resize(slab * stride);
            std::size_t items = 0;
            while (cell_cursor < cell_count && items < slab) {
                if (batch_cursor == 0 && wanted[cell_cursor] == 1 && derivation.slots == 0) {
                    // A run of cells that want one batch each (closed forms,
                    // a first round of one batch per cell): one work item
                    // each, their points asked for in one call, as
                    // add_items would put them.
                    std::size_t end = cell_cursor + 1;
                    while (end < cell_count && end - cell_cursor < slab - items && wanted[end] == 1)
                        ++end;
                    const std::size_t count = end - cell_cursor;
                    double* const points = launch.points.data() + items * stride;
                    points_of(cell_cursor, count, points);
                    if (check_while_building && model.check_cell) run.check_cells(points, count, stride);
                    for (std::size_t c = cell_cursor; c < end; ++c, ++items) {
                        launch.cells[items] = cell_base + static_cast<std::uint32_t>(c);
                        launch.batches[items] = issued[c]++;
                    }
                    cell_cursor = end;
                    advance_to_work();
                    continue;
                }
                // This cell's remaining batches of the round, as many as fit.
                const std::uint32_t take = static_cast<std::uint32_t>(std::min<std::size_t>(
                    wanted[cell_cursor] - batch_cursor, slab - items));
                add_items(cell_cursor, issued[cell_cursor], take, items);
                issued[cell_cursor] += take;
                batch_cursor += take;
                advance_to_work();
            }
            launch.cells.resize(items);
            launch.batches.resize(items);
            launch.points.resize(items * stride);
            const double launch_start = elapsed();
            backend.run(launch, slab_mean, slab_m2);
            run.resize_slab(launch.cells.size(), elapsed() - launch_start);
            for (std::size_t w = 0; w < launch.cells.size(); ++w)
                merge_batch(cells[launch.cells[w] - cell_base], slab_mean[w], slab_m2[w], batch_size);
            work_done += launch.cells.size();
            save_state(false);
            if (progress) {
                // Without a tolerance every cell is finished once its batches
                // are merged: the cursor counts them.
                if (!adaptive) prog.cells_done = cell_cursor;
                prog.samples_done = work_done * batch_size;
                prog.elapsed_seconds = elapsed();
                prog.fraction = std::min(1.0, static_cast<double>(work_done) /
                                                  static_cast<double>(std::max<std::uint64_t>(
                                                      total_work_estimate, 1)));
                progress(prog);
            }
        }
        // Decide which cells continue.
        std::size_t done = 0;
        const std::uint64_t next_work = next_round(run, cells, wanted, done);
        prog.cells_done = done;
        total_work_estimate = work_done + next_work;
        if (next_work == 0) break;
    }
    save_state(true);

    result.value.resize(cell_count);
    result.stderr_.resize(cell_count);
    result.samples.resize(cell_count);
    for (std::size_t c = 0; c < cell_count; ++c) {
        const CellState& s = cells[c];
        // RQMC: the mean of the batch means is the estimator whose error we report.
        // Quadrature: the accurate rule, with the coarse rule's distance as error.
        result.value[c] = quadrature ? s.first_batch : rqmc ? s.batch_mean : s.mean;
        result.stderr_[c] = quadrature ? std::fabs(s.first_batch - s.second_batch)
                            : closed   ? 0.0
                                       : cell_stderr(s, rqmc);
        result.samples[c] = quadrature ? 1u : static_cast<std::uint32_t>(std::min<std::uint64_t>(s.samples, 0xFFFFFFFFu));
        result.total_samples += s.samples;
    }
    run.finish(result, elapsed_before, false);
    return result;
}

}  // namespace

EstimateResult estimate(Backend& backend, const ModelInfo& model, const QuantityInfo& quantity,
                        const std::vector<int>& options, std::size_t cell_count,
                        const PointFn& point_of, const IntegrationSettings& settings,
                        const ProgressFn& progress, EstimateCheckpoint* checkpoint) {
    const std::size_t point_stride = model.point_stride();
    const PointsFn points_of = [&](std::size_t first_cell, std::size_t count, double* points) {
        for (std::size_t k = 0; k < count; ++k) point_of(first_cell + k, points + k * point_stride);
    };
    return estimate(backend, model, quantity, options, cell_count, points_of, settings, progress,
                    checkpoint);
}

EstimateResult estimate(Backend& backend, const ModelInfo& model, const QuantityInfo& quantity,
                        const std::vector<int>& options, std::size_t cell_count,
                        const PointsFn& points_of, const IntegrationSettings& settings,
                        const ProgressFn& progress, EstimateCheckpoint* checkpoint) {
    EstimateRun run{backend, model, quantity, options, cell_count, points_of, settings, progress};
    prepare_run(run, checkpoint);
    // Closed forms and quadratures without a checkpoint take the direct
    // pipeline; everything else the per-cell rounds.
    const bool direct = run.closed && !(checkpoint && (checkpoint->save || checkpoint->resume));
    return direct ? run_direct(run) : run_rounds(run, checkpoint);
}

}  // namespace brdftab

// plan.cpp — error and cost model, pilot, candidates and choice (plan.h).
#include "host/plan/plan.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>

#include <toml++/toml.h>

#include "host/core/error.h"
#include "host/core/polynomial.h"
#include "host/core/text.h"
#include "host/core/splitmix.h"
#include "host/engine/evaluate.h"
#include "host/generate/validate.h"
#include "host/models/registry.h"

namespace brdftab {

namespace {
// The pilots' integration runs draw from a stream offset from the user's
// seed, so that a pilot never replays the samples of the table it plans.
constexpr std::uint64_t kPilotSeedOffset = 17;


constexpr std::size_t kMinCount = 4, kMaxCount = 65536;
constexpr double kMaxCells = 4294967295.0;  // the kernels' 32-bit cell index

Axis remade(const Axis& axis, std::size_t count) {
    if (axis.spacing == Spacing::LogComplement)
        return make_log_complement_axis(axis.name, axis.unit, axis.min, axis.max, count, axis.pivot);
    if (axis.spacing == Spacing::Critical)  // fixed eta only (run_pilot refuses the others)
        return make_critical_axis(axis.name, axis.min, axis.max, count,
                                  critical_node_for(count, double(axis.critical_node) / double(axis.count - 1)),
                                  axis.grading, axis.critical_eta);
    return make_axis(axis.name, axis.unit, axis.min, axis.max, count, axis.spacing);
}

double now_seconds() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

// ------------------------------------------------------------ convergence fits

double PowerFit::eval(double x) const { return valid ? c * std::pow(x, p) : 0.0; }

PowerFit fit_power_law(const std::vector<double>& x, const std::vector<double>& y) {
    PowerFit f;
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    std::size_t n = 0;
    for (std::size_t k = 0; k < std::min(x.size(), y.size()); ++k) {
        if (!(x[k] > 0 && y[k] > 0 && std::isfinite(x[k]) && std::isfinite(y[k]))) continue;
        const double lx = std::log(x[k]), ly = std::log(y[k]);
        sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly, ++n;
    }
    f.points = n;
    const double den = n * sxx - sx * sx;
    if (n < 2 || !(std::fabs(den) > 1e-300)) return f;
    f.p = (n * sxy - sx * sy) / den;
    f.c = std::exp((sy - f.p * sx) / n);
    f.valid = true;
    return f;
}

PowerFit fit_power_law_fixed(const std::vector<double>& x, const std::vector<double>& y, double p) {
    PowerFit f;
    double s = 0;
    std::size_t n = 0;
    for (std::size_t k = 0; k < std::min(x.size(), y.size()); ++k) {
        if (!(x[k] > 0 && y[k] > 0 && std::isfinite(x[k]) && std::isfinite(y[k]))) continue;
        s += std::log(y[k]) - p * std::log(x[k]), ++n;
    }
    f.points = n;
    if (n < 1) return f;
    f.p = p;
    f.c = std::exp(s / n);
    f.valid = true;
    return f;
}

// ------------------------------------------------------------ interpolation probes

std::vector<double> probe_positions(std::size_t count) {
    std::vector<double> t;
    const double h = 1.0 / static_cast<double>(count - 1);
    for (std::size_t k = 0; k + 1 < count; ++k)
        for (double s : kProbeFractions) t.push_back((k + s) * h);
    return t;
}

std::vector<double> interpolate_line(const Axis& axis, const std::vector<double>& node_values,
                                     const std::vector<double>& probes, Interpolation interp) {
    TableData t;
    t.name = "line";
    t.units = "1";
    t.axes = {axis.spacing == Spacing::Explicit || axis.count == node_values.size() ? axis
                                                                                    : remade(axis, node_values.size())};
    t.value = node_values;
    const LookupTable lt(std::move(t));
    const Axis& a = lt.axes().front();
    std::vector<double> out;
    out.reserve(probes.size());
    for (double tp : probes)
        out.push_back(lt.eval({std::clamp(a.warp(tp), a.min, a.max)}, interp, OutOfRange::Clamp));
    return out;
}

double expected_max_error(const std::vector<double>& sigma, double cells) {
    double hi = 0;
    for (double s : sigma) hi = std::max(hi, s);
    if (!(hi > 0) || sigma.empty()) return 0;
    const double weight = std::max(cells, 1.0) / double(sigma.size());
    // log P(max <= x); increasing in x.
    auto log_p = [&](double x) {
        double sum = 0;
        for (double s : sigma)
            if (s > 0) sum += weight * std::log1p(-std::erfc(x / (s * std::sqrt(2.0))));
        return sum;
    };
    double lo = 0;
    hi *= 2;
    while (log_p(hi) < std::log(0.5)) hi *= 2;
    for (int k = 0; k < 100; ++k) {
        const double mid = 0.5 * (lo + hi);
        (log_p(mid) < std::log(0.5) ? lo : hi) = mid;
    }
    return hi;
}

PowerFit anchored_fit(const PowerFit& f, double x_anchor, double y_anchor, double p_min, double p_max) {
    PowerFit g = f;
    if (!f.valid || !(x_anchor > 0 && y_anchor > 0)) return g;
    g.p = std::clamp(f.p, p_min, p_max);
    g.c = y_anchor / std::pow(x_anchor, g.p);
    return g;
}

void fit_axis(AxisFit& fit, double max_exponent) {
    std::vector<double> h, max_abs, rms_abs, max_rel, rms_rel;
    for (const LevelErrors& l : fit.levels) {
        // Below 3x the reference's noise the measured error is the noise's.
        if (noise_dominated(l)) continue;
        h.push_back(l.h);
        max_abs.push_back(l.max_abs), rms_abs.push_back(l.rms_abs);
        max_rel.push_back(l.max_rel), rms_rel.push_back(l.rms_rel);
    }
    fit.max_abs = fit_power_law(h, max_abs);
    fit.rms_abs = fit_power_law(h, rms_abs);
    fit.max_rel = fit_power_law(h, max_rel);
    fit.rms_rel = fit_power_law(h, rms_rel);
    if (max_exponent > 0 && !h.empty()) {
        // Levels are coarsest first: the last usable ones are the finest.  The
        // slope of the two finest is the closest to the asymptotic regime: a
        // least-squares slope over all levels is biased low by the coarsest
        // (albedo_r's alpha axis: p = 1.22 against 1.37, a 6-fold over-prediction).
        const double lo = -std::numeric_limits<double>::infinity();
        auto finest = [&](const PowerFit& all, const std::vector<double>& y) {
            const std::size_t n = h.size();
            PowerFit f = n >= 2 ? fit_power_law({h[n - 2], h[n - 1]}, {y[n - 2], y[n - 1]}) : all;
            if (!f.valid) f = all;
            return anchored_fit(f, h.back(), y.back(), lo, max_exponent);
        };
        fit.max_abs = finest(fit.max_abs, max_abs);
        fit.rms_abs = finest(fit.rms_abs, rms_abs);
        fit.max_rel = finest(fit.max_rel, max_rel);
        fit.rms_rel = finest(fit.rms_rel, rms_rel);
    }
}

// --------------------------------------------------------------- storage rounding

StorageRounding storage_rounding(StoredType type) {
    switch (type) {
    case StoredType::Float64: return {std::ldexp(1.0, -53), 0.0, std::numeric_limits<double>::max()};
    case StoredType::Float32:
        // Subnormal float32 (below 2^-126) is far below any floor that matters.
        return {std::ldexp(1.0, -24), std::ldexp(1.0, -150), 3.4028234663852886e38};
    case StoredType::Float16: return {std::ldexp(1.0, -11), std::ldexp(1.0, -25), 65504.0};
    }
    return {};
}

// --------------------------------------------------------------- pilot

std::vector<std::size_t> pilot_counts(std::size_t count, std::size_t max_base) {
    const std::size_t b = std::clamp<std::size_t>((count + 1) / 2, 4, std::max<std::size_t>(max_base, 4));
    return {b, 2 * b - 1, 4 * b - 3};
}

namespace {

struct PilotContext {
    const ModelInfo* model = nullptr;
    const QuantityInfo* quantity = nullptr;
    std::vector<int> options;
    std::map<std::string, double> fixed;
    std::string where;
};

std::vector<double> kernel_points(const PilotContext& ctx,
                                  const std::vector<std::map<std::string, double>>& named) {
    return build_kernel_points(*ctx.model, *ctx.quantity, named,
                               [&](std::size_t) { return ctx.where; });
}

// One axis' lines at one level: indices into the batch of reference points.
struct LineBlock {
    std::size_t axis = 0, level = 0, first_node = 0, first_probe = 0, line = 0;
};

// The 1-D axis of a pilot line with n nodes.  A critical axis tied to an eta
// axis is, along a line that holds eta fixed, an ordinary critical axis at
// that eta (the table's nodes along the line are exactly its nodes).
Axis line_axis(const Axis& axis, std::size_t n, const std::map<std::string, double>& line) {
    if (axis.spacing == Spacing::Explicit) return axis;
    if (!axis.dependent()) return remade(axis, n);
    return make_critical_axis(axis.name, axis.min, axis.max, n,
                              critical_node_for(n, double(axis.critical_node) / double(axis.count - 1)),
                              axis.grading, line.at(axis.depends_on));
}

// A dependent axis held at its node t_k along a line (or in a pilot cell)
// sits at warp_at(t_k, eta) of each point's own eta: set those coordinates
// once the point's other coordinates are in place.
void place_dependents(std::map<std::string, double>& point, const std::vector<Axis>& axes,
                      const std::map<std::string, double>& t_of) {
    for (const Axis& b : axes) {
        const auto it = t_of.find(b.name);
        if (!b.dependent() || it == t_of.end()) continue;
        point[b.name] = std::clamp(b.warp_at(it->second, point.at(b.depends_on)), b.min, b.max);
    }
}

// A random cell of the spec's grid (a node of every axis; a dependent axis at
// its node t_k, placed at the cell's own eta), added to `base`.
std::map<std::string, double> random_cell(std::map<std::string, double> base, const std::vector<Axis>& axes,
                                          SplitMix& rng) {
    std::map<std::string, double> t_of;
    for (const Axis& ax : axes) {
        base[ax.name] = ax.values[rng.below(ax.count)];
        if (ax.dependent()) t_of[ax.name] = base[ax.name];
    }
    place_dependents(base, axes, t_of);
    return base;
}

// Total errors of a table plan from its terms.  Sum of the maxima: a bound at
// the worst point.  RMS: the terms are independent over the domain
// (interpolation: the function's shape; integration: random; rounding:
// uniform within +-half ulp, RMS ulp/(2 sqrt 3)).
void combine_errors(TablePlan& tp) {
    tp.error_max = tp.interpolation_max + tp.integration_max + tp.storage_max;
    const double storage_rms = tp.storage_max / std::sqrt(3.0);
    tp.error_rms = std::sqrt(tp.interpolation_rms * tp.interpolation_rms +
                             tp.integration_rms * tp.integration_rms + storage_rms * storage_rms);
}

}  // namespace

// --------------------------------------------------------------- cost model terms

WorkShape work_shape(Method method, std::uint64_t samples) {
    // The layout of estimate()'s first round (host/engine/engine_tuning.h).
    const BatchLayout b = first_round_batches(method, samples);
    WorkShape w;
    w.samples_per_item = double(b.batch_size);
    w.items_per_cell = double(b.batches);
    return w;
}

EngineLaunches engine_launch_sizes(double work_items, double seconds_per_item, double seconds_per_launch,
                                   std::size_t max_slab) {
    // As estimate() sizes its launches (next_launch_size, engine_tuning.h).
    constexpr std::size_t kKept = 32;
    EngineLaunches out;
    max_slab = std::max<std::size_t>(1, max_slab);
    std::size_t slab = std::min(max_slab, kFirstLaunch);
    double left = std::floor(std::max(work_items, 0.0));
    auto add = [&](std::size_t n, double times) {
        out.count += times;
        out.largest = std::max(out.largest, n);
        for (double k = 0; k < times && out.first.size() < kKept; ++k) out.first.push_back(n);
    };
    while (left > 0) {
        if (left < double(slab)) {  // the tail: too short to resize by
            add(static_cast<std::size_t>(left), 1);
            break;
        }
        add(slab, 1);
        left -= double(slab);
        const double seconds = seconds_per_launch + double(slab) * seconds_per_item;
        const std::size_t next = next_launch_size(slab, seconds, slab, max_slab);
        if (next == slab) {  // steady: every further full launch is the same
            const double full = std::floor(left / double(slab));
            add(slab, full);
            left -= full * double(slab);
            if (left > 0) add(static_cast<std::size_t>(left), 1);
            break;
        }
        slab = next;
    }
    return out;
}

bool reaches_large_grid(const EngineLaunches& launches) {
    constexpr std::size_t kGroup = kLocalSize;  // the engine's work-group size (engine_tuning.h)
    return (launches.largest + kGroup - 1) / kGroup * kGroup >= kLargeGridWorkItems;
}

double engine_seconds(const TablePilot& pilot, const IntegrationFit& f, double cells, std::uint64_t samples,
                      bool* large_grid) {
    const bool sampled = f.method == Method::MonteCarlo || f.method == Method::Rqmc;
    const WorkShape w = work_shape(f.method, sampled ? samples : 0);
    const double items = cells * w.items_per_cell;
    const double per_item = sampled ? f.item_overhead_seconds + w.samples_per_item * f.seconds_per_sample
                                    : f.seconds_per_cell / w.items_per_cell;
    double t = pilot.startup_seconds + pilot.overhead_seconds + items * per_item;
    const bool large =
        f.large_grid_load_seconds > 0 &&
        reaches_large_grid(engine_launch_sizes(items, per_item, pilot.overhead_seconds, pilot.preferred_slab));
    if (large) t += f.large_grid_load_seconds;
    if (large_grid) *large_grid = large;
    return t;
}

double shared_kernel_saving(const std::vector<TablePlan>& tables) {
    struct Loads {
        double startup_sum = 0, startup_max = 0, large_sum = 0, large_max = 0;
    };
    std::map<std::string, Loads> by_kernel;
    for (const TablePlan& t : tables) {
        if (t.kernel.empty()) continue;
        Loads& l = by_kernel[t.kernel];
        l.startup_sum += t.kernel_load_seconds, l.startup_max = std::max(l.startup_max, t.kernel_load_seconds);
        l.large_sum += t.large_grid_load_seconds, l.large_max = std::max(l.large_max, t.large_grid_load_seconds);
    }
    double saving = 0;
    for (const auto& [kernel, l] : by_kernel) saving += (l.startup_sum - l.startup_max) + (l.large_sum - l.large_max);
    return saving;
}

double write_seconds(double cells, StoredType type, int compression, bool with_stderr, bool with_samples) {
    // Seconds per stored value, write_tables() of a smooth 2-D table of
    // 3e5 and 3e6 cells (fastest of 3), 2 cores of an Intel Xeon (AVX-512):
    //             float16   float32   float64
    //   deflate    2.5e-7    4.5e-7    6.5e-7   (level 6, with shuffle)
    //   none       1.5e-7    2.0e-7    1.7e-7
    // uint32 samples as float32 (they compress better: an upper bound).
    const bool deflate = compression > 0;
    auto per_value = [&](StoredType t) {
        switch (t) {
        case StoredType::Float16: return deflate ? 2.5e-7 : 1.5e-7;
        case StoredType::Float32: return deflate ? 4.5e-7 : 2.0e-7;
        case StoredType::Float64: return deflate ? 6.5e-7 : 1.7e-7;
        }
        return 4.5e-7;
    };
    double per_cell = per_value(type);
    if (with_stderr) per_cell += per_value(type);
    if (with_samples) per_cell += per_value(StoredType::Float32);
    return std::max(cells, 0.0) * per_cell;
}

double process_fixed_seconds() {
    // Both measured on 2 cores of an Intel Xeon (AVX-512), load average 5-6.
    // `brdftab --version`: 0.03-0.04 s wall (exec, shared libraries, static
    // registration, exit).
    constexpr double kProcessStartSeconds = 0.035;
    // A 64-cell file: 7-8 ms (create, attributes, close, rename).
    constexpr double kFileSeconds = 0.008;
    return kProcessStartSeconds + kFileSeconds;
}

namespace {

// A launch costing more than this (by the pilot's per-item cost) is not made:
// generate's launches of such items stay below kLargeGridWorkItems anyway
// (0.5 s per launch / 65536 items = 7.6 us per item, this is twice that).
constexpr double kLargeLaunchPilotSeconds = 1.0;

// The large-grid pilot of one method (see run_pilot): `base` are kernel points
// (repeated to one launch of at least kLargeGridWorkItems work items); sets
// f.large_grid_load_seconds, and for MC / RQMC f.item_overhead_seconds.
void large_grid_pilot(const PilotContext& ctx, const Spec& spec, IntegrationFit& f,
                      const std::vector<double>& base, const IntegrationSettings& ref, Backend& backend,
                      Backend* fresh, TablePilot& pilot, const ProgressFn& progress) {
    const std::size_t stride = ctx.model->point_stride();
    if (base.size() < stride) return;
    // The host backends run C++, no PoCL variants; a backend whose launches
    // stay below the size never meets the variant.
    if (backend.device_name().rfind("host", 0) == 0 || backend.preferred_slab() < kLargeGridWorkItems) return;
    const bool sampled = f.method == Method::MonteCarlo || f.method == Method::Rqmc;
    IntegrationSettings s = ref;
    if (f.method != Method::ClosedForm) {
        s = IntegrationSettings{};
        s.method = f.method;
        s.seed = ref.seed;
        if (sampled) s.samples = spec.integration.samples ? spec.integration.samples : kDefaultSamplesPerCell;
    }
    const WorkShape w = work_shape(f.method, s.samples);
    const double guess = sampled ? w.samples_per_item * f.seconds_per_sample : f.seconds_per_cell / w.items_per_cell;
    if (!(guess > 0) || guess * double(kLargeGridWorkItems) > kLargeLaunchPilotSeconds) return;
    const std::size_t cells =
        static_cast<std::size_t>(std::ceil(double(kLargeGridWorkItems) / w.items_per_cell));
    std::vector<double> batch;
    batch.reserve(cells * stride);
    while (batch.size() < cells * stride) {
        const std::size_t take = std::min(base.size(), cells * stride - batch.size());
        batch.insert(batch.end(), base.begin(), base.begin() + static_cast<std::ptrdiff_t>(take));
    }
    s.slab_work_items = static_cast<std::size_t>(double(cells) * w.items_per_cell);  // one launch
    auto run = [&](Backend& b) {
        return estimate_at(b, *ctx.model, *ctx.quantity, ctx.options, batch, s, progress).elapsed_seconds;
    };
    (void)run(backend);  // builds the variant (into PoCL's cache)
    // The launch alone: the faster of two (the machine may be shared).
    const double work = std::min(run(backend), run(backend));
    if (fresh) {
        // A one-point run first loads this method's program (its small-grid
        // variant), which the table's startup_seconds already counts (for
        // the default method; MC and RQMC are two programs): what remains
        // of the large launch above `work` is the large-grid variant's load.
        (void)estimate_at(*fresh, *ctx.model, *ctx.quantity, ctx.options,
                          std::vector<double>(base.begin(), base.begin() + static_cast<std::ptrdiff_t>(stride)), s);
        f.large_grid_load_seconds = std::max(0.0, run(*fresh) - work);
    }
    pilot.pilot_evaluations += (fresh ? 4 : 3) * cells;
    const double per_item = std::max(work - pilot.overhead_seconds, 0.5 * work) / double(s.slab_work_items);
    if (sampled) f.item_overhead_seconds = std::max(0.0, per_item - w.samples_per_item * f.seconds_per_sample);
    f.large_grid_measured = true;
}

}  // namespace

namespace {

// A stage's progress callback, by the stage's name.
using StageProgress = std::function<ProgressFn(const std::string&)>;

// The interpolation pilot's points: every axis, level and line in one batch.
struct InterpolationDesign {
    std::vector<std::map<std::string, double>> named;   // the points, model inputs
    std::vector<LineBlock> blocks;                       // where each line's nodes and probes lie
    std::vector<std::vector<std::size_t>> level_counts;  // per axis (empty: a whole-number axis)
    // Each axis' lines (their fixed coordinates), for the line axes of the fits.
    std::vector<std::vector<std::map<std::string, double>>> axis_lines;
};

InterpolationDesign design_interpolation_pilot(const PilotContext& ctx, const TableSpec& ts,
                                               const PilotOptions& options, SplitMix& rng) {
    const std::size_t dims = ts.axes.size();
    InterpolationDesign d;
    std::vector<std::map<std::string, double>>& named = d.named;
    std::vector<LineBlock>& blocks = d.blocks;
    std::vector<std::vector<std::size_t>>& level_counts = d.level_counts;
    std::vector<std::vector<std::map<std::string, double>>>& axis_lines = d.axis_lines;
    level_counts.resize(dims);
    axis_lines.resize(dims);
    const bool integral = ctx.quantity->kind == QuantityKind::Integral;
    for (std::size_t a = 0; a < dims; ++a) {
        const Axis& axis = ts.axes[a];
        // An explicit axis of a whole-number parameter (an order, a mode) is
        // read at its nodes only: nothing lies between them to probe.
        if (axis.spacing == Spacing::Explicit)
            if (const ParameterInfo* info = ctx.model->find_parameter(axis.name); info && info->integer)
                continue;
        level_counts[a] = axis.spacing == Spacing::Explicit ? std::vector<std::size_t>{axis.count}
                                                            : pilot_counts(axis.count, integral ? options.integral_max_base : options.max_base);
        // The lines: the other coordinates at random nodes of the spec's axes,
        // the same for every level so the levels differ only in h.
        // Stratified: along each other axis the L lines take nodes spread
        // evenly from the first to the last (the ends, e.g. grazing angles,
        // are often where a quantity changes fastest), in a random order
        // per axis so that lines do not all pair first with first.
        // A one-axis table has a single line: copies would only repeat it.
        std::vector<std::map<std::string, double>> lines(
            dims == 1 ? 1 : integral ? options.integral_lines : options.lines, ctx.fixed);
        const std::size_t nl = lines.size();
        for (std::size_t b = 0; b < dims; ++b) {
            if (b == a) continue;
            const Axis& other = ts.axes[b];
            std::vector<std::size_t> idx(nl);
            for (std::size_t l = 0; l < nl; ++l)
                idx[l] = nl == 1 ? rng.below(other.count)
                                 : static_cast<std::size_t>(std::lround(double(l) * double(other.count - 1) / double(nl - 1)));
            for (std::size_t l = nl; l > 1; --l) std::swap(idx[l - 1], idx[rng.below(l)]);  // Fisher-Yates
            for (std::size_t l = 0; l < nl; ++l) lines[l][other.name] = other.values[idx[l]];
        }
        std::vector<std::map<std::string, double>> line_t(nl);
        for (std::size_t b = 0; b < dims; ++b)
            if (b != a && ts.axes[b].dependent())
                for (std::size_t l = 0; l < nl; ++l) line_t[l][ts.axes[b].name] = lines[l][ts.axes[b].name];
        for (std::size_t l = 0; l < level_counts[a].size(); ++l) {
            const std::size_t n = level_counts[a][l];
            const std::vector<double> probes = probe_positions(n);
            for (std::size_t li = 0; li < nl; ++li) {
                const auto& line = lines[li];
                const Axis ax = line_axis(axis, n, line);
                LineBlock blk{a, l, named.size(), 0, li};
                for (double x : ax.values) {
                    named.push_back(line);
                    named.back()[axis.name] = x;
                    place_dependents(named.back(), ts.axes, line_t[li]);
                }
                blk.first_probe = named.size();
                for (double t : probes) {
                    named.push_back(line);
                    // An explicit axis is piecewise linear in t between its nodes.
                    const double x = axis.spacing == Spacing::Explicit
                                         ? [&] {
                                               const double u = t * (ax.count - 1);
                                               const std::size_t k = std::min<std::size_t>(
                                                   static_cast<std::size_t>(u), ax.count - 2);
                                               return ax.values[k] + (u - k) * (ax.values[k + 1] - ax.values[k]);
                                           }()
                                         : std::clamp(ax.warp(t), ax.min, ax.max);
                    named.back()[axis.name] = x;
                    place_dependents(named.back(), ts.axes, line_t[li]);
                }
                blocks.push_back(blk);
            }
        }
        axis_lines[a] = std::move(lines);
    }
    return d;
}

// The range of the interpolation pilot's values and the relative floor.
void record_value_range(TablePilot& pilot, const EstimateResult& r,
                        const std::vector<std::map<std::string, double>>& named, const PilotOptions& options) {
    pilot.min_value = std::numeric_limits<double>::infinity();
    pilot.signed_min = r.value.empty() ? 0.0 : r.value.front();
    pilot.signed_max = pilot.signed_min;
    for (std::size_t k = 0; k < r.value.size(); ++k) {
        const double v = r.value[k];
        pilot.signed_min = std::min(pilot.signed_min, v), pilot.signed_max = std::max(pilot.signed_max, v);
        if (std::fabs(v) > pilot.max_value && k < named.size()) pilot.max_at = named[k];
        pilot.max_value = std::max(pilot.max_value, std::fabs(v));
        pilot.min_value = std::min(pilot.min_value, std::fabs(v));
    }
    pilot.rel_floor = options.abs_floor > 0 ? options.abs_floor : options.rel_floor_factor * pilot.max_value;
    if (!(pilot.rel_floor > 0)) pilot.rel_floor = 1e-300;
}

// The interpolation errors of every axis and level, measured on the pilot's
// lines, and their fitted laws (linear and cubic).
void fit_interpolation(TablePilot& pilot, const TableSpec& ts, const InterpolationDesign& d,
                       const EstimateResult& r) {
    const std::size_t dims = ts.axes.size();
    const std::vector<LineBlock>& blocks = d.blocks;
    const std::vector<std::vector<std::size_t>>& level_counts = d.level_counts;
    const std::vector<std::vector<std::map<std::string, double>>>& axis_lines = d.axis_lines;
    const bool noisy = r.method != Method::ClosedForm;
    // Only a sampled reference's stderr is its noise; a quadrature's is the
    // difference of two rules (an overestimate of its error, which must not
    // be subtracted from the line errors: LevelErrors::denoised_*).
    const bool sampled = r.method == Method::MonteCarlo || r.method == Method::Rqmc;
    for (int m = 0; m < 2; ++m) {
        const Interpolation interp = m == 0 ? Interpolation::Linear : Interpolation::Cubic;
        std::vector<AxisFit>& fits = m == 0 ? pilot.linear : pilot.cubic;
        fits.resize(dims);
        for (std::size_t a = 0; a < dims; ++a) {
            fits[a].axis = ts.axes[a].name;
            fits[a].planned = ts.axes[a].spacing != Spacing::Explicit;
            if (level_counts[a].empty()) {  // whole-number axis: exact at its nodes
                LevelErrors e;
                e.count = ts.axes[a].count;
                e.h = 1.0 / double(std::max<std::size_t>(e.count, 2) - 1);
                fits[a].levels.push_back(e);
                continue;
            }
            for (std::size_t l = 0; l < level_counts[a].size(); ++l) {
                const std::size_t n = level_counts[a][l];
                LevelErrors e;
                e.count = n;
                e.h = 1.0 / static_cast<double>(n - 1);
                std::vector<double> abs_err, rel_err, abs_denoised, rel_denoised;
                for (const LineBlock& blk : blocks) {
                    if (blk.axis != a || blk.level != l) continue;
                    const std::vector<double> nodes(r.value.begin() + blk.first_node,
                                                    r.value.begin() + blk.first_node + n);
                    const Axis ax = line_axis(ts.axes[a], n, axis_lines[a][blk.line]);
                    const std::vector<double> probes = probe_positions(n);
                    const std::vector<double> got = interpolate_line(ax, nodes, probes, interp);
                    // (No node placement on a dependent axis: explicit nodes
                    // cannot follow eta.)
                    if (m == 0 && l + 1 == level_counts[a].size() && fits[a].planned && !ts.axes[a].dependent()) {
                        PlacementLine pl{ax.values, nodes, {}, {}};
                        for (std::size_t k = 0; k < probes.size(); ++k) {
                            pl.probe_x.push_back(std::clamp(ax.warp(probes[k]), ax.min, ax.max));
                            pl.probe_f.push_back(r.value[blk.first_probe + k]);
                        }
                        pilot.placement_lines[a].push_back(std::move(pl));
                    }
                    double node_noise = 0;  // the line's largest node stderr
                    if (sampled)
                        for (std::size_t k = blk.first_node; k < blk.first_node + n; ++k)
                            node_noise = std::max(node_noise, r.stderr_[k]);
                    for (std::size_t k = 0; k < probes.size(); ++k) {
                        const double want = r.value[blk.first_probe + k];
                        const double scale = std::max(std::fabs(want), pilot.rel_floor);
                        const double d = got[k] - want;
                        abs_err.push_back(d);
                        rel_err.push_back(d / scale);
                        const double probe_noise = sampled ? r.stderr_[blk.first_probe + k] : 0.0;
                        const double kept = std::sqrt(std::max(
                            0.0, d * d - (probe_noise * probe_noise + node_noise * node_noise)));
                        abs_denoised.push_back(kept);
                        rel_denoised.push_back(kept / scale);
                    }
                    if (noisy)
                        for (std::size_t k = blk.first_node; k < blk.first_probe + probes.size(); ++k)
                            e.noise = std::max(e.noise, r.stderr_[k]);
                }
                const ErrorStats sa = error_stats(abs_err), sr = error_stats(rel_err);
                e.max_abs = sa.max, e.rms_abs = sa.rms, e.max_rel = sr.max, e.rms_rel = sr.rms;
                const ErrorStats da = error_stats(abs_denoised), dr = error_stats(rel_denoised);
                e.denoised_max_abs = da.max, e.denoised_rms_abs = da.rms;
                e.denoised_max_rel = dr.max, e.denoised_rms_rel = dr.rms;
                fits[a].levels.push_back(e);
            }
            fit_axis(fits[a], m == 0 ? 2.0 : 3.0);
        }
    }
}

// The cost per cell of a closed form.
void closed_form_cost(const PilotContext& ctx, Backend& backend, const std::vector<double>& points,
                      const EstimateResult& r, const IntegrationSettings& ref, TablePilot& pilot,
                      const ProgressFn& progress) {
    // Cost per cell: one full launch of the backend's preferred size, as
    // `generate` runs them (the pilot's points repeated; 16384 <= cells
    // <= 131072), fastest of two.  A smaller batch measured 4x too little
    // per cell on PoCL: the cost per cell grows with the launch size.
    //
    // Expensive closed forms (e.g. the Lambert-sphere constants, a solve
    // per point): when the interpolation pilot's own launch says that
    // full launch would take more than kCostPilotSeconds, its per-point
    // cost is used instead: launch-size effects are a per-launch
    // overhead, negligible against such a per-cell cost, and the full
    // launch would cost more than the table (201 cells) it plans.
    constexpr double kCostPilotSeconds = 2.0;
    const std::size_t want = std::clamp<std::size_t>(backend.preferred_slab(), 16384, 131072);
    const std::size_t stride = ctx.model->point_stride();
    const std::size_t n_points = points.size() / stride;
    const double per_point = std::max(r.elapsed_seconds - pilot.overhead_seconds, 0.5 * r.elapsed_seconds) /
                             double(std::max<std::size_t>(n_points, 1));
    IntegrationFit f;
    f.method = Method::ClosedForm;
    if (per_point * double(want) > kCostPilotSeconds) {
        f.seconds_per_cell = per_point;
    } else {
        std::vector<double> batch;
        while (batch.size() / stride < want) batch.insert(batch.end(), points.begin(), points.end());
        const std::size_t m = batch.size() / stride;
        double t = std::numeric_limits<double>::infinity();
        for (int k = 0; k < 2; ++k)
            t = std::min(t, estimate_at(backend, *ctx.model, *ctx.quantity, ctx.options, batch, ref,
                                        progress).elapsed_seconds);
        pilot.pilot_evaluations += 2 * m;
        f.seconds_per_cell = std::max(t - pilot.overhead_seconds, 0.5 * t) / double(m);
    }
    pilot.integration.push_back(f);
}

// A quadrature whose model exposes its rule size: the rule's own error,
// measured against the finer rule (f's latest entries replaced).
void measure_rule_against_finer(const PilotContext& ctx, const TableSpec& ts, Backend& backend,
                                const std::vector<std::map<std::string, double>>& cells, const EstimateResult& e,
                                const IntegrationSettings& s, double finer, SplitMix& rng, IntegrationFit& f,
                                TablePilot& pilot, const StageProgress& stage) {
    // The stored difference |Q_n - Q_(n/2)| is the coarse
    // rule's error, ~1e3 x the n-node rule's own in the median
    // (docs/models/rough-dielectric.md, "Quadrature"): measure
    // the rule's own error against the finer rule instead, on
    // the pilot cells (max and RMS) and on as many cells of a
    // 16x larger random screen where the difference is largest
    // (max only): it is largest where the rule struggles
    // (grazing light), which 32 random cells rarely hit.
    std::vector<std::map<std::string, double>> screen(16 * cells.size());
    for (auto& c : screen) c = random_cell(ctx.fixed, ts.axes, rng);
    const EstimateResult sc =
        estimate_at(backend, *ctx.model, *ctx.quantity, ctx.options, kernel_points(ctx, screen), s,
                    stage(ts.name + ": quadrature screen"));
    // Half of them by the absolute difference, half by the
    // relative one (the target's measure is not known here).
    std::vector<std::size_t> chosen;
    for (int measure = 0; measure < 2; ++measure) {
        auto key = [&](std::size_t k) {
            return measure == 0 ? sc.stderr_[k]
                                : sc.stderr_[k] / std::max(std::fabs(sc.value[k]), pilot.rel_floor);
        };
        std::vector<std::size_t> order;
        for (std::size_t k = 0; k < screen.size(); ++k)
            if (std::find(chosen.begin(), chosen.end(), k) == chosen.end()) order.push_back(k);
        const std::size_t top = std::min((cells.size() + 1) / 2, order.size());
        std::partial_sort(order.begin(), order.begin() + top, order.end(),
                          [&](std::size_t a, std::size_t b) { return key(a) > key(b); });
        chosen.insert(chosen.end(), order.begin(), order.begin() + top);
    }
    std::vector<std::map<std::string, double>> probe = cells;
    std::vector<double> rule_value = e.value;
    for (std::size_t k : chosen) {
        probe.push_back(screen[k]);
        rule_value.push_back(sc.value[k]);
    }
    for (auto& c : probe) c["nodes"] = finer;
    const EstimateResult fine =
        estimate_at(backend, *ctx.model, *ctx.quantity, ctx.options, kernel_points(ctx, probe), s,
                    stage(ts.name + ": quadrature reference, " + number_text(finer) + " nodes"));
    std::vector<double> abs_err(probe.size()), rel_err(probe.size());
    for (std::size_t k = 0; k < probe.size(); ++k) {
        abs_err[k] = std::fabs(rule_value[k] - fine.value[k]);
        rel_err[k] = abs_err[k] / std::max(std::fabs(fine.value[k]), pilot.rel_floor);
    }
    // RMS over the random cells only (the screened ones are the worst).
    const std::vector<double> random_abs(abs_err.begin(), abs_err.begin() + cells.size()),
        random_rel(rel_err.begin(), rel_err.begin() + cells.size());
    const ErrorStats ma = error_stats(abs_err), mr = error_stats(rel_err);
    f.max_abs.back() = ma.max, f.rms_abs.back() = error_stats(random_abs).rms;
    f.max_rel.back() = mr.max, f.rms_rel.back() = error_stats(random_rel).rms;
    f.cell_abs = random_abs;
    f.cell_rel = random_rel;
    f.reference_nodes = finer;
    pilot.pilot_evaluations += screen.size() + probe.size();
}

// A quadrature's cost per cell, from a launch of a few hundred cells or more.
void quadrature_cost_pilot(const PilotContext& ctx, const TableSpec& ts, const PilotOptions& options,
                           Backend& backend, const std::vector<double>& cell_points, std::size_t n_cells,
                           IntegrationFit& f, TablePilot& pilot, const StageProgress& stage) {
    // Cost per cell from a launch of a few hundred cells or more:
    // the 32 pilot cells are too few work items to keep every core
    // of a CPU device busy, and measured 3x the cost per cell that
    // `generate` then paid (docs/planning.md, "How good are the
    // predictions").  The pilot cells repeated, for about 1 s.
    const double run = f.seconds_per_cell * double(n_cells);
    const std::size_t reps = static_cast<std::size_t>(
        std::clamp(std::floor(1.0 / std::max(run, 1e-9)), 1.0, 64.0));
    if (reps >= 4) {
        std::vector<double> batch;
        for (std::size_t k = 0; k < reps; ++k)
            batch.insert(batch.end(), cell_points.begin(), cell_points.end());
        IntegrationSettings s;
        s.method = Method::Quadrature;
        s.seed = options.seed + kPilotSeedOffset;
        const double t = estimate_at(backend, *ctx.model, *ctx.quantity, ctx.options, batch, s,
                                     stage(ts.name + ": quadrature cost pilot")).elapsed_seconds;
        f.seconds_per_cell = std::max(t - pilot.overhead_seconds, 0.5 * t) /
                             double(reps * n_cells);
        pilot.pilot_evaluations += reps * n_cells;
    }
}

void mark_unseen_variance(TablePilot& pilot) {
    // Rare events: a budget at which no pilot cell saw two different
    // sample values (stderr exactly 0 everywhere, while the values are
    // not all 0) means the stderrs measure too few events to be trusted
    // as the noise (lambert-sphere-brdf `brdf_mc_remainder`, the tail of
    // the walks beyond order 1000).  The line errors are then used as
    // measured, noise included (LevelErrors::denoised_* = the raw ones).
    for (const IntegrationFit& f : pilot.integration)
        for (double m : f.max_abs)
            if (f.method != Method::Quadrature && m == 0 && pilot.max_value > 0) pilot.variance_unseen = true;
    if (pilot.variance_unseen)
        for (int m = 0; m < 2; ++m)
            for (AxisFit& fit : m == 0 ? pilot.linear : pilot.cubic)
                for (LevelErrors& l : fit.levels) {
                    l.denoised_max_abs = l.max_abs, l.denoised_rms_abs = l.rms_abs;
                    l.denoised_max_rel = l.max_rel, l.denoised_rms_rel = l.rms_rel;
                }
}

// The integration pilot of an integral (quadrature, or MC and RQMC): its
// errors and costs per budget on random cells of the grid.  Returns the
// cells' kernel points (for the large-grid pilot).
std::vector<double> integration_pilot(const PilotContext& ctx, const TableSpec& ts, const PilotOptions& options,
                                      Backend& backend, SplitMix& rng, TablePilot& pilot,
                                      const StageProgress& stage) {
    // Random cells of the spec's grid.
    std::vector<std::map<std::string, double>> cells(options.cells);
    for (auto& c : cells) c = random_cell(ctx.fixed, ts.axes, rng);
    const std::vector<double> cell_points = kernel_points(ctx, cells);
    const std::vector<Method> methods =
        ctx.quantity->kind == QuantityKind::Quadrature ? std::vector<Method>{Method::Quadrature}
                                                       : std::vector<Method>{Method::MonteCarlo, Method::Rqmc};
    for (Method method : methods) {
        IntegrationFit f;
        f.method = method;
        const std::vector<std::uint64_t> budgets =
            method == Method::Quadrature ? std::vector<std::uint64_t>{0} : options.integration_samples;
        for (std::uint64_t n : budgets) {
            IntegrationSettings s;
            s.method = method;
            s.samples = n;
            s.seed = options.seed + kPilotSeedOffset;
            const EstimateResult e = estimate_at(
                backend, *ctx.model, *ctx.quantity, ctx.options, cell_points, s,
                stage(ts.name + ": " + to_string(method) + " pilot, " + std::to_string(n) + " samples"));
            std::vector<double> rel(e.stderr_.size());
            for (std::size_t k = 0; k < rel.size(); ++k)
                rel[k] = e.stderr_[k] / std::max(std::fabs(e.value[k]), pilot.rel_floor);
            const ErrorStats sa = error_stats(e.stderr_), sr = error_stats(rel);
            f.samples.push_back(n);
            f.max_abs.push_back(sa.max), f.rms_abs.push_back(sa.rms);
            f.max_rel.push_back(sr.max), f.rms_rel.push_back(sr.rms);
            f.seconds.push_back(e.elapsed_seconds);
            f.cell_abs = e.stderr_;
            f.cell_rel = rel;
            f.cell_value.resize(e.value.size());
            for (std::size_t k = 0; k < e.value.size(); ++k) f.cell_value[k] = std::fabs(e.value[k]);
            const double work = std::max(0.0, e.elapsed_seconds - pilot.overhead_seconds);
            if (method == Method::Quadrature)
                f.seconds_per_cell = work / cells.size();
            else
                f.seconds_per_sample = work / (double(cells.size()) * double(n));
            // (A `nodes` left out of the spec is in ctx.fixed at its default.)
            const double finer = finer_rule_nodes(*ctx.model, *ctx.quantity, ctx.fixed);
            if (finer > 0) measure_rule_against_finer(ctx, ts, backend, cells, e, s, finer, rng, f, pilot, stage);
        }
        if (method == Method::Quadrature && !cells.empty())
            quadrature_cost_pilot(ctx, ts, options, backend, cell_points, cells.size(), f, pilot, stage);
        if (method != Method::Quadrature) {
            std::vector<double> x(f.samples.begin(), f.samples.end());
            // RQMC: q within [0.5, 1] (no worse than MC, no better than
            // the rate of smooth integrands in low dimension), through
            // the largest budget's measurement.
            auto fit = [&](const std::vector<double>& y) {
                return method == Method::MonteCarlo
                           ? fit_power_law_fixed(x, y, -0.5)
                           : anchored_fit(fit_power_law(x, y), x.back(), y.back(), -1.0, -0.5);
            };
            f.fit_max_abs = fit(f.max_abs), f.fit_rms_abs = fit(f.rms_abs);
            f.fit_max_rel = fit(f.max_rel), f.fit_rms_rel = fit(f.rms_rel);
        }
        if (f.reference_nodes > 0) {
            // The interpolation levels took the stored difference as
            // their reference's noise (up to ~1e3 x the rule's error),
            // which hid every level below 3x it from the fits: the
            // rule's measured error is that noise.
            for (int m = 0; m < 2; ++m)
                for (AxisFit& fit : m == 0 ? pilot.linear : pilot.cubic) {
                    for (LevelErrors& l : fit.levels) l.noise = f.max_abs.back();
                    fit_axis(fit, m == 0 ? 2.0 : 3.0);
                }
        }
        pilot.integration.push_back(f);
    }
    mark_unseen_variance(pilot);
    return cell_points;
}

}  // namespace

TablePilot run_pilot(const Spec& spec, std::size_t table_index, Backend& backend,
                     const PilotOptions& options, const PilotProgressFn& progress) {
    const double start = now_seconds();
    if (table_index >= spec.tables.size()) throw InputError("plan: no table " + std::to_string(table_index));
    const TableSpec& ts = spec.tables[table_index];
    PilotContext ctx;
    ctx.model = &find_model(spec.model);
    ctx.quantity = &ctx.model->quantity(ts.quantity);
    ctx.where = spec.file + ": table '" + ts.name + "'";
    ctx.options = resolve_options(*ctx.model, ts.options, ctx.where);
    ctx.fixed = ts.fixed;
    if (options.lines < 1 || options.cells < 1) throw InputError("plan: the pilot needs lines and cells >= 1");

    TablePilot pilot;
    pilot.table = ts.name;
    pilot.quantity = ts.quantity;
    pilot.kind = ctx.quantity->kind;
    pilot.axes = ts.axes;
    const std::size_t dims = ts.axes.size();
    (void)Grid(ts.axes);  // InputError unless every dependent axis follows an independent one
    pilot.placement_lines.resize(dims);
    SplitMix rng{options.seed * 0x9E3779B97F4A7C15ull + table_index + 1};

    const InterpolationDesign design = design_interpolation_pilot(ctx, ts, options, rng);
    const std::vector<std::map<std::string, double>>& named = design.named;
    const std::vector<double> points = kernel_points(ctx, named);

    IntegrationSettings ref;
    ref.method = resolve_method(*ctx.quantity, Method::Auto);
    if (ctx.quantity->kind == QuantityKind::Integral) ref.samples = options.reference_samples;
    ref.seed = options.seed + 0x5EED;
    const StageProgress stage = [&](const std::string& name) -> ProgressFn {
        if (!progress) return nullptr;
        return [&progress, name](const Progress& p) { progress(name, p); };
    };

    // Launch overhead: the fastest of three one-point runs, after a first one
    // that builds (or loads) the kernel.  Minima, because the machine may be
    // shared: the fastest run is the one least disturbed.
    const std::size_t stride = ctx.model->point_stride();
    const std::vector<double> one(points.begin(), points.begin() + stride);
    pilot.startup_seconds = estimate_at(backend, *ctx.model, *ctx.quantity, ctx.options, one, ref).elapsed_seconds;
    // Kept for the large-grid pilot below (its variant's load, as a fresh
    // process pays it).
    const std::unique_ptr<Backend> fresh = options.fresh_backend ? options.fresh_backend() : nullptr;
    if (fresh)
        pilot.startup_seconds = estimate_at(*fresh, *ctx.model, *ctx.quantity, ctx.options, one, ref).elapsed_seconds;
    pilot.kernel = spec.model + "\n" + ts.quantity;
    for (int o : ctx.options) pilot.kernel += " " + std::to_string(o);
    pilot.compression = spec.output.compression;
    pilot.keep_stderr = spec.output.keep_stderr;
    pilot.preferred_slab = backend.preferred_slab();
    pilot.process_seconds = options.process_seconds;
    pilot.overhead_seconds = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 3; ++k)
        pilot.overhead_seconds = std::min(
            pilot.overhead_seconds,
            estimate_at(backend, *ctx.model, *ctx.quantity, ctx.options, one, ref).elapsed_seconds);

    const EstimateResult r = estimate_at(backend, *ctx.model, *ctx.quantity, ctx.options, points, ref,
                                         stage(ts.name + ": interpolation pilot"));
    pilot.pilot_evaluations = named.size();
    record_value_range(pilot, r, named, options);
    fit_interpolation(pilot, ts, design, r);

    // ---- cost per cell (closed form, quadrature) and integration error.
    std::vector<double> integral_cells;  // the integration pilot's cell points (large-grid pilot)
    if (ctx.quantity->kind == QuantityKind::ClosedForm) {
        closed_form_cost(ctx, backend, points, r, ref, pilot, stage(ts.name + ": cost pilot"));
    } else {
        integral_cells = integration_pilot(ctx, ts, options, backend, rng, pilot, stage);
    }
    // ---- PoCL's large-grid kernel variant (kLargeGridWorkItems).
    // generate's launches grow towards 0.5 s each, up to 131072 work items;
    // cheap work items (micrograin's one-sample RQMC items, closed forms)
    // reach 65536, where PoCL compiles a second variant of the kernel: 2-8 s
    // that a pilot of small launches never paid nor measured (docs/planning.md,
    // "How good are the predictions").  One launch of that size here builds it
    // into PoCL's cache (so the generate after `plan` only loads it); the same
    // launch on the fresh backend measures that load, and again the cost per
    // work item in that variant.
    for (IntegrationFit& f : pilot.integration)
        large_grid_pilot(ctx, spec, f, ctx.quantity->kind == QuantityKind::ClosedForm ? points : integral_cells,
                         ref, backend, fresh.get(), pilot, stage(ts.name + ": large-grid pilot"));
    pilot.pilot_seconds = now_seconds() - start;
    return pilot;
}

// --------------------------------------------------------------- candidates

void check_target(const PlanTarget& t) {
    if (t.accuracy && t.budget)
        throw InputError("--accuracy and --budget exclude each other: give one target (an error "
                         "to reach, or seconds to spend)");
    if (t.accuracy && !(std::isfinite(*t.accuracy) && *t.accuracy > 0))
        throw InputError("--accuracy must be a finite number > 0, got " + number_text(*t.accuracy, 6));
    if (t.budget && !(std::isfinite(*t.budget) && *t.budget > 0))
        throw InputError("--budget must be a finite number of seconds > 0, got " + number_text(*t.budget, 6));
}

namespace {

const AxisFit& axis_fit(const TablePilot& p, const PlanTarget& t, std::size_t a) {
    return t.interpolation == Interpolation::Linear ? p.linear[a] : p.cubic[a];
}
const PowerFit& max_fit(const AxisFit& f, const PlanTarget& t) { return t.absolute ? f.max_abs : f.max_rel; }
const PowerFit& rms_fit(const AxisFit& f, const PlanTarget& t) { return t.absolute ? f.rms_abs : f.rms_rel; }

// The error of an axis at h: the fit, or without one (an explicit axis,
// every level exact or below the reference noise) the finest level's
// measurement, a constant.  Where that measurement is below 3 x its
// reference's noise (the rule that keeps a level out of the fits: its error
// is mostly the noise's), it is taken with the noise of the pilot's Monte
// Carlo values removed (LevelErrors::denoised_*): the noise of the table's
// own cells is the integration term, and counting the pilot's again here
// over-predicted 3x where every axis is explicit (lambert-sphere-modes
// `ms_mc`, docs/planning.md).  Above 3 x the noise the raw measurement
// stands: removing the noise there took real error away at a narrow peak
// (micrograin-slice86 `diffuse_explicit`, 3.6 x its noise).
void axis_error(const AxisFit& f, const PlanTarget& t, double h, double& max_e, double& rms_e) {
    const PowerFit &fm = max_fit(f, t), &fr = rms_fit(f, t);
    const LevelErrors& finest = f.levels.back();
    const bool noisy = noise_dominated(finest);
    const double finest_max = t.absolute ? (noisy ? finest.denoised_max_abs : finest.max_abs)
                                         : (noisy ? finest.denoised_max_rel : finest.max_rel);
    const double finest_rms = t.absolute ? (noisy ? finest.denoised_rms_abs : finest.rms_abs)
                                         : (noisy ? finest.denoised_rms_rel : finest.rms_rel);
    max_e = f.planned && fm.valid ? fm.eval(h) : finest_max;
    rms_e = f.planned && fr.valid ? fr.eval(h) : finest_rms;
}

}  // namespace

std::vector<std::size_t> balanced_counts(const TablePilot& pilot, const PlanTarget& target,
                                         double interpolation_target) {
    const std::size_t dims = pilot.axes.size();
    std::size_t planned = 0;
    for (std::size_t a = 0; a < dims; ++a) planned += axis_fit(pilot, target, a).planned;
    std::vector<std::size_t> counts(dims);
    const double share = interpolation_target / std::max<std::size_t>(planned, 1);
    for (std::size_t a = 0; a < dims; ++a) {
        const AxisFit& f = axis_fit(pilot, target, a);
        const PowerFit& fm = max_fit(f, target);
        if (!f.planned || !fm.valid || !(fm.p > 0)) {
            counts[a] = pilot.axes[a].count;
            continue;
        }
        // C h^p <= share  <=>  h <= (share / C)^(1/p).
        const double h = std::pow(share / fm.c, 1.0 / fm.p);
        const double n = 1 + std::ceil(1 / h - 1e-9);
        counts[a] = static_cast<std::size_t>(std::clamp(n, double(kMinCount), double(kMaxCount)));
    }
    return counts;
}

namespace {
double table_write_seconds(const TablePilot& pilot, Method method, double cells, StoredType type) {
    const bool computed = method != Method::ClosedForm;
    return write_seconds(cells, type, pilot.compression, computed && pilot.keep_stderr, computed);
}
}  // namespace

TablePlan predict_table(const TablePilot& pilot, const PlanTarget& target,
                        const std::vector<std::size_t>& counts, Method method,
                        std::uint64_t samples, StoredType stored_type) {
    TablePlan tp;
    tp.table = pilot.table;
    tp.counts = counts;
    tp.cells = 1;
    double interp_rms2 = 0;
    for (std::size_t a = 0; a < counts.size(); ++a) {
        tp.cells *= double(counts[a]);
        double m = 0, r = 0;
        axis_error(axis_fit(pilot, target, a), target, 1.0 / double(counts[a] - 1), m, r);
        // Max: the per-axis maxima add (triangle inequality on the tensor
        // product's error split; their worst points may coincide).
        tp.interpolation_max += m;
        interp_rms2 += r * r;
    }
    tp.interpolation_rms = std::sqrt(interp_rms2);

    // Integration: the quadrature's two-rule difference is an error
    // estimate, not a standard deviation: its maximum is taken as is.
    const IntegrationFit* f = nullptr;
    for (const IntegrationFit& g : pilot.integration)
        if (g.method == method || pilot.kind == QuantityKind::ClosedForm) f = &g;
    if (!f) {
        tp.error_max = tp.error_rms = std::numeric_limits<double>::infinity();
        tp.seconds = std::numeric_limits<double>::infinity();
        return tp;
    }
    if (f->method == Method::Quadrature) {
        tp.integration_max = target.absolute ? f->max_abs.front() : f->max_rel.front();
        tp.integration_rms = target.absolute ? f->rms_abs.front() : f->rms_rel.front();
    } else if (f->method != Method::ClosedForm) {
        // Every pilot cell's stderr scaled from the largest pilot budget with
        // the fitted rate, then the median of the largest error over the
        // table's cells (expected_max_error).
        const double n = double(samples);
        const PowerFit& fm = target.absolute ? f->fit_max_abs : f->fit_max_rel;
        const std::vector<double>& cell = target.absolute ? f->cell_abs : f->cell_rel;
        const double scale = fm.valid ? std::pow(n / double(f->samples.back()), fm.p) : 1.0;
        std::vector<double> sigma(cell.size());
        for (std::size_t k = 0; k < cell.size(); ++k) sigma[k] = cell[k] * scale;
        tp.integration_max = expected_max_error(sigma, tp.cells);
        tp.integration_rms = (target.absolute ? f->fit_rms_abs : f->fit_rms_rel).eval(n);
    }
    // The engine run, then the table's HDF5 write (generate.cpp keeps no
    // stderr and no samples for closed forms).
    bool large_grid = false;
    tp.seconds = engine_seconds(pilot, *f, tp.cells, samples, &large_grid) +
                 table_write_seconds(pilot, f->method, tp.cells, stored_type);
    if (!pilot.kernel.empty()) tp.kernel = pilot.kernel + "\n" + to_string(f->method);
    tp.kernel_load_seconds = pilot.startup_seconds;
    tp.large_grid_load_seconds = large_grid ? f->large_grid_load_seconds : 0.0;

    // Storage: half an ulp of the stored value (relative), or of the floor.
    const StorageRounding s = storage_rounding(stored_type);
    if (pilot.max_value > s.max_value)
        tp.storage_max = std::numeric_limits<double>::infinity();
    else
        // Relative: a subnormal's abs error counts against max(|v|, floor),
        // and no |v| below the pilot's smallest is expected.
        tp.storage_max = target.absolute
                             ? std::max(s.rel * pilot.max_value, s.abs)
                             : std::max(s.rel, s.abs / std::max(pilot.rel_floor, pilot.min_value));
    combine_errors(tp);
    return tp;
}

namespace {

// The methods a set of pilots can be planned with (sampled methods when any
// table is an integral, else quadrature, else the closed form), and the
// largest |value| the pilots saw (the scale of absolute targets).
std::vector<Method> candidate_methods(const std::vector<TablePilot>& pilots, double& scale) {
    bool integral = false, quadrature = false;
    scale = 0;
    for (const TablePilot& p : pilots) {
        integral |= p.kind == QuantityKind::Integral;
        quadrature |= p.kind == QuantityKind::Quadrature;
        scale = std::max(scale, p.max_value);
    }
    if (integral) return {Method::MonteCarlo, Method::Rqmc};
    if (quadrature) return {Method::Quadrature};
    return {Method::ClosedForm};
}

}  // namespace

std::vector<Candidate> make_candidates(const std::vector<TablePilot>& pilots, const PlanTarget& target) {
    // Plain tables are the case without recombined groups: one enumeration
    // serves both (make_recombined_candidates).
    return make_recombined_candidates(pilots, target, {});
}

std::vector<Candidate> pareto_front(const std::vector<Candidate>& candidates) {
    std::vector<Candidate> front;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
        const Candidate& a = candidates[i];
        bool dominated = false;
        for (std::size_t j = 0; j < candidates.size() && !dominated; ++j) {
            if (i == j) continue;
            const Candidate& b = candidates[j];
            const bool no_worse = b.seconds <= a.seconds && b.error_max <= a.error_max && b.bytes <= a.bytes;
            const bool better = b.seconds < a.seconds || b.error_max < a.error_max || b.bytes < a.bytes;
            // Exact duplicates: keep the first.
            dominated = no_worse && (better || j < i);
        }
        if (!dominated) front.push_back(a);
    }
    std::sort(front.begin(), front.end(), [](const Candidate& a, const Candidate& b) {
        return a.seconds != b.seconds ? a.seconds < b.seconds : a.error_max < b.error_max;
    });
    return front;
}

std::optional<std::size_t> choose_plan(const std::vector<Candidate>& c, const PlanTarget& target) {
    std::optional<std::size_t> best;
    if (target.accuracy) {
        for (std::size_t i = 0; i < c.size(); ++i) {
            if (!(c[i].error_max <= *target.accuracy)) continue;
            if (!best) { best = i; continue; }
            const Candidate& b = c[*best];
            const bool tie = std::fabs(c[i].seconds - b.seconds) <= 0.01 * std::max(c[i].seconds, b.seconds);
            if (tie ? (c[i].bytes < b.bytes || (c[i].bytes == b.bytes && c[i].error_max < b.error_max))
                    : c[i].seconds < b.seconds)
                best = i;
        }
    } else if (target.budget) {
        for (std::size_t i = 0; i < c.size(); ++i) {
            if (!(c[i].seconds <= *target.budget)) continue;
            if (!best || c[i].error_max < c[*best].error_max ||
                (c[i].error_max == c[*best].error_max && c[i].seconds < c[*best].seconds))
                best = i;
        }
    }
    return best;
}

// --------------------------------------------------------------- recombined tables

std::vector<RecombinedGroup> recombined_groups(const Spec& spec,
                                               const std::vector<std::size_t>& table_indices) {
    std::vector<RecombinedGroup> out;
    for (const RecombinedSpec& rs : spec.recombined) {
        RecombinedGroup g;
        g.name = rs.name;
        bool complete = true;
        for (const auto& [table, coeffs] : rs.terms) {
            std::optional<std::size_t> k;
            for (std::size_t j = 0; j < table_indices.size(); ++j)
                if (table_indices[j] < spec.tables.size() && spec.tables[table_indices[j]].name == table) k = j;
            if (!k) { complete = false; break; }
            g.terms.push_back(*k);
            g.coeffs.push_back(coeffs);
        }
        if (!complete || g.terms.empty()) continue;
        // Shared nodes need the same axes (names, ranges, spacings): only the
        // counts are planned.
        const TableSpec& first = spec.tables[table_indices[g.terms.front()]];
        for (std::size_t k = 1; k < g.terms.size(); ++k) {
            const TableSpec& t = spec.tables[table_indices[g.terms[k]]];
            bool same = t.axes.size() == first.axes.size();
            for (std::size_t a = 0; same && a < t.axes.size(); ++a)
                same = t.axes[a].name == first.axes[a].name && t.axes[a].min == first.axes[a].min &&
                       t.axes[a].max == first.axes[a].max && t.axes[a].spacing == first.axes[a].spacing &&
                       (t.axes[a].spacing != Spacing::Explicit || t.axes[a].values == first.axes[a].values);
            if (!same)
                throw InputError(spec.file + ": recombined table '" + rs.name + "': terms '" + first.name +
                                 "' and '" + t.name + "' differ in their axes (names, ranges or spacings); "
                                 "the planner can share node counts only");
        }
        if (rs.range) {
            g.lo = rs.range->first, g.hi = rs.range->second;
        } else if (const ParameterInfo* info = find_model(spec.model).find_parameter(rs.parameter)) {
            g.lo = info->min, g.hi = info->max;
        } else {
            g.lo = g.hi = rs.stored_at;
        }
        out.push_back(std::move(g));
    }
    return out;
}

std::vector<std::size_t> shared_counts(const RecombinedGroup& group,
                                       const std::vector<std::vector<std::size_t>>& counts) {
    std::vector<std::size_t> shared;
    for (std::size_t t : group.terms) {
        if (shared.empty()) shared.assign(counts[t].size(), 0);
        for (std::size_t a = 0; a < shared.size() && a < counts[t].size(); ++a)
            shared[a] = std::max(shared[a], counts[t][a]);
    }
    return shared;
}

TablePlan predict_recombined(const RecombinedGroup& group, const std::vector<TablePilot>& pilots,
                             const std::vector<TablePlan>& term_plans, const PlanTarget& target) {
    TablePlan tp;
    tp.table = group.name;
    if (!term_plans.empty()) tp.counts = term_plans.front().counts, tp.cells = term_plans.front().cells;
    constexpr int kSteps = 128;
    bool nonnegative = true, floor_bound = true;
    for (std::size_t k = 0; k < group.terms.size(); ++k) {
        const TablePilot& p = pilots[group.terms[k]];
        nonnegative = nonnegative && p.signed_min >= 0;
        // A floor at or above every value (e.g. albedos with floor 1): the
        // relative errors are absolute errors / floor, and add like them.
        floor_bound = floor_bound && p.rel_floor >= p.max_value;
    }
    for (int s = 0; s <= kSteps; ++s) {
        const double p = group.lo + (group.hi - group.lo) * double(s) / kSteps;
        TablePlan at;
        for (std::size_t k = 0; k < group.terms.size() && k < term_plans.size(); ++k) {
            const double c = polynomial_at(group.coeffs[k], p);
            const TablePlan& t = term_plans[k];
            if (target.absolute || (floor_bound && c >= 0)) {
                at.interpolation_max += std::fabs(c) * t.interpolation_max;
                at.interpolation_rms += std::fabs(c) * t.interpolation_rms;
                at.integration_max += std::fabs(c) * t.integration_max;
                at.integration_rms += std::fabs(c) * t.integration_rms;
                at.storage_max += std::fabs(c) * t.storage_max;
                at.error_max += std::fabs(c) * t.error_max;
                at.error_rms += std::fabs(c) * t.error_rms;
            } else if (!(c >= 0 && nonnegative)) {
                at.error_max = at.error_rms = std::numeric_limits<double>::infinity();
            } else if (c > 0) {
                // A weighted mean of the terms' relative errors is at most
                // the largest: each part's bound is the largest term's.
                at.interpolation_max = std::max(at.interpolation_max, t.interpolation_max);
                at.interpolation_rms = std::max(at.interpolation_rms, t.interpolation_rms);
                at.integration_max = std::max(at.integration_max, t.integration_max);
                at.integration_rms = std::max(at.integration_rms, t.integration_rms);
                at.storage_max = std::max(at.storage_max, t.storage_max);
                at.error_max = std::max(at.error_max, t.error_max);
                at.error_rms = std::max(at.error_rms, t.error_rms);
            }
        }
        if (at.error_max >= tp.error_max) {
            const std::vector<std::size_t> counts = tp.counts;
            const double cells = tp.cells;
            tp = at;
            tp.table = group.name, tp.counts = counts, tp.cells = cells;
        }
    }
    tp.seconds = 0;  // formed from the terms in memory: the terms carry the time
    return tp;
}

namespace {

// A computed table joins a candidate: its errors (the worst table's), time
// and stored bytes.
void add_table(Candidate& c, const TablePlan& tp, double bytes_per_cell) {
    c.tables.push_back(tp);
    c.error_max = std::max(c.error_max, tp.error_max);
    c.error_rms = std::max(c.error_rms, tp.error_rms);
    c.seconds += tp.seconds;
    c.bytes += tp.cells * bytes_per_cell;
}

// The recombined tables of a candidate, after its computed ones (their terms):
// no time of their own, their values stored at the recombination points.
void add_recombined(Candidate& c, const std::vector<RecombinedGroup>& groups,
                    const std::vector<TablePilot>& pilots, const PlanTarget& target, double bytes_per_cell) {
    for (const RecombinedGroup& g : groups) {
        std::vector<TablePlan> terms;
        for (std::size_t t : g.terms) terms.push_back(c.tables[t]);
        c.tables.push_back(predict_recombined(g, pilots, terms, target));
        const TablePlan& tp = c.tables.back();
        c.error_max = std::max(c.error_max, tp.error_max);
        c.error_rms = std::max(c.error_rms, tp.error_rms);
        c.bytes += tp.cells * bytes_per_cell;
    }
}

}  // namespace

std::vector<Candidate> make_recombined_candidates(const std::vector<TablePilot>& pilots,
                                                  const PlanTarget& target,
                                                  const std::vector<RecombinedGroup>& groups) {
    std::vector<Candidate> out;
    if (pilots.empty()) return out;
    double scale = 0;
    const std::vector<Method> methods = candidate_methods(pilots, scale);
    for (int k = 1; k <= 26; ++k) {
        const double interp_target = std::ldexp(1.0, -k) * (target.absolute ? std::max(scale, 1e-300) : 1.0);
        std::vector<std::vector<std::size_t>> counts;
        for (const TablePilot& p : pilots) counts.push_back(balanced_counts(p, target, interp_target));
        // Each group's terms on one layout: per axis the largest need.
        for (const RecombinedGroup& g : groups) {
            const std::vector<std::size_t> shared = shared_counts(g, counts);
            for (std::size_t t : g.terms) counts[t] = shared;
        }
        double cells_max = 0;
        for (const auto& c : counts) {
            double cells = 1;
            for (std::size_t n : c) cells *= double(n);
            cells_max = std::max(cells_max, cells);
        }
        if (cells_max > kMaxCells) continue;
        double process = 0;  // once per generate process: device set-up (measured), start, exit
        for (const TablePilot& p : pilots) process = std::max(process, p.process_seconds);
        process += process_fixed_seconds();
        for (Method m : methods) {
            std::vector<std::uint64_t> budgets = {0};
            if (m == Method::MonteCarlo || m == Method::Rqmc)
                budgets = {1u << 8, 1u << 10, 1u << 12, 1u << 14, 1u << 16, 1u << 18, 1u << 20, 1u << 22};
            for (std::uint64_t n : budgets)
                for (StoredType st : {StoredType::Float16, StoredType::Float32}) {
                    Candidate c;
                    c.method = m;
                    c.samples = n;
                    c.stored_type = st;
                    c.interpolation_target = interp_target;
                    c.seconds = process;
                    const double bytes_per_cell = st == StoredType::Float16 ? 2 : 4;
                    for (std::size_t i = 0; i < pilots.size(); ++i)
                        add_table(c, predict_table(pilots[i], target, counts[i], m, n, st), bytes_per_cell);
                    c.seconds -= shared_kernel_saving(c.tables);
                    add_recombined(c, groups, pilots, target, bytes_per_cell);
                    if (std::isfinite(c.error_max) && std::isfinite(c.seconds)) out.push_back(std::move(c));
                }
        }
    }
    return out;
}

// --------------------------------------------------------------- quadrature reference

double finer_rule_nodes(const ModelInfo& model, const QuantityInfo& quantity,
                        const std::map<std::string, double>& fixed) {
    if (quantity.kind != QuantityKind::Quadrature) return 0;
    const ParameterInfo* rule = model.find_parameter("nodes");
    const auto it = fixed.find("nodes");
    if (!rule || it == fixed.end()) return 0;
    const double finer = std::min(rule->max, std::max(24.0, 2 * it->second));
    return finer > it->second ? finer : 0.0;
}

// --------------------------------------------------------------- the spec as written

namespace {

// Adaptive sampling (host/engine/estimate.cpp): a cell stops once its stderr <= max(tol
// |value|, abs_floor); otherwise it asks for N (stderr / target)^2 x 1.1
// samples, at least 2N and at most 16N, capped at max_samples.  Simulated per
// pilot cell with the fitted stderr(N) = sigma_pilot (N / N_pilot)^q.
void predict_adaptive(const TablePilot& pilot, const IntegrationFit& f, const PlanTarget& target,
                      const IntegrationSettings& s, TablePlan& tp) {
    const PowerFit& fa = f.fit_max_abs;
    const double q = fa.valid ? fa.p : -0.5;
    const double n_pilot = double(f.samples.back());
    const double n0 = double(s.samples ? s.samples : kDefaultSamplesPerCell);
    const double n_cap = double(s.max_samples);
    std::vector<double> sigma(f.cell_abs.size());
    double samples_sum = 0, rounds_max = 0, rms2 = 0;
    for (std::size_t k = 0; k < f.cell_abs.size(); ++k) {
        const double value = k < f.cell_value.size() ? f.cell_value[k] : 0.0;
        const double goal = std::max(s.tolerance * value, s.abs_floor);
        auto sd = [&](double n) { return f.cell_abs[k] * std::pow(n / n_pilot, q); };
        double n = std::min(n0, n_cap);
        int rounds = 1;
        while (sd(n) > goal && n < n_cap) {
            const double ratio = sd(n) / goal;
            n = std::min(std::clamp(std::ceil(n * ratio * ratio * 1.1), 2 * n, 16 * n), n_cap);
            ++rounds;
        }
        const double e = sd(n);
        sigma[k] = target.absolute ? e : e / std::max(value, pilot.rel_floor);
        rms2 += sigma[k] * sigma[k];
        samples_sum += n;
        rounds_max = std::max(rounds_max, double(rounds));
    }
    if (sigma.empty()) return;
    const double mean_samples = samples_sum / double(sigma.size());
    tp.integration_max = expected_max_error(sigma, tp.cells);
    tp.integration_rms = std::sqrt(rms2 / double(sigma.size()));
    tp.seconds = pilot.startup_seconds + rounds_max * pilot.overhead_seconds +
                 tp.cells * mean_samples * f.seconds_per_sample;
}

}  // namespace

std::optional<Candidate> predict_as_written(const Spec& spec, const std::vector<TablePilot>& pilots,
                                            const PlanTarget& target,
                                            const std::vector<RecombinedGroup>& groups,
                                            std::string& why) {
    Candidate c;
    c.stored_type = spec.output.stored_type;
    for (const TablePilot& p : pilots) c.seconds = std::max(c.seconds, p.process_seconds);
    c.seconds += process_fixed_seconds();
    c.samples = spec.integration.samples ? spec.integration.samples : kDefaultSamplesPerCell;
    const double bytes_per_cell = c.stored_type == StoredType::Float16   ? 2
                                  : c.stored_type == StoredType::Float64 ? 8
                                                                         : 4;
    const ModelInfo& model = find_model(spec.model);
    for (const TablePilot& p : pilots) {
        const TableSpec* ts = nullptr;
        for (const TableSpec& t : spec.tables)
            if (t.name == p.table) ts = &t;
        if (!ts) throw Error("plan: no spec table '" + p.table + "'");
        const Method m = resolve_table_method(model.quantity(ts->quantity), spec.integration.method);
        if (m != Method::ClosedForm && c.method == Method::ClosedForm) c.method = m;
        std::vector<std::size_t> counts;
        for (const Axis& a : p.axes) counts.push_back(a.count);
        TablePlan tp = predict_table(p, target, counts, m, c.samples, c.stored_type);
        if (!std::isfinite(tp.seconds)) {
            why = "table '" + p.table + "': its method " + to_string(m) + " was not piloted";
            return std::nullopt;
        }
        if (spec.integration.tolerance > 0 && (m == Method::MonteCarlo || m == Method::Rqmc)) {
            for (const IntegrationFit& f : p.integration)
                if (f.method == m) {
                    predict_adaptive(p, f, target, spec.integration, tp);
                    tp.seconds += table_write_seconds(p, m, tp.cells, c.stored_type);
                    tp.large_grid_load_seconds = 0;  // not counted by predict_adaptive
                }
            combine_errors(tp);
        }
        add_table(c, tp, bytes_per_cell);
    }
    c.seconds -= shared_kernel_saving(c.tables);
    add_recombined(c, groups, pilots, target, bytes_per_cell);
    return c;
}

// --------------------------------------------------------------- output

std::string planned_spec_text(const Spec& spec, const std::vector<std::size_t>& table_indices,
                              const Candidate& plan, const std::vector<std::string>& header) {
    toml::table root;
    try {
        root = toml::parse(spec.text, spec.file);
    } catch (const toml::parse_error& e) {
        throw InputError(spec.file + ": cannot re-read the spec: " + std::string(e.description()));
    }
    toml::array* tables = root["tables"].as_array();
    if (!tables) throw Error(spec.file + ": the spec has no [[tables]] array to plan");
    for (std::size_t k = 0; k < table_indices.size() && k < plan.tables.size(); ++k) {
        const std::size_t i = table_indices[k];
        toml::table* t = i < tables->size() ? tables->get(i)->as_table() : nullptr;
        if (!t) throw Error(spec.file + ": tables[" + std::to_string(i) + "] is not a table");
        toml::array axes;
        const TableSpec& ts = spec.tables[i];
        for (std::size_t a = 0; a < ts.axes.size(); ++a) {
            const Axis& ax = ts.axes[a];
            toml::table e;
            e.insert("name", ax.name);
            const std::vector<double>* placed =
                a < plan.tables[k].explicit_values.size() && !plan.tables[k].explicit_values[a].empty()
                    ? &plan.tables[k].explicit_values[a]
                    : nullptr;
            if (ax.spacing == Spacing::Explicit || placed) {
                toml::array v;
                for (double x : placed ? *placed : ax.values) v.push_back(x);
                e.insert("spacing", "explicit");
                e.insert("values", v);
            } else {
                e.insert("range", toml::array{ax.min, ax.max});
                e.insert("count", static_cast<std::int64_t>(plan.tables[k].counts[a]));
                if (ax.spacing != Spacing::Linear) e.insert("spacing", spacing_name(ax.spacing));
                if (ax.spacing == Spacing::LogComplement) e.insert("pivot", ax.pivot);
                if (ax.spacing == Spacing::Critical) {
                    e.insert("critical_fraction", double(ax.critical_node) / double(ax.count - 1));
                    e.insert("grading", ax.grading);
                }
            }
            axes.push_back(std::move(e));
        }
        t->insert_or_assign("axes", std::move(axes));
    }
    if (plan.method != Method::ClosedForm) {
        if (!root["integration"].as_table()) root.insert("integration", toml::table{});
        toml::table& in = *root["integration"].as_table();
        in.insert_or_assign("method", to_string(plan.method));
        in.erase("tolerance");
        if (plan.samples > 0) {
            in.insert_or_assign("samples", static_cast<std::int64_t>(plan.samples));
            if (auto m = in["max_samples"].value<std::int64_t>(); m && *m < std::int64_t(plan.samples))
                in.insert_or_assign("max_samples", static_cast<std::int64_t>(plan.samples));
        }
    }
    if (!root["output"].as_table()) root.insert("output", toml::table{});
    root["output"].as_table()->insert_or_assign("type", stored_type_name(plan.stored_type));
    if (spec.output.round_accuracy > 0) {  // rounded storage (host/io/bit_rounding.h)
        root["output"].as_table()->insert_or_assign("round_to_accuracy", spec.output.round_accuracy);
        root["output"].as_table()->insert_or_assign("round_measure",
                                                    spec.output.round_absolute ? "absolute" : "relative");
    }

    std::ostringstream out;
    for (const std::string& h : header) out << "# " << h << "\n";
    out << toml::toml_formatter(root) << "\n";
    return out.str();
}

std::string adaptive_spec_text(const Spec& spec, double accuracy, bool absolute,
                               const std::vector<std::string>& header) {
    toml::table root;
    try {
        root = toml::parse(spec.text, spec.file);
    } catch (const toml::parse_error& e) {
        throw InputError(spec.file + ": cannot re-read the spec: " + std::string(e.description()));
    }
    if (!root["output"].as_table()) root.insert("output", toml::table{});
    root["output"].as_table()->insert_or_assign("representation", "adaptive");
    if (!root["adaptive"].as_table()) root.insert("adaptive", toml::table{});
    root["adaptive"].as_table()->insert_or_assign("accuracy", accuracy);
    root["adaptive"].as_table()->insert_or_assign("measure", absolute ? "absolute" : "relative");
    std::ostringstream out;
    for (const std::string& h : header) out << "# " << h << "\n";
    out << toml::toml_formatter(root) << "\n";
    return out.str();
}

namespace {
nlohmann::json fit_json(const PowerFit& f) {
    if (!f.valid) return nullptr;
    return {{"C", f.c}, {"p", f.p}};
}
}  // namespace

nlohmann::json pilot_json(const TablePilot& p) {
    nlohmann::json axes = nlohmann::json::array();
    for (std::size_t a = 0; a < p.axes.size(); ++a) {
        nlohmann::json j = {{"name", p.axes[a].name}, {"spec_count", p.axes[a].count},
                            {"planned", p.linear[a].planned}};
        for (int m = 0; m < 2; ++m) {
            const AxisFit& f = m == 0 ? p.linear[a] : p.cubic[a];
            nlohmann::json levels = nlohmann::json::array();
            for (const LevelErrors& l : f.levels)
                levels.push_back({{"count", l.count}, {"h", l.h}, {"max_abs", l.max_abs},
                                  {"rms_abs", l.rms_abs}, {"max_rel", l.max_rel},
                                  {"rms_rel", l.rms_rel}, {"noise", l.noise},
                                  {"denoised_max_abs", l.denoised_max_abs},
                                  {"denoised_max_rel", l.denoised_max_rel}});
            j[m == 0 ? "linear" : "cubic"] = {{"levels", levels},
                                              {"max_abs", fit_json(f.max_abs)},
                                              {"rms_abs", fit_json(f.rms_abs)},
                                              {"max_rel", fit_json(f.max_rel)},
                                              {"rms_rel", fit_json(f.rms_rel)}};
        }
        axes.push_back(j);
    }
    nlohmann::json integ = nlohmann::json::array();
    for (const IntegrationFit& f : p.integration) {
        nlohmann::json j = {{"method", to_string(f.method)}};
        if (f.method == Method::ClosedForm || f.method == Method::Quadrature)
            j["seconds_per_cell"] = f.seconds_per_cell;
        if (f.method == Method::Quadrature && f.reference_nodes > 0)
            j["rule_error"] = {{"max_abs", f.max_abs.front()}, {"max_rel", f.max_rel.front()},
                               {"reference_nodes", f.reference_nodes}};
        else if (f.method == Method::Quadrature)
            j["difference"] = {{"max_abs", f.max_abs.front()}, {"max_rel", f.max_rel.front()}};
        if (f.method == Method::MonteCarlo || f.method == Method::Rqmc) {
            j["seconds_per_sample"] = f.seconds_per_sample;
            j["samples"] = f.samples;
            j["stderr_max_abs"] = f.max_abs;
            j["stderr_max_rel"] = f.max_rel;
            j["fit_max_abs"] = fit_json(f.fit_max_abs);
            j["fit_max_rel"] = fit_json(f.fit_max_rel);
            j["q"] = f.fit_max_rel.valid ? -f.fit_max_rel.p : 0.0;
            if (f.large_grid_measured) j["item_overhead_seconds"] = f.item_overhead_seconds;
        }
        if (f.large_grid_measured) j["large_grid_load_seconds"] = f.large_grid_load_seconds;
        integ.push_back(j);
    }
    return {{"table", p.table}, {"quantity", p.quantity}, {"max_value", p.max_value}, {"min_value", p.min_value},
            {"relative_floor", p.rel_floor}, {"variance_unseen", p.variance_unseen}, {"axes", axes}, {"integration", integ},
            {"overhead_seconds", p.overhead_seconds}, {"startup_seconds", p.startup_seconds},
            {"pilot_seconds", p.pilot_seconds},
            {"pilot_evaluations", p.pilot_evaluations}};
}

nlohmann::json candidate_json(const Candidate& c, const std::vector<TablePilot>& pilots) {
    nlohmann::json tables = nlohmann::json::array();
    for (std::size_t i = 0; i < c.tables.size(); ++i) {
        const TablePlan& t = c.tables[i];
        nlohmann::json counts = nlohmann::json::object();
        for (std::size_t a = 0; a < t.counts.size() && i < pilots.size(); ++a)
            counts[pilots[i].axes[a].name] = t.counts[a];
        if (i >= pilots.size()) counts = t.counts;  // a recombined table: its terms' shared counts, in axis order
        tables.push_back({{"table", t.table}, {"counts", counts}, {"cells", t.cells},
                          {"predicted_error", {{"max", t.error_max}, {"rms", t.error_rms},
                                               {"interpolation_max", t.interpolation_max},
                                               {"integration_max", t.integration_max},
                                               {"storage_max", t.storage_max}}},
                          {"predicted_seconds", t.seconds}});
    }
    return {{"method", to_string(c.method)},
            {"samples", c.samples},
            {"stored_type", stored_type_name(c.stored_type)},
            {"predicted_error", {{"max", c.error_max}, {"rms", c.error_rms}}},
            {"predicted_seconds", c.seconds},
            {"bytes", c.bytes},
            {"tables", tables}};
}

}  // namespace brdftab

// adaptive_resample.cpp — an adaptive table on a tensor grid
// (adaptive_resample.h).
#include "host/io/adaptive_resample.h"

#include <algorithm>
#include <cmath>

#include "host/core/error.h"
#include "host/core/grid.h"
#include "host/core/splitmix.h"
#include "host/lookup/lookup.h"

namespace brdftab {

namespace {

// `a` with `n` nodes and the same warp x(t) (n rounded up where the warp
// depends on the count: a critical axis' kink node, an explicit node list).
Axis resampled_axis(const Axis& a, std::size_t n) {
    const std::size_t cells0 = a.count - 1;
    auto round_up = [&](std::size_t m) { return ((m - 1 + cells0 - 1) / cells0) * cells0 + 1; };
    switch (a.spacing) {
    case Spacing::Critical: {
        n = round_up(std::max<std::size_t>(n, 3));
        const std::size_t node = a.critical_node * ((n - 1) / cells0);
        return make_critical_axis(a.name, a.min, a.max, n, node, a.grading, a.critical_eta, a.depends_on);
    }
    case Spacing::Explicit: {
        n = round_up(n);
        std::vector<double> x(n);
        for (std::size_t k = 0; k < n; ++k) x[k] = a.warp(double(k) / double(n - 1));
        x.front() = a.values.front();
        x.back() = a.values.back();
        Axis r = make_axis(a.name, a.unit, a.min, a.max, n, Spacing::Explicit, x);
        return r;
    }
    case Spacing::LogComplement:
        return make_log_complement_axis(a.name, a.unit, a.min, a.max, n, a.pivot);
    default:
        return make_axis(a.name, a.unit, a.min, a.max, n, a.spacing);
    }
}

}  // namespace

TableData resample_adaptive(const AdaptiveTable& t, const ResampleOptions& options, ResampleReport& report) {
    const TableData& d = t.data;
    const std::size_t dims = d.axes.size();
    for (const auto& [name, n] : options.axis_nodes)
        if (std::none_of(d.axes.begin(), d.axes.end(), [&](const Axis& a) { return a.name == name; }))
            throw InputError("--resample " + name + ": not an axis of table '" + d.name + "'");
    std::size_t base = options.nodes;
    if (!base) {
        // The default: 65 per axis, fewer so that the grid stays below 2^22 values.
        base = kResampleDefaultNodes;
        while (base > 9 && std::pow(double(base), double(dims)) > double(kResampleDefaultValues)) --base;
    }
    TableData out = d;
    out.axes.clear();
    for (const Axis& a : d.axes) {
        const auto it = options.axis_nodes.find(a.name);
        const std::size_t n = it != options.axis_nodes.end() ? it->second : base;
        if (n < 2 || n > 1'000'000)
            throw InputError("--resample " + a.name + ": nodes must be in [2, 1000000], got " + std::to_string(n));
        out.axes.push_back(resampled_axis(a, n));
    }
    const Grid grid(out.axes);
    const std::size_t cells = checked_cell_count(out.axes, "--resample: ");
    if (cells > (std::size_t{1} << 28))
        throw InputError("--resample: " + std::to_string(cells) + " values, more than 2^28: give fewer nodes");
    const bool with_se = d.stderr_.size() == d.value.size() && !d.stderr_.empty();
    out.value.assign(cells, 0.0);
    out.stderr_.assign(with_se ? cells : 0, 0.0);
    out.samples.clear();
    std::vector<double> tt(dims);
    report = ResampleReport{};
    for (const Axis& a : out.axes) report.counts.push_back(a.count);
    for (std::size_t c = 0; c < cells; ++c) {
        const std::vector<double> x = grid.coordinates(c);
        t.to_t(x.data(), tt.data());
        const std::size_t leaf = t.layout.leaf_of(tt.data());
        out.value[c] = t.layout.eval_leaf(leaf, tt.data(), d.value.data());
        if (with_se) out.stderr_[c] = t.layout.eval_leaf(leaf, tt.data(), d.stderr_.data());
        report.max_abs_value = std::max(report.max_abs_value, std::fabs(out.value[c]));
    }

    // Probes between the nodes: cell centres in t, or random points in t.
    std::size_t cell_count = 1;
    for (const Axis& a : out.axes) cell_count *= a.count - 1;
    report.probes_at_centres = cell_count <= kResampleProbeCap;
    report.probes = report.probes_at_centres ? cell_count : kResampleProbeCap;
    const LookupTable lt(out);
    SplitMix rng{options.seed};
    std::vector<std::size_t> idx(dims, 0);
    std::vector<double> pt(dims);
    for (std::size_t p = 0; p < report.probes; ++p) {
        for (std::size_t a = 0; a < dims; ++a) {
            const double cells_a = double(out.axes[a].count - 1);
            pt[a] = report.probes_at_centres ? (double(idx[a]) + 0.5) / cells_a : rng.uniform();
        }
        if (report.probes_at_centres)
            for (std::size_t a = dims; a-- > 0;) {
                if (++idx[a] < out.axes[a].count - 1) break;
                idx[a] = 0;
            }
        const std::vector<double> x = grid.point_at(pt);
        const double e = std::fabs(lt.eval(x, Interpolation::Linear, OutOfRange::Clamp) - t.eval(x.data()));
        if (e > report.max_abs || report.worst.empty()) {
            report.max_abs = std::max(report.max_abs, e);
            report.worst = x;
        }
    }
    return out;
}

}  // namespace brdftab

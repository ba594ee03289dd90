// node_placement.cpp — equidistributing the measured interpolation error
// (see node_placement.h for the model and its derivation).
#include "host/plan/node_placement.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "host/core/error.h"
#include "host/plan/plan.h"

namespace brdftab {

std::vector<double> local_linear_errors(const std::vector<PlacementLine>& lines, bool relative,
                                        double floor) {
    if (lines.empty()) throw InputError("node placement: no pilot lines");
    const std::vector<double>& x = lines.front().node_x;
    if (x.size() < 2) throw InputError("node placement: a pilot line needs at least 2 nodes");
    std::vector<double> err(x.size() - 1, 0.0);
    for (const PlacementLine& l : lines) {
        if (l.node_x != x || l.node_f.size() != x.size() || l.probe_x.size() != l.probe_f.size())
            throw InputError("node placement: pilot lines of different shapes");
        for (std::size_t k = 0; k < l.probe_x.size(); ++k) {
            const double p = l.probe_x[k];
            std::size_t i = std::size_t(std::upper_bound(x.begin(), x.end(), p) - x.begin());
            i = std::min(std::max<std::size_t>(i, 1), x.size() - 1) - 1;
            const double s = (p - x[i]) / (x[i + 1] - x[i]);
            const double lin = (1 - s) * l.node_f[i] + s * l.node_f[i + 1];
            double e = std::fabs(lin - l.probe_f[k]);
            if (relative) e /= std::max(std::fabs(l.probe_f[k]), floor);
            if (std::isfinite(e)) err[i] = std::max(err[i], e);
        }
    }
    return err;
}

NodePlacement place_nodes(const std::vector<double>& node_x,
                          const std::vector<double>& local_error, double order,
                          std::size_t count, double refine_order) {
    if (!(refine_order > 0)) refine_order = order;
    const std::size_t m = local_error.size();
    if (node_x.size() != m + 1 || m < 1)
        throw InputError("node placement: " + std::to_string(node_x.size()) + " pilot nodes for " +
                         std::to_string(m) + " interval errors");
    if (count < 2) throw InputError("node placement: needs at least 2 nodes");
    if (!(order > 0)) throw InputError("node placement: the error order must be > 0");
    // C_i = e_i / h_i^p and the density C_i^(1/p) per unit x.
    std::vector<double> c(m), w(m);
    double wmax = 0;
    for (std::size_t i = 0; i < m; ++i) {
        const double h = node_x[i + 1] - node_x[i];
        if (!(h > 0)) throw InputError("node placement: pilot nodes must increase");
        c[i] = std::max(local_error[i], 0.0) / std::pow(h, order);
        w[i] = std::pow(c[i], 1.0 / order);
        wmax = std::max(wmax, w[i]);
    }
    const double lo = node_x.front(), hi = node_x.back();
    NodePlacement out;
    out.values.resize(count);
    if (!(wmax > 0)) {  // nothing measurable: uniform nodes
        for (std::size_t k = 0; k < count; ++k)
            out.values[k] = lo + (hi - lo) * double(k) / double(count - 1);
        out.values.back() = hi;
        return out;
    }
    for (double& v : w) v = std::max(v, 1e-3 * wmax);
    // Cumulative density at the pilot nodes; the new nodes invert it.
    std::vector<double> cum(m + 1, 0.0);
    for (std::size_t i = 0; i < m; ++i) cum[i + 1] = cum[i] + w[i] * (node_x[i + 1] - node_x[i]);
    const double total = cum[m];
    std::size_t i = 0;
    for (std::size_t k = 0; k < count; ++k) {
        const double target = total * double(k) / double(count - 1);
        while (i + 1 < m && cum[i + 1] < target) ++i;
        out.values[k] = node_x[i] + (target - cum[i]) / w[i];
    }
    out.values.front() = lo;
    out.values.back() = hi;
    for (std::size_t k = 1; k < count; ++k)
        if (!(out.values[k] > out.values[k - 1]))
            throw InputError("node placement: " + std::to_string(count) +
                             " nodes collapse in double precision; use fewer");
    // Predicted error of a set of nodes: on a cell the model's error is
    // (integral of C^(1/p) dx)^p over the cell, which is C H^p where C is
    // constant and follows C's variation inside large cells (the largest C
    // of the cell would overstate it: 2x for exp(6x) on 20 nodes).
    std::vector<double> density(m);
    for (std::size_t q = 0; q < m; ++q) density[q] = std::pow(c[q], 1.0 / order);
    auto predict = [&](const std::vector<double>& nodes) {
        double worst = 0;
        for (std::size_t k = 0; k + 1 < nodes.size(); ++k) {
            const double a = nodes[k], b = nodes[k + 1];
            double integral = 0, inside = 0;
            for (std::size_t q = 0; q < m; ++q) {
                const double lo_q = std::max(a, node_x[q]), hi_q = std::min(b, node_x[q + 1]);
                if (hi_q > lo_q) integral += density[q] * (hi_q - lo_q);
                // A cell within pilot interval q: its error scaled from e_q
                // with the measured order.
                if (a >= node_x[q] && b <= node_x[q + 1])
                    inside = std::max(local_error[q], 0.0) *
                             std::pow((b - a) / (node_x[q + 1] - node_x[q]), refine_order);
            }
            worst = std::max(worst, std::max(std::pow(integral, order), inside));
        }
        return worst;
    };
    out.predicted_max = predict(out.values);
    std::vector<double> uniform(count);
    for (std::size_t k = 0; k < count; ++k)
        uniform[k] = lo + (hi - lo) * double(k) / double(count - 1);
    uniform.back() = hi;
    out.uniform_max = predict(uniform);
    return out;
}

std::vector<PlacedAxis> place_plan_nodes(const std::vector<TablePilot>& pilots, Candidate& plan,
                                         const PlanTarget& target) {
    if (target.interpolation != Interpolation::Linear)
        throw InputError("--place-nodes needs --interpolation linear: explicit nodes are "
                         "interpolated piecewise linearly in x");
    std::vector<PlacedAxis> out;
    for (std::size_t k = 0; k < plan.tables.size() && k < pilots.size(); ++k) {
        const TablePilot& pilot = pilots[k];
        TablePlan& tp = plan.tables[k];
        tp.explicit_values.assign(pilot.axes.size(), {});
        for (std::size_t a = 0; a < pilot.axes.size(); ++a) {
            const auto& lines = pilot.placement_lines.at(a);
            if (lines.empty() || a >= tp.counts.size()) continue;
            const std::vector<double> err =
                local_linear_errors(lines, !target.absolute, pilot.rel_floor);
            // Nodes for the nominal order 2; the prediction of cells smaller
            // than a pilot interval uses the measured order (an axis with a
            // sqrt or log edge converges as h^1 there, not h^2).
            const AxisFit& fit = pilot.linear.at(a);
            const PowerFit& law = target.absolute ? fit.max_abs : fit.max_rel;
            const double order = law.valid ? std::clamp(law.p, 0.5, 2.0) : 2.0;
            const NodePlacement p =
                place_nodes(lines.front().node_x, err, 2.0, tp.counts[a], order);
            PlacedAxis r;
            r.table = pilot.table;
            r.axis = pilot.axes[a].name;
            r.count = tp.counts[a];
            r.predicted_max = p.predicted_max;
            r.uniform_max = p.uniform_max;
            r.spacing_max = law.eval(1.0 / double(tp.counts[a] - 1));
            if (r.predicted_max < r.spacing_max) tp.explicit_values[a] = p.values;
            out.push_back(r);
        }
    }
    return out;
}

}  // namespace brdftab

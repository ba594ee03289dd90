// grid.cpp — axis node placement and its closed-form inverse (see grid.h).
#include "host/core/grid.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "host/core/error.h"
#include "host/core/text.h"

namespace brdftab {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;

std::string num(double v) { return number_text(v, 17); }

// Piecewise-linear node lookup shared by the explicit spacing: t_k = k/(n-1).
double explicit_warp(const std::vector<double>& v, double t) {
    const std::size_t n = v.size();
    const double s = t * double(n - 1);
    // Outside [0, 1] extrapolate with the end segments so that unwarp() stays
    // the exact inverse there too (the caller decides whether to clamp).
    std::size_t k;
    if (s <= 0) {
        k = 0;
    } else if (s >= double(n - 1)) {
        k = n - 2;
    } else {
        k = std::min<std::size_t>(std::size_t(s), n - 2);
    }
    const double u = s - double(k);
    if (u == 0) return v[k];
    if (u == 1) return v[k + 1];
    return v[k] + u * (v[k + 1] - v[k]);
}

double explicit_unwarp_impl(const std::vector<double>& v, double x) {
    const std::size_t n = v.size();
    // First node strictly greater than x, then step back to the cell start.
    std::size_t k = std::size_t(std::upper_bound(v.begin(), v.end(), x) - v.begin());
    k = (k == 0) ? 0 : k - 1;
    if (k > n - 2) k = n - 2;
    const double u = (x - v[k]) / (v[k + 1] - v[k]);
    return (double(k) + u) / double(n - 1);
}

// Power of a non-negative base (s >= 0 on each side of a critical axis, also
// for t outside [0, 1], so the map extrapolates monotonically).
double side_power(double s, double q) { return q == 1 ? s : std::pow(s, q); }

double critical_cosine(double eta, bool inside) {
    // r = n_far / n_near; total internal reflection for |mu| < sqrt(1 - r^2)
    // when r < 1 (docs/models/rough-dielectric.md: eta = inside / outside).
    if (!(eta > 0) || !std::isfinite(eta)) return 0;
    const double r = inside ? 1.0 / eta : eta;
    return r < 1 ? std::sqrt((1 - r) * (1 + r)) : 0.0;
}

}  // namespace

const double kCriticalMinSide = 1.0 / 16;

std::size_t critical_node_for(std::size_t count, double fraction) {
    if (count < 3) return 1;
    const double k = std::round(fraction * double(count - 1));
    return std::size_t(std::clamp(k, 1.0, double(count - 2)));
}

double Axis::critical_position(double eta) const {
    const bool inside = max <= 0;
    const double mu_c = critical_cosine(eta, inside);
    const double x_c = inside ? -mu_c : mu_c;
    const double t_c = double(critical_node) / double(count - 1);
    const double span = max - min;
    const double lo = min + kCriticalMinSide * t_c * span;
    const double hi = max - kCriticalMinSide * (1 - t_c) * span;
    return std::clamp(x_c, lo, hi);
}

double Axis::warp_at(double t, double dep) const {
    if (spacing != Spacing::Critical) return warp(t);
    if (t == 0) return min;
    if (t == 1) return max;
    const double eta = dependent() ? dep : critical_eta;
    const double x_c = critical_position(eta);
    const double t_c = double(critical_node) / double(count - 1);
    // Both sides are graded towards the kink: the transmitting side
    // (|mu| > mu_c) rises like sqrt(|mu| - mu_c) at a smooth interface, and
    // roughness rounds the kink over a width that both sides must resolve.
    if (t <= t_c) {
        const double s = (t_c - t) / t_c;  // 0 at the kink, 1 at min
        return x_c - (x_c - min) * side_power(s, grading);
    }
    const double s = (t - t_c) / (1 - t_c);  // 0 at the kink, 1 at max
    return x_c + (max - x_c) * side_power(s, grading);
}

double Axis::unwarp_at(double x, double dep) const {
    if (spacing != Spacing::Critical) return unwarp(x);
    if (x == min) return 0;
    if (x == max) return 1;
    const double eta = dependent() ? dep : critical_eta;
    const double x_c = critical_position(eta);
    const double t_c = double(critical_node) / double(count - 1);
    if (x <= x_c) {
        const double s = (x_c - x) / (x_c - min);
        return t_c - t_c * side_power(s, 1.0 / grading);
    }
    const double s = (x - x_c) / (max - x_c);
    return t_c + (1 - t_c) * side_power(s, 1.0 / grading);
}

double Axis::warp(double t) const {
    if (spacing == Spacing::Critical) {
        if (dependent())
            throw Error("axis '" + name + "': its nodes depend on '" + depends_on +
                        "'; warp needs that value (warp_at)");
        return warp_at(t, critical_eta);
    }
    // The end points are returned exactly: a table's first and last node must
    // be the user's min and max, not a rounding of acos(cos(min)) etc.
    if (spacing != Spacing::Explicit) {
        if (t == 0) return min;
        if (t == 1) return max;
    }
    switch (spacing) {
        case Spacing::Linear:
            return min + t * (max - min);
        case Spacing::Cos: {
            const double c0 = std::cos(min * kDegToRad), c1 = std::cos(max * kDegToRad);
            const double c = c0 + t * (c1 - c0);
            // Clamp only against acos' domain; t outside [0, 1] cannot go
            // past the poles anyway.
            return std::acos(std::max(-1.0, std::min(1.0, c))) / kDegToRad;
        }
        case Spacing::Log:
            return min * std::exp(t * std::log(max / min));
        case Spacing::Quadratic:
            // Sign-preserving square so that warp stays monotone (and the
            // exact inverse of unwarp) for t < 0.
            return min + t * std::fabs(t) * (max - min);
        case Spacing::Explicit:
            return explicit_warp(values, t);
        case Spacing::LogComplement:
            // Geometric in the distance d = P - x: d(t) = d_min (d_max/d_min)^t.
            return pivot - (pivot - min) * std::exp(t * std::log((pivot - max) / (pivot - min)));
        case Spacing::Critical:
            break;  // handled above
    }
    return min;
}

double Axis::unwarp(double x) const {
    if (spacing == Spacing::Critical) {
        if (dependent())
            throw Error("axis '" + name + "': its nodes depend on '" + depends_on +
                        "'; unwarp needs that value (unwarp_at)");
        return unwarp_at(x, critical_eta);
    }
    if (spacing != Spacing::Explicit) {
        if (x == min) return 0;
        if (x == max) return 1;
    }
    switch (spacing) {
        case Spacing::Linear:
            return (x - min) / (max - min);
        case Spacing::Cos: {
            const double c0 = std::cos(min * kDegToRad), c1 = std::cos(max * kDegToRad);
            return (std::cos(x * kDegToRad) - c0) / (c1 - c0);
        }
        case Spacing::Log:
            // Below zero there is no preimage; -inf clamps to the first cell.
            if (x <= 0) return -std::numeric_limits<double>::infinity();
            return std::log(x / min) / std::log(max / min);
        case Spacing::Quadratic: {
            const double r = (x - min) / (max - min);
            return r >= 0 ? std::sqrt(r) : -std::sqrt(-r);
        }
        case Spacing::Explicit:
            return explicit_unwarp_impl(values, x);
        case Spacing::LogComplement: {
            // Past the pivot there is no preimage: +-inf clamps to an end cell.
            const double r = (pivot - x) / (pivot - min);
            if (!(r > 0)) return (pivot > max) ? std::numeric_limits<double>::infinity()
                                                : -std::numeric_limits<double>::infinity();
            return std::log(r) / std::log((pivot - max) / (pivot - min));
        }
        case Spacing::Critical:
            break;  // handled above
    }
    return 0;
}

namespace {

// Node positions of a range-defined axis at `dep` (the coordinate a critical
// axis depends on; ignored otherwise).  The end points are set exactly, and
// grids so dense that neighbouring nodes collapse in double precision are
// refused.
void fill_nodes(Axis& a, double dep) {
    const std::string what = "axis '" + a.name + "': ";
    a.values.resize(a.count);
    for (std::size_t k = 0; k < a.count; ++k)
        a.values[k] = a.warp_at(double(k) / double(a.count - 1), dep);
    a.values.front() = a.min;
    a.values.back() = a.max;
    for (std::size_t k = 1; k < a.count; ++k) {
        if (!(a.values[k] > a.values[k - 1]))
            throw InputError(what + "nodes " + std::to_string(k - 1) + " and " +
                             std::to_string(k) + " coincide in double precision (" +
                             num(a.values[k]) + (a.dependent() ? " at " + a.depends_on + " = " + num(dep) : std::string()) +
                             "); use fewer nodes or another spacing");
    }
}

}  // namespace

Axis make_axis(const std::string& name, const std::string& unit, double min, double max,
               std::size_t count, Spacing spacing,
               const std::vector<double>& explicit_values) {
    const std::string what = "axis '" + name + "': ";
    Axis a;
    a.name = name;
    a.unit = unit;
    a.spacing = spacing;

    if (spacing == Spacing::Explicit) {
        if (explicit_values.size() < 2)
            throw InputError(what + "explicit spacing needs at least 2 values, got " +
                             std::to_string(explicit_values.size()));
        for (std::size_t k = 0; k < explicit_values.size(); ++k) {
            if (!std::isfinite(explicit_values[k]))
                throw InputError(what + "explicit value #" + std::to_string(k) +
                                 " is not finite");
            if (k > 0 && !(explicit_values[k] > explicit_values[k - 1]))
                throw InputError(what + "explicit values must be strictly increasing; value #" +
                                 std::to_string(k) + " (" + num(explicit_values[k]) +
                                 ") does not exceed the previous one (" +
                                 num(explicit_values[k - 1]) + ")");
        }
        a.values = explicit_values;
        a.min = a.values.front();
        a.max = a.values.back();
        a.count = a.values.size();
        return a;
    }

    if (!explicit_values.empty())
        throw InputError(what + "node values may only be given with spacing 'explicit' (spacing is '" +
                         spacing_name(spacing) + "')");
    if (count < 2)
        throw InputError(what + "count must be >= 2, got " + std::to_string(count));
    if (!std::isfinite(min) || !std::isfinite(max))
        throw InputError(what + "min and max must be finite numbers");
    if (!(min < max))
        throw InputError(what + "min must be less than max, got [" + num(min) + ", " + num(max) +
                         "]");
    if (spacing == Spacing::LogComplement || spacing == Spacing::Critical)
        throw InputError(what + "spacing '" + spacing_name(spacing) +
                         "' needs its own parameters (make_log_complement_axis, "
                         "make_critical_axis)");
    if (spacing == Spacing::Log && !(min > 0))
        throw InputError(what + "log spacing needs min > 0, got min = " + num(min));
    if (spacing == Spacing::Cos && (min < 0 || max > 180))
        throw InputError(what + "cos spacing needs an angle range within [0, 180] degrees, got [" +
                         num(min) + ", " + num(max) + "]");

    a.min = min;
    a.max = max;
    a.count = count;
    fill_nodes(a, 0.0);
    return a;
}

Axis make_log_complement_axis(const std::string& name, const std::string& unit, double min,
                              double max, std::size_t count, double pivot) {
    const std::string what = "axis '" + name + "': ";
    Axis a = make_axis(name, unit, min, max, count, Spacing::Linear);
    if (!std::isfinite(pivot) || (pivot >= min && pivot <= max))
        throw InputError(what + "log-complement spacing needs a pivot outside [" + num(min) +
                         ", " + num(max) + "], got " + num(pivot));
    a.spacing = Spacing::LogComplement;
    a.pivot = pivot;
    fill_nodes(a, 0.0);
    return a;
}

Axis make_critical_axis(const std::string& name, double min, double max, std::size_t count,
                        std::size_t critical_node, double grading, double eta,
                        const std::string& eta_axis) {
    const std::string what = "axis '" + name + "': ";
    if (count < 3)
        throw InputError(what + "critical spacing needs at least 3 nodes, got " +
                         std::to_string(count));
    Axis a = make_axis(name, "1", min, max, count, Spacing::Linear);
    if (!(min >= -1 && max <= 0) && !(min >= 0 && max <= 1))
        throw InputError(what + "critical spacing is for a cosine axis on one side of the "
                                "surface: the range must lie within [-1, 0] (light from inside) "
                                "or [0, 1] (from outside), got [" + num(min) + ", " + num(max) + "]");
    if (critical_node < 1 || critical_node > count - 2)
        throw InputError(what + "critical node " + std::to_string(critical_node) +
                         " is out of range; allowed: 1 .. " + std::to_string(count - 2));
    if (!(grading >= 1 && grading <= 4))
        throw InputError(what + "critical grading " + num(grading) +
                         " is out of range; allowed: [1, 4]");
    a.spacing = Spacing::Critical;
    a.critical_node = critical_node;
    a.grading = grading;
    if (eta_axis.empty()) {
        if (!(eta > 0) || !std::isfinite(eta))
            throw InputError(what + "critical spacing needs eta > 0, got " + num(eta));
        a.critical_eta = eta;
        fill_nodes(a, eta);
    } else {
        a.depends_on = eta_axis;
        for (std::size_t k = 0; k < count; ++k) a.values[k] = double(k) / double(count - 1);
    }
    return a;
}

void check_dependent_nodes(const Axis& a, const std::vector<double>& dep_values) {
    Axis probe = a;
    for (double d : dep_values) fill_nodes(probe, d);
}

std::size_t checked_cell_count(const std::vector<Axis>& axes, const std::string& where) {
    std::size_t n = 1;  // a table without axes is a single value
    for (const Axis& a : axes) {
        if (a.count != 0 && n > std::numeric_limits<std::size_t>::max() / a.count) {
            std::string dims;
            for (const Axis& b : axes) dims += (dims.empty() ? "" : " x ") + std::to_string(b.count);
            throw InputError(where + "the axes' node counts (" + dims +
                             ") multiply to more cells than this machine can address");
        }
        n *= a.count;
    }
    return n;
}

Grid::Grid(std::vector<Axis> axes) : axes_(std::move(axes)) {
    for (const Axis& a : axes_)
        if (a.count == 0 || a.values.size() != a.count)
            throw Error("grid: axis '" + a.name + "' has no nodes (build it with make_axis)");
    cell_count_ = checked_cell_count(axes_, "grid: ");
    dependency_.assign(axes_.size(), -1);
    for (std::size_t d = 0; d < axes_.size(); ++d) {
        if (!axes_[d].dependent()) continue;
        for (std::size_t e = 0; e < axes_.size(); ++e)
            if (axes_[e].name == axes_[d].depends_on && !axes_[e].dependent()) dependency_[d] = int(e);
        if (dependency_[d] < 0)
            throw InputError("grid: axis '" + axes_[d].name + "' depends on '" +
                             axes_[d].depends_on + "', which is not an axis of the table");
    }
}

std::vector<std::size_t> Grid::index_of(std::size_t flat) const {
    if (flat >= cell_count_)
        throw Error("grid: cell index " + std::to_string(flat) + " out of range (cell count " +
                    std::to_string(cell_count_) + ")");
    std::vector<std::size_t> idx(axes_.size());
    // Row-major, last axis fastest: peel the fastest axis off first.
    for (std::size_t d = axes_.size(); d-- > 0;) {
        idx[d] = flat % axes_[d].count;
        flat /= axes_[d].count;
    }
    return idx;
}

std::vector<double> Grid::coordinates(std::size_t flat) const {
    return coordinates(index_of(flat));
}

std::vector<double> Grid::coordinates(const std::vector<std::size_t>& idx) const {
    std::vector<double> x(axes_.size());
    for (std::size_t d = 0; d < axes_.size(); ++d) x[d] = axes_[d].values[idx[d]];
    // Dependent axes hold t_k: place them at their cell's value of the axis
    // they depend on (the same arithmetic as make_critical_axis' nodes).
    for (std::size_t d = 0; d < axes_.size(); ++d)
        if (dependency_[d] >= 0) {
            const Axis& a = axes_[d];
            x[d] = idx[d] == 0 ? a.min
                   : idx[d] + 1 == a.count ? a.max
                                           : a.warp_at(a.values[idx[d]], x[std::size_t(dependency_[d])]);
        }
    return x;
}

std::vector<double> Grid::point_at(const std::vector<double>& t) const {
    std::vector<double> x(axes_.size());
    for (std::size_t d = 0; d < axes_.size(); ++d)
        if (dependency_[d] < 0) x[d] = std::clamp(axes_[d].warp(t[d]), axes_[d].min, axes_[d].max);
    for (std::size_t d = 0; d < axes_.size(); ++d)
        if (dependency_[d] >= 0)
            x[d] = std::clamp(axes_[d].warp_at(t[d], x[std::size_t(dependency_[d])]), axes_[d].min,
                              axes_[d].max);
    return x;
}

AxisPosition axis_position(const Axis& a, double x, double dep) {
    const double span = std::fabs(a.max - a.min);
    const double tol = 1e-9 * std::max({span, std::fabs(a.min), std::fabs(a.max), 1e-300});
    if (!(x >= a.min - tol && x <= a.max + tol))
        throw InputError(a.name + " = " + number_text(x, 6) + " is outside the axis [" + number_text(a.min, 6) +
                         ", " + number_text(a.max, 6) + "]" + unit_suffix(a.unit));
    AxisPosition p;
    // Nodes as positions (a dependent axis stores t_k: its positions need dep).
    const std::size_t n = a.count;
    auto node_at = [&](std::size_t k) { return a.dependent() ? a.warp_at(a.values[k], dep) : a.values[k]; };
    for (std::size_t k = 0; k < n; ++k) {
        const double node = node_at(k);
        if (std::fabs(node - x) <= 1e-9 * std::max({std::fabs(node), span, 1e-300})) {
            p.node = k;
            return p;
        }
    }
    const double t = std::min(1.0, std::max(0.0, a.dependent() ? a.unwarp_at(x, dep) : a.unwarp(x)));
    const double u = t * static_cast<double>(n - 1);
    p.node = std::min(static_cast<std::size_t>(std::floor(u)), n - 2);
    p.s = std::min(1.0, std::max(0.0, u - static_cast<double>(p.node)));
    p.at_node = false;
    return p;
}

std::string slice_note(const Axis& a, double x, const AxisPosition& p) {
    if (p.at_node) return "";
    const double lo = a.dependent() ? std::numeric_limits<double>::quiet_NaN() : a.values[p.node];
    const double hi = a.dependent() ? std::numeric_limits<double>::quiet_NaN() : a.values[p.node + 1];
    std::string s = a.name + " = " + number_text(x, 6) + unit_suffix(a.unit) + " is not a node; it lies between ";
    s += a.dependent() ? "nodes " + std::to_string(p.node) + " and " + std::to_string(p.node + 1)
                       : "the nodes " + number_text(lo, 6) + " and " + number_text(hi, 6);
    return s + ": values interpolated linearly in the axis' warped coordinate (weights " +
           number_text(1 - p.s, 3) + ", " + number_text(p.s, 3) + ")";
}

}  // namespace brdftab

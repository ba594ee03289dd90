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

double explicit_unwarp(const std::vector<double>& v, double x) {
    const std::size_t n = v.size();
    // First node strictly greater than x, then step back to the cell start.
    std::size_t k = std::size_t(std::upper_bound(v.begin(), v.end(), x) - v.begin());
    k = (k == 0) ? 0 : k - 1;
    if (k > n - 2) k = n - 2;
    const double u = (x - v[k]) / (v[k + 1] - v[k]);
    return (double(k) + u) / double(n - 1);
}

}  // namespace

double Axis::warp(double t) const {
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
    }
    return min;
}

double Axis::unwarp(double x) const {
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
            return explicit_unwarp(values, x);
    }
    return 0;
}

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
    if (spacing == Spacing::Log && !(min > 0))
        throw InputError(what + "log spacing needs min > 0, got min = " + num(min));
    if (spacing == Spacing::Cos && (min < 0 || max > 180))
        throw InputError(what + "cos spacing needs an angle range within [0, 180] degrees, got [" +
                         num(min) + ", " + num(max) + "]");

    a.min = min;
    a.max = max;
    a.count = count;
    a.values.resize(count);
    for (std::size_t k = 0; k < count; ++k) a.values[k] = a.warp(double(k) / double(count - 1));
    // Guard the end points against t = k/(n-1) rounding (k = n-1 gives exactly
    // 1.0 in IEEE arithmetic, but be explicit) and reject grids so dense that
    // neighbouring nodes collapse in double precision.
    a.values.front() = min;
    a.values.back() = max;
    for (std::size_t k = 1; k < count; ++k) {
        if (!(a.values[k] > a.values[k - 1]))
            throw InputError(what + "nodes " + std::to_string(k - 1) + " and " +
                             std::to_string(k) + " coincide in double precision (" +
                             num(a.values[k]) + "); use fewer nodes or another spacing");
    }
    return a;
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
    const std::vector<std::size_t> idx = index_of(flat);
    std::vector<double> x(axes_.size());
    for (std::size_t d = 0; d < axes_.size(); ++d) x[d] = axes_[d].values[idx[d]];
    return x;
}

}  // namespace brdftab

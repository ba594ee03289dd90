// fast_axis.cpp — axes prepared for lookups (lookup_detail::FastAxis): the
// constants of each inverse warp computed once, the uniform node index that
// replaces binary searches over explicit node lists, and the out-of-line
// errors of the range checks.  The per-lookup code is inline in
// lookup_internal.h.
#include <algorithm>
#include <cmath>

#include "host/core/error.h"
#include "host/lookup/lookup.h"
#include "host/lookup/lookup_internal.h"

namespace brdftab {

namespace lookup_detail {

void NodeIndex::build(std::vector<double> v) {
    nodes = std::move(v);
    const std::size_t n = nodes.size();
    start.clear();
    lo = n ? nodes.front() : 0;
    inv_width = 0;
    if (n < 2) {
        start.assign(1, 0);
        return;
    }
    // Four bins per cell on average: with roughly even node spacing the scan
    // in cell() takes at most a step or two.
    const std::size_t bins = 4 * (n - 1);
    const double width = nodes.back() - nodes.front();
    inv_width = width > 0 ? double(bins) / width : 0;
    start.resize(bins);
    for (std::size_t b = 0; b < bins; ++b) {
        const double x = lo + double(b) / inv_width;
        std::size_t k = std::size_t(std::upper_bound(nodes.begin(), nodes.end(), x) - nodes.begin());
        k = k == 0 ? 0 : k - 1;
        if (k > n - 2) k = n - 2;
        start[b] = std::uint32_t(k);
    }
}

void FastAxis::build(const Axis& a) {
    count = a.count;
    last = double(a.count - 1);
    min = a.min;
    max = a.max;
    tol = 1e-9 * (a.max - a.min);
    span = a.max - a.min;
    dependent = a.dependent();
    if (!dependent && a.values.size() >= 2) cells.build(a.values);
    mirror = a.name == "phi_d" && a.spacing == Spacing::Linear && std::fabs(a.min) < 1e-9 &&
             (a.unit == "rad" ? std::fabs(a.max - lookup_internal::kPi) < 1e-9
                              : std::fabs(a.max - 180.0) < 1e-9);
    // The reduction of fold_periodic() (directions.cpp).
    periodic = Periodic::None;
    if (a.name == "phi_d") {
        half_turn = 0;
        if (a.unit == "deg" || a.unit == "degree" || a.unit == "degrees")
            half_turn = 180.0;
        else if (a.unit == "rad")
            half_turn = lookup_internal::kPi;
        if (half_turn > 0) {
            turn = 2 * half_turn;
            const double eps = 1e-12 * half_turn;
            periodic = a.min >= -eps && a.max <= half_turn + eps ? Periodic::Fold : Periodic::Wrap;
        }
    }
    constexpr double kDegToRad = lookup_internal::kPi / 180.0;
    switch (a.spacing) {
        case Spacing::Linear: warp = Warp::Linear; break;
        case Spacing::Cos:
            warp = Warp::Cos;
            c0 = std::cos(a.min * kDegToRad);
            dc = std::cos(a.max * kDegToRad) - c0;
            break;
        case Spacing::Log:
            warp = Warp::Log;
            log_ratio = std::log(a.max / a.min);
            break;
        case Spacing::Quadratic: warp = Warp::Quadratic; break;
        case Spacing::Explicit:
            warp = Warp::Explicit;
            explicit_nodes.build(a.values);
            break;
        case Spacing::LogComplement:
            warp = Warp::LogComplement;
            pivot = a.pivot;
            log_ratio = std::log((a.pivot - a.max) / (a.pivot - a.min));
            break;
        case Spacing::Critical: warp = Warp::General; break;
    }
}

}  // namespace lookup_detail

namespace lookup_internal {

double reduce_periodic(const FastAxis& f, double x) {
    if (f.periodic == FastAxis::Periodic::Fold) {
        // Into (-half, half], then |.|: phi_d and -phi_d are one configuration.
        double d = std::fmod(x, f.turn);
        if (d > f.half_turn) d -= f.turn;
        if (d <= -f.half_turn) d += f.turn;
        return std::fabs(d);
    }
    double v = std::fmod(x - f.min, f.turn);
    if (v < 0) v += f.turn;
    return f.min + v;
}

void throw_nan(const Axis& a, const std::string& table) {
    throw InputError("table '" + table + "': axis '" + a.name + "' value is NaN");
}

void throw_outside(const Axis& a, double x, const std::string& table) {
    throw InputError("table '" + table + "': axis '" + a.name + "' value " + fmt_num(x) +
                     " is outside " + range_text(a));
}

}  // namespace lookup_internal

}  // namespace brdftab

// lookup_internal.h — helpers shared by the files of the lookup library
// (lookup.cpp, interpolate.cpp, recombine.cpp, directions.cpp, sample.cpp).
// Not installed: the public API is lookup.h alone.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "host/core/grid.h"
#include "host/core/table.h"
#include "host/lookup/fast_trig.h"
#include "host/lookup/lookup.h"

namespace brdftab::lookup_internal {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

// Numbers in messages (10 significant digits) and "[min, max] unit"
// (interpolate.cpp).
std::string fmt_num(double v);
std::string range_text(const Axis& a);

// A phi_d coordinate outside its axis, reduced as direction lookups reduce
// it (directions.cpp): folded to |phi_d| in [0, 180] deg when the axis lies
// within [0, 180] (isotropy), else wrapped into [min, min + 360).  Other
// axes, units other than deg/rad, and values inside the axis are returned
// unchanged.
double fold_periodic(const Axis& a, double x);

// Validate a coordinate against its axis and apply the out-of-range policy
// (interpolate.cpp); phi_d is first reduced by fold_periodic().
double resolve(const Axis& a, double x, OutOfRange mode, const std::string& table);

using lookup_detail::FastAxis;
using lookup_detail::NodeIndex;

// The per-lookup helpers below are small enough to inline into the lookup
// kernels, where the axes' independent work can then overlap; GCC and Clang
// otherwise outline them from -O2 on.
#if defined(__GNUC__)
#define BT_LOOKUP_INLINE inline __attribute__((always_inline))
#else
#define BT_LOOKUP_INLINE inline
#endif

// A phi_d value outside its axis reduced as fold_periodic() does (f.periodic
// is Fold or Wrap, x finite); out of line, lookups rarely need it.
double reduce_periodic(const FastAxis& f, double x);

// The InputErrors of resolve(), out of line so that the lookups' hot code
// stays small (fast_axis.cpp).
[[noreturn]] void throw_nan(const Axis& a, const std::string& table);
[[noreturn]] void throw_outside(const Axis& a, double x, const std::string& table);

// resolve() on a prepared axis: the same checks, reduction and clamp, bit
// for bit (f was built from a).
BT_LOOKUP_INLINE double resolve_fast(const FastAxis& f, const Axis& a, double x, OutOfRange mode,
                                     const std::string& table) {
    if (std::isnan(x)) throw_nan(a, table);
    if (x < f.min || x > f.max) {
        if (f.periodic != FastAxis::Periodic::None && std::isfinite(x)) {
            x = reduce_periodic(f, x);
            if (!(x < f.min || x > f.max)) return x;
        }
        if (mode == OutOfRange::Reject && (x < f.min - f.tol || x > f.max + f.tol))
            throw_outside(a, x, table);
        x = std::min(std::max(x, f.min), f.max);
    }
    return x;
}

// Axis::unwarp(x) from the prepared constants (a: the axis f was built from,
// used by the critical warp only).  Not for dependent axes (unwarp_at).
BT_LOOKUP_INLINE double unwarp_fast(const FastAxis& f, const Axis& a, double x) {
    constexpr double kDegToRad = kPi / 180.0;  // as in grid.cpp
    switch (f.warp) {
        case FastAxis::Warp::General:
            return a.unwarp(x);
        case FastAxis::Warp::Explicit: {
            const double* v = f.explicit_nodes.nodes.data();
            const std::size_t k = f.explicit_nodes.cell(x);
            const double u = (x - v[k]) / (v[k + 1] - v[k]);
            return (double(k) + u) / f.last;
        }
        default:
            break;
    }
    if (x == f.min) return 0;
    if (x == f.max) return 1;
    switch (f.warp) {
        case FastAxis::Warp::Cos:
            return (std::cos(x * kDegToRad) - f.c0) / f.dc;
        case FastAxis::Warp::Log:
            if (x <= 0) return -std::numeric_limits<double>::infinity();
            return std::log(x / f.min) / f.log_ratio;
        case FastAxis::Warp::Quadratic: {
            const double r = (x - f.min) / f.span;
            return r >= 0 ? std::sqrt(r) : -std::sqrt(-r);
        }
        case FastAxis::Warp::LogComplement: {
            const double r = (f.pivot - x) / (f.pivot - f.min);
            if (!(r > 0))
                return f.pivot > f.max ? std::numeric_limits<double>::infinity()
                                       : -std::numeric_limits<double>::infinity();
            return std::log(r) / f.log_ratio;
        }
        default:
            return (x - f.min) / f.span;
    }
}

// The linear cell of normalised coordinate t: node k = min(floor(u),
// count - 2) for u = t (count - 1) clamped to [0, count - 1], and the
// fraction s in [0, 1] (the weights 1 - s, s of nodes k, k + 1).
BT_LOOKUP_INLINE std::size_t linear_cell_u(const FastAxis& f, double u, double& s);
BT_LOOKUP_INLINE std::size_t linear_cell(const FastAxis& f, double t, double& s) {
    return linear_cell_u(f, t * f.last, s);
}

// The same from the node coordinate u = t (count - 1).
BT_LOOKUP_INLINE std::size_t linear_cell_u(const FastAxis& f, double u, double& s) {
    if (!(u >= 0)) u = 0;  // also catches NaN from a degenerate warp
    if (u > f.last) u = f.last;
    // Signed conversions: u and k are small non-negative numbers, and the
    // unsigned ones cost a branch each.
    const std::size_t k =
        std::min<std::size_t>(std::size_t(std::int64_t(u)), f.count - 2);
    s = std::min(std::max(u - double(std::int64_t(k)), 0.0), 1.0);
    return k;
}

// Multilinear interpolation of the cell whose first corner is v: the
// tensor-product contraction of contract() for linear weights (1 - s[d],
// s[d]), in its order of operations, so the result is contract()'s bit for
// bit.  contract() skips zero weights; with Skip the products are selected
// away the same way, without it they are formed, which gives the same bits
// as long as the values are finite (0 * v = +-0, and 0.0 + (+-0) = +0 in
// both).  Unrolled at compile time for D axes.
template <int D, bool Skip, int d = 0>
BT_LOOKUP_INLINE double multilinear(const double* v, const std::size_t* strides, const double* s) {
    if constexpr (d == D) {
        return *v;
    } else {
        const double a = multilinear<D, Skip, d + 1>(v, strides, s);
        const double b = multilinear<D, Skip, d + 1>(v + strides[d], strides, s);
        const double w0 = 1.0 - s[d], w1 = s[d];
        if constexpr (Skip)
            return (0.0 + (w0 != 0 ? w0 * a : 0.0)) + (w1 != 0 ? w1 * b : 0.0);
        else
            return (0.0 + w0 * a) + w1 * b;
    }
}

// Whether every value is finite (the unskipped multilinear path applies).
inline bool all_finite(const std::vector<double>& v) {
    for (double x : v)
        if (!std::isfinite(x)) return false;
    return true;
}

// Linear lookups on up to this many axes take the unrolled path.
constexpr std::size_t kMaxUnrolledDims = 8;

// Sparse 1-D interpolation weights over real node indices of one axis.
struct AxisWeights {
    std::size_t idx[4];
    double w[4];
    int n = 0;
    void add(std::size_t i, double wt) {
        for (int k = 0; k < n; ++k)
            if (idx[k] == i) {
                w[k] += wt;
                return;
            }
        idx[n] = i;
        w[n] = wt;
        ++n;
    }
    void single(std::size_t i) {
        n = 0;
        add(i, 1.0);
    }
};

// Weights of a range-resolved coordinate on one axis, and their
// tensor-product contraction with a row-major array (interpolate.cpp).
void axis_weights(const Axis& a, double x, Interpolation interp, AxisWeights& out);
// The same from the axis' normalised coordinate t (node k at k/(count-1)).
void axis_weights_t(const Axis& a, double t, Interpolation interp, AxisWeights& out);
// The same with the ghost rule given: count nodes, mirrored ghosts or not.
void axis_weights_n(std::size_t count, bool mirror, double t, Interpolation interp,
                    AxisWeights& out);
double contract(const AxisWeights* ws, const std::size_t* strides, std::size_t dims,
                const double* values, std::size_t d = 0, std::size_t offset = 0);

// Table names a "recombine" object refers to, after checking its shape
// (recombine.cpp).
std::vector<std::string> recombine_tables(const TableData& head);

// Direction helpers (directions.cpp, sample.cpp).
[[noreturn]] void throw_zero_direction();

// w.z / |w| clamped to [-1, 1]: the cosine of w's polar angle.  A zero or
// NaN length is an InputError.
BT_LOOKUP_INLINE double unit_z(const Vec3& w) {
    const double l = std::sqrt(w.x * w.x + w.y * w.y + w.z * w.z);
    if (!(l > 0)) throw_zero_direction();
    return std::min(1.0, std::max(-1.0, w.z / l));
}

// The coordinate of w's polar angle on a mu axis (unit_z()) or on a theta
// axis: atan2(sqrt(x^2 + y^2), z) in radians times `per_rad` (axis units
// per radian), from the fast atan2 (fast_trig.h, within 2.5e-15 rad of
// std::acos(unit_z(w))), without normalising w.  The same InputError as
// unit_z() for a zero or NaN vector.
BT_LOOKUP_INLINE double polar_coordinate(const Vec3& w, bool mu, double per_rad) {
    if (mu) return unit_z(w);
    const double r2 = w.x * w.x + w.y * w.y;
    if (!(r2 + w.z * w.z > 0)) throw_zero_direction();
    return fast_trig::atan2(std::sqrt(r2), w.z) * per_rad;
}

// phi_o - phi_i in (-pi, pi] from the tangent components of wi and wo, with
// phi = atan2(y, x) (0 on the pole).  One atan2 of the cross and dot
// products instead of the difference of two: the same angle up to rounding
// (a few 1e-16 rad), and the fast atan2 adds at most 2.5e-15 rad.  A
// direction on the pole keeps azimuth 0, as in the sampler.
BT_LOOKUP_INLINE double phi_difference(double ix, double iy, double ox, double oy) {
    double d;
    if (ix == 0 && iy == 0)
        d = fast_trig::atan2(oy, ox);
    else if (ox == 0 && oy == 0)
        d = -fast_trig::atan2(iy, ix);
    else
        d = fast_trig::atan2(ix * oy - iy * ox, ix * ox + iy * oy);
    if (d <= -kPi) d += 2 * kPi;
    return d;
}

// The phi_d coordinate (axis units) of an azimuth difference d in (-pi, pi]:
// |d| when the axis is folded (isotropy), else wrapped into
// [min, min + 360).
BT_LOOKUP_INLINE double phi_coordinate(const LookupTable::AngleLayout& L, double axis_min, double d) {
    if (L.fold_phi) return std::fabs(d) * L.per_rad_phi;
    const double period = 2 * kPi * L.per_rad_phi;
    double v = d * L.per_rad_phi - axis_min;
    if (!(v >= 0 && v < period)) {
        v = std::fmod(v, period);
        if (v < 0) v += period;
    }
    return axis_min + v;
}

// Angular coordinates of (wi, wo) in axis units, phi reduced to the phi
// axis' span (directions.cpp).
void direction_coords(const LookupTable::AngleLayout& L, const Axis* phi_axis,
                      const Vec3& wi, const Vec3& wo, double& xi, double& xo, double& xphi);

}  // namespace brdftab::lookup_internal

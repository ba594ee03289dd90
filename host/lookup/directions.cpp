// directions.cpp — direction-level lookup for isotropic tables: (wi, wo) to
// the table's angular coordinates, LookupTable::eval_dirs, and bind(), which
// fixes every non-angle coordinate and leaves a BoundTable over the angles.
#include <algorithm>
#include <cmath>
#include <limits>

#include "host/core/error.h"
#include "host/lookup/lookup.h"
#include "host/lookup/lookup_internal.h"

namespace brdftab {

namespace lookup_internal {

double fold_periodic(const Axis& a, double x) {
    if (a.name != "phi_d" || !(x < a.min || x > a.max) || !std::isfinite(x)) return x;
    double half_turn;
    if (a.unit == "deg" || a.unit == "degree" || a.unit == "degrees")
        half_turn = 180.0;
    else if (a.unit == "rad")
        half_turn = kPi;
    else
        return x;
    const double turn = 2 * half_turn;
    const double eps = 1e-12 * half_turn;
    if (a.min >= -eps && a.max <= half_turn + eps) {
        // Into (-half, half], then |.|: phi_d and -phi_d are one configuration.
        double d = std::fmod(x, turn);
        if (d > half_turn) d -= turn;
        if (d <= -half_turn) d += turn;
        return std::fabs(d);
    }
    double v = std::fmod(x - a.min, turn);
    if (v < 0) v += turn;
    return a.min + v;
}

void throw_zero_direction() { throw InputError("direction vector has zero or NaN length"); }

// Shared by LookupTable::eval_dirs and BoundTable: angular coordinates of
// (wi, wo) in axis units.  phi is reduced to the phi axis' span (fold or wrap).
void direction_coords(const LookupTable::AngleLayout& L, const Axis* phi_axis,
                      const Vec3& wi, const Vec3& wo, double& xi, double& xo, double& xphi) {
    xi = polar_coordinate(wi, L.mu_i, L.per_rad_i);
    xo = polar_coordinate(wo, L.mu_o, L.per_rad_o);
    // atan2(0, 0) = 0: a direction on the pole gets azimuth 0, both here and
    // in the sampler, so pdf() and sample() agree there too.
    xphi = phi_axis ? phi_coordinate(L, phi_axis->min, phi_difference(wi.x, wi.y, wo.x, wo.y))
                    : 0.0;
}

}  // namespace lookup_internal

using namespace lookup_internal;

// Coordinates of the non-angle axes from `params` (NaN in angle slots).
std::vector<double> LookupTable::param_coords(const std::map<std::string, double>& params,
                                              double* p_out) const {
    if (!directional_) throw InputError(directional_error_);
    const auto& ax = axes();
    std::vector<double> v(ax.size() + (terms_.empty() ? 0 : 1),
                          std::numeric_limits<double>::quiet_NaN());
    std::vector<std::string> used;
    for (std::size_t d = 0; d < ax.size(); ++d) {
        if (int(d) == layout_.axis_i || int(d) == layout_.axis_o || int(d) == layout_.axis_phi)
            continue;
        auto it = params.find(ax[d].name);
        if (it == params.end())
            throw InputError("table '" + table().name + "': parameter '" + ax[d].name +
                             "' is missing (range " + range_text(ax[d]) + ")");
        v[d] = it->second;
        used.push_back(ax[d].name);
    }
    if (!terms_.empty()) {
        auto it = params.find(rparam_);
        if (it == params.end())
            throw InputError("table '" + table().name + "': parameter '" + rparam_ +
                             "' is missing");
        v.back() = it->second;
        used.push_back(rparam_);
        if (p_out) *p_out = it->second;
    }
    for (const auto& kv : params)
        if (std::find(used.begin(), used.end(), kv.first) == used.end())
            throw InputError("table '" + table().name + "': unknown parameter '" + kv.first +
                             "'");
    return v;
}

// The coordinates of a direction-level lookup: the parameter coordinates
// (param_coords()) with the angles of (wi, wo) in their slots.
void LookupTable::dirs_point(const double* pc, const Vec3& wi, const Vec3& wo,
                             double* coords) const {
    const std::size_t width = axes().size() + (terms_.empty() ? 0 : 1);
    std::copy(pc, pc + width, coords);
    double xi, xo, xphi;
    const Axis* phi_axis = layout_.axis_phi >= 0 ? &axes()[layout_.axis_phi] : nullptr;
    direction_coords(layout_, phi_axis, wi, wo, xi, xo, xphi);
    coords[layout_.axis_i] = xi;
    coords[layout_.axis_o] = xo;
    if (phi_axis) coords[layout_.axis_phi] = xphi;
}

double LookupTable::eval_dirs(const Vec3& wi, const Vec3& wo,
                              const std::map<std::string, double>& params,
                              Interpolation interp, OutOfRange mode) const {
    const std::vector<double> pc = param_coords(params, nullptr);
    std::vector<double> v(pc.size());
    dirs_point(pc.data(), wi, wo, v.data());
    return eval_point(v.data(), interp, mode);
}

void LookupTable::eval_dirs_many(const double* wi, const double* wo, std::size_t count,
                                 double* out, const std::map<std::string, double>& params,
                                 Interpolation interp, OutOfRange mode) const {
    const std::vector<double> pc = param_coords(params, nullptr);
    std::vector<double> v(pc.size());
    for (std::size_t k = 0; k < count; ++k) {
        const double* a = wi + 3 * k;
        const double* b = wo + 3 * k;
        dirs_point(pc.data(), {a[0], a[1], a[2]}, {b[0], b[1], b[2]}, v.data());
        out[k] = eval_point(v.data(), interp, mode);
    }
}

BoundTable LookupTable::bind(const std::map<std::string, double>& params,
                             Interpolation interp, OutOfRange mode) const {
    std::vector<double> v = param_coords(params, nullptr);
    if (adaptive_ && interp == Interpolation::Cubic) refuse_adaptive("no cubic interpolation");
    const auto& ax = axes();
    const std::size_t dims = ax.size();
    std::vector<AxisWeights> ws(dims);
    for (std::size_t d = 0; d < dims; ++d) {
        if (int(d) == layout_.axis_i || int(d) == layout_.axis_o || int(d) == layout_.axis_phi)
            continue;
        if (adaptive_)  // resolved as eval() resolves them
            v[d] = resolve_fast(fast_[d], ax[d], v[d], mode, table().name);
        else
            axis_weights(ax[d], resolve(ax[d], v[d], mode, table().name), interp, ws[d]);
    }
    double p = 0;
    if (!terms_.empty()) {
        p = v.back();
        resolve_param(p, mode);
    }

    BoundTable b;
    b.name_ = table().name;
    b.layout_ = layout_;
    b.interp_ = interp;
    b.mode_ = mode;
    b.axes_.push_back(ax[layout_.axis_i]);
    b.axes_.push_back(ax[layout_.axis_o]);
    b.has_phi_ = layout_.axis_phi >= 0;
    if (b.has_phi_) {
        b.axes_.push_back(ax[layout_.axis_phi]);
    } else {
        // Azimuth-independent table: a 2-node synthetic phi_d axis over [0, 180]
        // carrying the same value at both nodes.
        Axis a;
        a.name = "phi_d";
        a.unit = "deg";
        a.min = 0;
        a.max = 180;
        a.count = 2;
        a.spacing = Spacing::Linear;
        a.values = {0.0, 180.0};
        b.axes_.push_back(a);
        b.layout_.fold_phi = true;
        b.layout_.scale_phi = kDeg;
        b.layout_.per_rad_phi = 1 / kDeg;
    }
    const std::size_t ni = b.axes_[0].count, no = b.axes_[1].count, np = b.axes_[2].count;
    for (int d = 0; d < 3; ++d) b.fast_[d].build(b.axes_[d]);
    b.stride_i_ = no * np;
    b.stride_o_ = np;
    if (adaptive_) {
        b.bind_adaptive(*this, v);
        b.build_sampling();
        return b;
    }
    b.values_.resize(ni * no * np);
    std::vector<double> pv(pieces_.size());
    for (std::size_t i = 0; i < ni; ++i)
        for (std::size_t o = 0; o < no; ++o)
            for (std::size_t f = 0; f < np; ++f) {
                ws[layout_.axis_i].single(i);
                ws[layout_.axis_o].single(o);
                if (b.has_phi_) ws[layout_.axis_phi].single(f);
                for (std::size_t k = 0; k < pieces_.size(); ++k)
                    pv[k] = contract(ws.data(), strides_.data(), dims, pieces_[k].value.data());
                b.values_[(i * no + o) * np + f] = combine(pv.data(), p);
            }
    b.kernel_ = interp == Interpolation::Cubic ? BoundTable::Kernel::GridCubic
                : all_finite(b.values_)            ? BoundTable::Kernel::GridLinear
                                                   : BoundTable::Kernel::GridLinearNonFinite;
    b.build_sampling();  // with the axis coordinates (the direction kernel is off)
    b.build_direction_kernel();
    return b;
}

// ---------------------------------------------------------------------------
// BoundTable

double BoundTable::eval_angles(double xi, double xo, double xphi) const {
    const double x[3] = {resolve_fast(fast_[0], axes_[0], xi, mode_, name_),
                         resolve_fast(fast_[1], axes_[1], xo, mode_, name_),
                         resolve_fast(fast_[2], axes_[2], xphi, mode_, name_)};
    const std::size_t strides[3] = {stride_i_, stride_o_, 1};
    switch (kernel_) {
        case Kernel::GridLinear:
        case Kernel::GridLinearNonFinite: {
            double s[3];
            std::size_t offset = 0;
#pragma GCC unroll 3
            for (int d = 0; d < 3; ++d)
                offset += linear_cell(fast_[d], unwarp_fast(fast_[d], axes_[d], x[d]), s[d]) *
                          strides[d];
            const double* v = values_.data() + offset;
            return kernel_ == Kernel::GridLinear ? multilinear<3, false>(v, strides, s)
                                                 : multilinear<3, true>(v, strides, s);
        }
        case Kernel::GridCubic:
            break;
        case Kernel::Adaptive:
            return eval_adaptive(x);
    }
    AxisWeights ws[3];
    for (int d = 0; d < 3; ++d)
        axis_weights_n(fast_[d].count, fast_[d].mirror, unwarp_fast(fast_[d], axes_[d], x[d]),
                       interp_, ws[d]);
    return contract(ws, strides, 3, values_.data());
}

void BoundTable::build_direction_kernel() {
    dir_affine_ = false;
    if (mode_ != OutOfRange::Clamp ||
        !(kernel_ == Kernel::GridLinear || kernel_ == Kernel::GridLinearNonFinite))
        return;
    for (int d = 0; d < 3; ++d) {
        const FastAxis& f = fast_[d];
        const bool mu = d == 0 ? layout_.mu_i : d == 1 && layout_.mu_o;
        const double per_rad = d == 0 ? layout_.per_rad_i : d == 1 ? layout_.per_rad_o
                                                                   : layout_.per_rad_phi;
        double a, b;  // u = (q - b') a'
        if (f.warp == FastAxis::Warp::Linear && f.span > 0 && (d < 2 || layout_.fold_phi)) {
            // theta or |phi_d| in radians times per_rad, or mu.
            a = (mu ? 1.0 : per_rad) * f.last / f.span;
            b = -f.min * f.last / f.span;
            if (d < 2) dir_cos_[d] = mu;
        } else if (d < 2 && !mu && f.warp == FastAxis::Warp::Cos && f.dc != 0) {
            a = f.last / f.dc;  // t = (cos(theta) - c0) / dc
            b = -f.c0 * f.last / f.dc;
            dir_cos_[d] = true;
        } else {
            return;
        }
        dir_a_[d] = a;
        dir_b_[d] = b;
    }
    dir_affine_ = true;
}

double BoundTable::direction_coord(const Vec3& w, int axis) const {
    if (!dir_affine_)
        return axis == 0 ? polar_coordinate(w, layout_.mu_i, layout_.per_rad_i)
                         : polar_coordinate(w, layout_.mu_o, layout_.per_rad_o);
    const double q = dir_cos_[axis] ? unit_z(w) : polar_coordinate(w, false, 1.0);
    return q * dir_a_[axis] + dir_b_[axis];
}

// The direction kernel's lookup at node coordinates u (clamped here).  With
// finite values the corners are blended as a + s (b - a), two operations a
// blend instead of contract()'s three (the direction kernel is bound to no
// other lookup's bits); with non-finite ones as contract() does, which
// skips zero weights.
double BoundTable::eval_u(const double* u) const {
    const std::size_t strides[3] = {stride_i_, stride_o_, 1};
    double s[3];
    std::size_t offset = 0;
#pragma GCC unroll 3
    for (int d = 0; d < 3; ++d) offset += linear_cell_u(fast_[d], u[d], s[d]) * strides[d];
    const double* v = values_.data() + offset;
    if (kernel_ != Kernel::GridLinear) return multilinear<3, true>(v, strides, s);
    const std::size_t si = stride_i_, so = stride_o_;
    auto lerp = [](double a, double b, double t) { return a + t * (b - a); };
    const double c00 = lerp(v[0], v[1], s[2]), c01 = lerp(v[so], v[so + 1], s[2]);
    const double c10 = lerp(v[si], v[si + 1], s[2]), c11 = lerp(v[si + so], v[si + so + 1], s[2]);
    return lerp(lerp(c00, c01, s[1]), lerp(c10, c11, s[1]), s[0]);
}

BoundTable::Incident BoundTable::incident(const Vec3& wi) const {
    Incident in;
    in.xi = direction_coord(wi, 0);
    in.x = wi.x;
    in.y = wi.y;
    return in;
}

double BoundTable::eval_from(const Incident& in, double xo, double d) const {
    if (dir_affine_) {
        const double u[3] = {in.xi, xo, std::fabs(d) * dir_a_[2] + dir_b_[2]};
        return eval_u(u);
    }
    return eval_angles(in.xi, xo, phi_coordinate(layout_, axes_[2].min, d));
}

double BoundTable::eval(const Vec3& wi, const Vec3& wo) const {
    const Incident in = incident(wi);
    return eval_from(in, direction_coord(wo, 1), phi_difference(in.x, in.y, wo.x, wo.y));
}

void BoundTable::eval_many(const double* wi, const double* wo, std::size_t count,
                           double* out) const {
    for (std::size_t k = 0; k < count; ++k) {
        const double* a = wi + 3 * k;
        const double* b = wo + 3 * k;
        out[k] = eval({a[0], a[1], a[2]}, {b[0], b[1], b[2]});
    }
}

}  // namespace brdftab

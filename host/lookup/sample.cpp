// sample.cpp — importance sampling of a BoundTable: per theta_i node a
// piecewise-constant density over theta_o x phi_d cells (built once by
// bind()), the sampler that mixes neighbouring nodes, and its pdf for MIS.
#include <algorithm>
#include <cmath>

#include "host/core/error.h"
#include "host/lookup/lookup.h"
#include "host/lookup/lookup_internal.h"

namespace brdftab {

using namespace lookup_internal;

void BoundTable::build_sampling() {
    const Axis& ao = axes_[1];
    const Axis& ap = axes_[2];
    // Coverage: theta_o must span [0, 90] or [0, 180]; phi_d [0, 180] (folded)
    // or a full 360-degree period (wrapped).
    double mu_top, mu_bottom;
    if (layout_.mu_o) {
        mu_top = ao.max;
        mu_bottom = ao.min;
    } else {
        mu_top = std::cos(ao.min * layout_.scale_o);
        mu_bottom = std::cos(ao.max * layout_.scale_o);
    }
    if (std::fabs(mu_top - 1) > 1e-9 ||
        !(std::fabs(mu_bottom) < 1e-9 || std::fabs(mu_bottom + 1) < 1e-9)) {
        sampling_error_ = "table '" + name_ + "': sampling needs the " + ao.name +
                          " axis to cover theta_o in [0, 90] or [0, 180] degrees";
        return;
    }
    const double pspan = (ap.max - ap.min) * layout_.scale_phi;
    if (layout_.fold_phi ? (std::fabs(ap.min) > 1e-9 || std::fabs(pspan - kPi) > 1e-9)
                         : std::fabs(pspan - 2 * kPi) > 1e-9) {
        sampling_error_ = "table '" + name_ +
                          "': sampling needs phi_d to span [0, 180] degrees or a full "
                          "360-degree period";
        return;
    }
    phi_mult_ = layout_.fold_phi ? 2.0 : 1.0;
    const std::size_t ni = axes_[0].count, no = ao.count, np = ap.count;
    mu_nodes_o_.resize(no);
    for (std::size_t k = 0; k < no; ++k)
        mu_nodes_o_[k] = layout_.mu_o ? ao.values[k] : std::cos(ao.values[k] * layout_.scale_o);
    phi_nodes_.resize(np);
    for (std::size_t l = 0; l < np; ++l) phi_nodes_[l] = ap.values[l] * layout_.scale_phi;

    const double g = 0.5 / std::sqrt(3.0);  // 2-point Gauss abscissae at mid +- g * width
    const std::size_t co = no - 1, cp = np - 1;
    cell_prob_.assign(ni * co * cp, 0.0);
    cell_density_.assign(ni * co * cp, 0.0);
    cdf_o_.assign(ni * no, 0.0);
    cdf_phi_.assign(ni * co * np, 0.0);
    for (std::size_t j = 0; j < ni; ++j) {
        const double xi = axes_[0].values[j];
        double* cell_prob = cell_prob_.data() + j * co * cp;
        double* cdf_o = cdf_o_.data() + j * no;
        double* cdf_phi = cdf_phi_.data() + j * co * np;
        double total = 0;
        for (std::size_t k = 0; k < co; ++k) {
            const double ma = std::min(mu_nodes_o_[k], mu_nodes_o_[k + 1]);
            const double mb = std::max(mu_nodes_o_[k], mu_nodes_o_[k + 1]);
            // Split at mu = 0 so |mu| is smooth on each piece (the integrand
            // is then polynomial enough for 2x2 Gauss to be exact for the
            // multilinear interpolant of a cos-spaced axis).
            double cuts[3] = {ma, mb, mb};
            int pieces = 1;
            if (ma < 0 && mb > 0) {
                cuts[1] = 0;
                pieces = 2;
            }
            const double mean_abs_mu =
                (ma >= 0 ? 0.5 * (ma + mb)
                         : (mb <= 0 ? -0.5 * (ma + mb) : 0.5 * (ma * ma + mb * mb) / (mb - ma)));
            for (std::size_t l = 0; l < cp; ++l) {
                const double pa = phi_nodes_[l], pb = phi_nodes_[l + 1];
                double w = 0;
                for (int s = 0; s < pieces; ++s) {
                    const double a = cuts[s], b = cuts[s + 1];
                    const double mm = 0.5 * (a + b), hm = b - a;
                    const double pm = 0.5 * (pa + pb), hp = pb - pa;
                    for (int q = 0; q < 4; ++q) {
                        const double mu = mm + ((q & 1) ? g : -g) * hm;
                        const double ph = pm + ((q & 2) ? g : -g) * hp;
                        const double xo = layout_.mu_o ? mu : std::acos(mu) / layout_.scale_o;
                        const double f = eval_angles(xi, xo, ph / layout_.scale_phi);
                        w += 0.25 * hm * hp * std::max(f, 0.0) * std::fabs(mu);
                    }
                }
                if (w == 0) {
                    // Keep cells whose corner nodes are positive reachable
                    // (Catmull-Rom may undershoot to 0 at the Gauss points).
                    double corner = 0;
                    for (std::size_t dk = 0; dk < 2; ++dk)
                        for (std::size_t dl = 0; dl < 2; ++dl)
                            corner = std::max(corner,
                                              values_[(j * no + k + dk) * np + l + dl]);
                    w = 1e-3 * corner * mean_abs_mu * (mb - ma) * (pb - pa);
                }
                cell_prob[k * cp + l] = w;
                total += w;
            }
        }
        if (!(total > 0)) {
            // f == 0 for this theta_i: any density works (weights are 0);
            // use uniform in solid angle.
            total = 0;
            for (std::size_t k = 0; k < co; ++k)
                for (std::size_t l = 0; l < cp; ++l) {
                    const double w = std::fabs(mu_nodes_o_[k + 1] - mu_nodes_o_[k]) *
                                     (phi_nodes_[l + 1] - phi_nodes_[l]);
                    cell_prob[k * cp + l] = w;
                    total += w;
                }
        }
        for (std::size_t c = 0; c < co * cp; ++c) cell_prob[c] /= total;
        for (std::size_t k = 0; k < co; ++k) {
            double row = 0;
            for (std::size_t l = 0; l < cp; ++l) {
                row += cell_prob[k * cp + l];
                cdf_phi[k * np + l + 1] = row;
            }
            for (std::size_t l = 1; l <= cp; ++l)
                cdf_phi[k * np + l] = row > 0 ? cdf_phi[k * np + l] / row : double(l) / cp;
            cdf_phi[k * np + cp] = 1.0;
            cdf_o[k + 1] = cdf_o[k] + row;
        }
        for (std::size_t k = 1; k < no; ++k) cdf_o[k] /= cdf_o[co];
        cdf_o[co] = 1.0;
        // Densities w.r.t. solid angle: the cell probability over its area
        // (phi_mult_: a folded cell stands for both signs of phi_d).
        for (std::size_t k = 0; k < co; ++k)
            for (std::size_t l = 0; l < cp; ++l) {
                const double area = phi_mult_ * std::fabs(mu_nodes_o_[k + 1] - mu_nodes_o_[k]) *
                                    (phi_nodes_[l + 1] - phi_nodes_[l]);
                cell_density_[(j * co + k) * cp + l] = cell_prob[k * cp + l] / area;
            }
    }
    // Cell lookups for pdf(): ascending node lists (mu negated on a theta
    // axis, where it decreases along the axis).
    std::vector<double> mu_sorted(mu_nodes_o_);
    if (!layout_.mu_o)
        for (double& m : mu_sorted) m = -m;
    mu_index_.build(std::move(mu_sorted));
    phi_index_.build(phi_nodes_);
}

namespace {
// Pick cell c with cdf[c] <= u < cdf[c+1] (never a zero-probability cell) and
// return u rescaled to [0, 1) within it.  The search is std::upper_bound's
// over cdf[0..cells], branch-free: its steps depend on `cells` alone.
std::size_t pick(const double* cdf, std::size_t cells, double& u) {
    u = std::min(std::max(u, 0.0), 1.0);
    const double* base = cdf;
    for (std::size_t len = cells + 1; len > 1;) {
        const std::size_t half = len / 2;
        base = u < base[half] ? base : base + half;
        len -= half;
    }
    std::size_t c = std::size_t(base - cdf) + (u < *base ? 0 : 1);  // upper_bound
    c = c == 0 ? 0 : c - 1;
    if (c >= cells) c = cells - 1;
    while (c > 0 && !(cdf[c + 1] > cdf[c])) --c;  // u == 1 lands past the last positive cell
    const double width = cdf[c + 1] - cdf[c];
    u = width > 0 ? std::min(std::max((u - cdf[c]) / width, 0.0), 1.0) : 0.5;
    return c;
}
}  // namespace

void BoundTable::node_mixture(double xi, std::size_t& j0, double& w1) const {
    double s;
    if (dir_affine_) {  // xi is the node coordinate u
        j0 = linear_cell_u(fast_[0], xi, s);
    } else {
        xi = resolve_fast(fast_[0], axes_[0], xi, mode_, name_);
        j0 = linear_cell(fast_[0], unwarp_fast(fast_[0], axes_[0], xi), s);
    }
    w1 = s;
}

BoundTable::Incident BoundTable::incident_sampled(const Vec3& wi) const {
    Incident in = incident(wi);
    node_mixture(in.xi, in.j0, in.w1);
    return in;
}

// The mixture of the two theta_i nodes' piecewise-constant densities at wo.
double BoundTable::pdf_from(const Incident& in, double mu, double d) const {
    // theta_o cell: mu outside the nodes' range has density 0.
    const std::size_t no = mu_nodes_o_.size(), np = phi_nodes_.size();
    const double lo = std::min(mu_nodes_o_[0], mu_nodes_o_[no - 1]);
    const double hi = std::max(mu_nodes_o_[0], mu_nodes_o_[no - 1]);
    if (mu < lo || mu > hi) return 0;
    std::size_t k, l;
    double s;
    // With the direction kernel, the cells of axes evenly spaced in mu and
    // of the phi_d axis follow from its affine node coordinates.
    if (dir_affine_ && dir_cos_[1])
        k = linear_cell_u(fast_[1], mu * dir_a_[1] + dir_b_[1], s);
    else
        k = mu_index_.cell(layout_.mu_o ? mu : -mu);
    if (dir_affine_)
        l = linear_cell_u(fast_[2], std::fabs(d) * dir_a_[2] + dir_b_[2], s);
    else
        l = phi_index_.cell(phi_coordinate(layout_, axes_[2].min, d) * layout_.scale_phi);
    const std::size_t cells = (no - 1) * (np - 1), c = k * (np - 1) + l;
    const double w1 = in.w1;
    double p = 0;
    if (w1 < 1) p += (1 - w1) * cell_density_[in.j0 * cells + c];
    if (w1 > 0) p += w1 * cell_density_[(in.j0 + 1) * cells + c];
    return p;
}

double BoundTable::pdf(const Vec3& wi, const Vec3& wo) const {
    if (!can_sample()) throw Error(sampling_error_);
    const double mo = unit_z(wo);
    const Incident in = incident_sampled(wi);
    return pdf_from(in, mo, phi_difference(in.x, in.y, wo.x, wo.y));
}

void BoundTable::pdf_many(const double* wi, const double* wo, std::size_t count,
                          double* out) const {
    if (!can_sample()) throw Error(sampling_error_);
    for (std::size_t k = 0; k < count; ++k) {
        const double* a = wi + 3 * k;
        const double* b = wo + 3 * k;
        out[k] = pdf({a[0], a[1], a[2]}, {b[0], b[1], b[2]});
    }
}

SampleResult BoundTable::sample_from(const Incident& in, double u1, double u2) const {
    // Choose the theta_i node with probability equal to its interpolation
    // weight, re-using u1.
    // Both choices below are taken at random, half of the time each: as 0/1
    // factors, not branches, which would be mispredicted as often.
    const double w1 = in.w1;
    u1 = std::min(std::max(u1, 0.0), 1.0);
    const int up = w1 > 0 && u1 < w1;  // node j0 + 1, u1 rescaled from [0, w1)
    const double upf = double(up);
    const std::size_t j = in.j0 + std::size_t(up);
    const double num = u1 - (1 - upf) * w1, den = upf * w1 + (1 - upf) * (1 - w1);
    u1 = den > 0 ? num / den : u1;
    const std::size_t no = mu_nodes_o_.size(), np = phi_nodes_.size();
    const std::size_t co = no - 1, cp = np - 1;
    const std::size_t k = pick(cdf_o_.data() + j * no, co, u1);
    const std::size_t l = pick(cdf_phi_.data() + (j * co + k) * np, cp, u2);
    double sign = 1;
    if (phi_mult_ == 2) {  // mirror: phi_d and -phi_d equally likely
        const double neg = double(u2 >= 0.5);
        sign = 1 - 2 * neg;
        u2 = 2 * u2 - neg;
    }
    // Uniform in (cos theta, phi) inside the cell: constant density in solid angle.
    const double mu = mu_nodes_o_[k] + u1 * (mu_nodes_o_[k + 1] - mu_nodes_o_[k]);
    const double pd = phi_nodes_[l] + u2 * (phi_nodes_[l + 1] - phi_nodes_[l]);
    const double st = std::sqrt(std::max(0.0, 1 - mu * mu));
    // phi_o = phi_i + sign * pd, by rotating wi's azimuth direction (1, 0 on
    // the pole) by sign * pd.
    double ci = 1, si = 0;
    const double r = std::sqrt(in.x * in.x + in.y * in.y);
    if (r > 0) {
        const double inv = 1 / r;
        ci = in.x * inv;
        si = in.y * inv;
    }
    double cp_, sp;
    fast_trig::sincos(pd, sp, cp_);  // |pd| <= 2 pi
    sp *= sign;
    SampleResult res;
    res.wo = {st * (ci * cp_ - si * sp), st * (si * cp_ + ci * sp), mu};
    // pdf() and eval() at wo, sharing its azimuth difference: the same
    // functions of wo as there, so the same bits.
    const double mo = unit_z(res.wo), d = phi_difference(in.x, in.y, res.wo.x, res.wo.y);
    res.pdf = pdf_from(in, mo, d);
    res.value = eval_from(in, direction_coord(res.wo, 1), d);
    res.weight = res.pdf > 0 ? res.value * std::fabs(mu) / res.pdf : 0.0;
    return res;
}

SampleResult BoundTable::sample(const Vec3& wi, double u1, double u2) const {
    if (!can_sample()) throw Error(sampling_error_);
    return sample_from(incident_sampled(wi), u1, u2);
}

void BoundTable::sample_many(const double* wi, const double* u, std::size_t count, double* wo,
                             double* pdf, double* value, double* weight) const {
    if (!can_sample()) throw Error(sampling_error_);
    for (std::size_t k = 0; k < count; ++k) {
        const double* a = wi + 3 * k;
        const SampleResult r = sample_from(incident_sampled({a[0], a[1], a[2]}), u[2 * k],
                                           u[2 * k + 1]);
        wo[3 * k] = r.wo.x;
        wo[3 * k + 1] = r.wo.y;
        wo[3 * k + 2] = r.wo.z;
        if (pdf) pdf[k] = r.pdf;
        if (value) value[k] = r.value;
        if (weight) weight[k] = r.weight;
    }
}

}  // namespace brdftab

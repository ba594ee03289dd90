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
    dists_.resize(ni);
    for (std::size_t j = 0; j < ni; ++j) {
        const double xi = axes_[0].values[j];
        NodeDist& nd = dists_[j];
        nd.cell_prob.assign(co * cp, 0.0);
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
                nd.cell_prob[k * cp + l] = w;
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
                    nd.cell_prob[k * cp + l] = w;
                    total += w;
                }
        }
        for (auto& w : nd.cell_prob) w /= total;
        nd.cdf_o.assign(no, 0.0);
        nd.cdf_phi.assign(co * np, 0.0);
        for (std::size_t k = 0; k < co; ++k) {
            double row = 0;
            for (std::size_t l = 0; l < cp; ++l) {
                row += nd.cell_prob[k * cp + l];
                nd.cdf_phi[k * np + l + 1] = row;
            }
            for (std::size_t l = 1; l <= cp; ++l)
                nd.cdf_phi[k * np + l] = row > 0 ? nd.cdf_phi[k * np + l] / row : double(l) / cp;
            nd.cdf_phi[k * np + cp] = 1.0;
            nd.cdf_o[k + 1] = nd.cdf_o[k] + row;
        }
        for (std::size_t k = 1; k < no; ++k) nd.cdf_o[k] /= nd.cdf_o[co];
        nd.cdf_o[co] = 1.0;
    }
}

namespace {
// Pick cell c with cdf[c] <= u < cdf[c+1] (never a zero-probability cell) and
// return u rescaled to [0, 1) within it.
std::size_t pick(const double* cdf, std::size_t cells, double& u) {
    u = std::min(std::max(u, 0.0), 1.0);
    std::size_t c = std::size_t(std::upper_bound(cdf, cdf + cells + 1, u) - cdf);
    c = c == 0 ? 0 : c - 1;
    if (c >= cells) c = cells - 1;
    while (c > 0 && !(cdf[c + 1] > cdf[c])) --c;  // u == 1 lands past the last positive cell
    const double width = cdf[c + 1] - cdf[c];
    u = width > 0 ? std::min(std::max((u - cdf[c]) / width, 0.0), 1.0) : 0.5;
    return c;
}
}  // namespace

void BoundTable::node_mixture(double xi, std::size_t& j0, double& w1) const {
    const Axis& a = axes_[0];
    xi = resolve(a, xi, mode_, name_);
    AxisWeights w;
    axis_weights(a, xi, Interpolation::Linear, w);
    j0 = w.idx[0];
    w1 = w.n > 1 ? w.w[1] : 0.0;
}

double BoundTable::node_pdf(std::size_t j, double mu, double phi) const {
    const std::size_t no = mu_nodes_o_.size(), np = phi_nodes_.size();
    const NodeDist& nd = dists_[j];
    // theta_o cell: nodes are ordered by axis value; mu decreases along a theta axis.
    const bool desc = !layout_.mu_o;
    const double lo = desc ? mu_nodes_o_[no - 1] : mu_nodes_o_[0];
    const double hi = desc ? mu_nodes_o_[0] : mu_nodes_o_[no - 1];
    if (mu < lo || mu > hi) return 0;
    std::size_t k;
    if (desc)
        k = std::size_t(std::upper_bound(mu_nodes_o_.begin(), mu_nodes_o_.end(), mu,
                                         [](double a, double b) { return a > b; }) -
                        mu_nodes_o_.begin());
    else
        k = std::size_t(std::upper_bound(mu_nodes_o_.begin(), mu_nodes_o_.end(), mu) -
                        mu_nodes_o_.begin());
    k = std::min(std::max<std::size_t>(k, 1), no - 1) - 1;
    std::size_t l = std::size_t(std::upper_bound(phi_nodes_.begin(), phi_nodes_.end(), phi) -
                                phi_nodes_.begin());
    l = std::min(std::max<std::size_t>(l, 1), np - 1) - 1;
    const double area = phi_mult_ * std::fabs(mu_nodes_o_[k + 1] - mu_nodes_o_[k]) *
                        (phi_nodes_[l + 1] - phi_nodes_[l]);
    return nd.cell_prob[k * (np - 1) + l] / area;
}

double BoundTable::pdf(const Vec3& wi, const Vec3& wo) const {
    if (!can_sample()) throw Error(sampling_error_);
    double xi, xo, xphi, phi_i;
    direction_coords(layout_, &axes_[2], wi, wo, xi, xo, xphi, phi_i);
    const double mu = layout_.mu_o ? xo : std::cos(xo * layout_.scale_o);
    const double phi = xphi * layout_.scale_phi;
    std::size_t j0;
    double w1;
    node_mixture(xi, j0, w1);
    double p = 0;
    if (w1 < 1) p += (1 - w1) * node_pdf(j0, mu, phi);
    if (w1 > 0) p += w1 * node_pdf(j0 + 1, mu, phi);
    return p;
}

SampleResult BoundTable::sample(const Vec3& wi, double u1, double u2) const {
    if (!can_sample()) throw Error(sampling_error_);
    double xi, xo, xphi, phi_i;
    direction_coords(layout_, &axes_[2], wi, Vec3{0, 0, 1}, xi, xo, xphi, phi_i);
    std::size_t j0;
    double w1;
    node_mixture(xi, j0, w1);
    // Choose the theta_i node with probability equal to its interpolation
    // weight, re-using u1.
    std::size_t j = j0;
    u1 = std::min(std::max(u1, 0.0), 1.0);
    if (w1 > 0 && u1 < w1) {
        j = j0 + 1;
        u1 = u1 / w1;
    } else if (w1 < 1) {
        u1 = (u1 - w1) / (1 - w1);
    }
    const NodeDist& nd = dists_[j];
    const std::size_t co = mu_nodes_o_.size() - 1, cp = phi_nodes_.size() - 1;
    const std::size_t k = pick(nd.cdf_o.data(), co, u1);
    const std::size_t l = pick(nd.cdf_phi.data() + k * (cp + 1), cp, u2);
    double sign = 1;
    if (phi_mult_ == 2) {  // mirror: phi_d and -phi_d equally likely
        if (u2 < 0.5) {
            u2 *= 2;
        } else {
            sign = -1;
            u2 = 2 * u2 - 1;
        }
    }
    // Uniform in (cos theta, phi) inside the cell: constant density in solid angle.
    const double mu = mu_nodes_o_[k] + u1 * (mu_nodes_o_[k + 1] - mu_nodes_o_[k]);
    const double pd = phi_nodes_[l] + u2 * (phi_nodes_[l + 1] - phi_nodes_[l]);
    const double phi_o = phi_i + sign * pd;
    const double st = std::sqrt(std::max(0.0, 1 - mu * mu));
    SampleResult r;
    r.wo = {st * std::cos(phi_o), st * std::sin(phi_o), mu};
    r.pdf = pdf(wi, r.wo);
    r.value = eval(wi, r.wo);
    r.weight = r.pdf > 0 ? r.value * std::fabs(mu) / r.pdf : 0.0;
    return r;
}

}  // namespace brdftab

// test_renderer_luts.cpp — the renderer LUT quantities of rough-dielectric
// (fresnel = none | schlick, split_a / split_b, albedo) and the renderer
// layouts (tables/renderers/, host/io/renderer_layout.h).
// Oracles: limits (E -> 1 as alpha -> 0 with F = 1), identities (Kulla &
// Conty's white furnace with an independent Gauss-Legendre integral over mu;
// A + B = E; Schlick's linearity in F0; eta^2 T_avg(inside) = T_avg(outside)
// from the reciprocity of f_t), a brute-force integral of the closed-form
// f_r with the split-sum weight, and each renderer's node formulas and array
// order as its public source states them (docs/renderer-luts.md).
#include <doctest/doctest.h>

#include "test_sampling.h"
#include "test_support.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "host/core/error.h"
#include "host/engine/engine.h"
#include "host/io/renderer_layout.h"
#include "host/plan/layout_certify.h"
#include "host/spec/spec.h"
#include "kernels/common/gauss_legendre.h"
#include "kernels/models/rough_dielectric.h"

namespace {

using brdftab::test::kPi;

bt_sampler quad_sampler() { return brdftab::test::make_sampler(BT_METHOD_QUADRATURE, 0, 0, 0, 0, 0); }

// Quantity q by quadrature with n nodes at light cosine mu (mu < 0: from inside).
double quad(int q, double mu, double alpha, double eta, int n, const int* o) {
    double p[8] = {std::acos(mu), 0, 0, 0, alpha, eta, double(n), 0};
    bt_sampler s = quad_sampler();
    return rough_dielectric_sample(p, o, q, &s);
}

struct Options {
    int o[RD_OPT_COUNT] = {0, 0, 0, 0, 0, 0, 0, 0};
    Options(int dist, int sh, int fresnel, int lobe = RD_LOBE_BOTH, int side = 0) {
        o[RD_OPT_DISTRIBUTION] = dist;
        o[RD_OPT_SHADOWING] = sh;
        o[RD_OPT_FRESNEL] = fresnel;
        o[RD_OPT_LOBE] = lobe;
        o[RD_OPT_SIDE] = side;
        o[RD_OPT_SAMPLING] = RD_SAMPLING_VISIBLE;
    }
};

const int kDists[] = {BT_MF_GGX, BT_MF_BECKMANN};
const int kShadows[] = {BT_SHADOW_SEPARABLE, BT_SHADOW_HEIGHT_CORRELATED};

}  // namespace

TEST_CASE("F = 1: E -> 1 as alpha -> 0, E in [0, 1], eta is not read")
{
    for (int dist : kDists)
        for (int sh : kShadows) {
            Options op(dist, sh, RD_FRESNEL_NONE);
            for (double mu : {0.05, 0.3, 0.7, 1.0}) {
                double previous_loss = 1;
                for (double alpha : {1e-2, 1e-3, 1e-4, 1e-6}) {
                    const double e = quad(RD_Q_ALBEDO_R, mu, alpha, 1.5, 16, op.o);
                    INFO("dist " << dist << " sh " << sh << " mu " << mu << " alpha " << alpha
                                 << " E " << e);
                    CHECK(e <= 1 + 1e-12);
                    CHECK(1 - e <= previous_loss + 1e-12);  // shrinks with alpha
                    previous_loss = 1 - e;
                    // Nothing transmitted, whatever eta.
                    CHECK(quad(RD_Q_ALBEDO_T, mu, alpha, 1.5, 16, op.o) == 0.0);
                    CHECK(quad(RD_Q_ALBEDO_R, mu, alpha, 3.0, 16, op.o) == e);
                }
                CHECK(previous_loss < 1e-5);  // alpha = 1e-6
            }
        }
}

TEST_CASE("Kulla-Conty white furnace: E(mu) + int f_ms cos = 1 at F = 1")
{
    // f_ms(mu_o, mu_i) = (1 - E(mu_o))(1 - E(mu_i)) / (pi (1 - Eavg)), so
    // int f_ms cos do = (1 - E(mu_i)) * 2 int (1 - E(mu_o)) mu_o dmu_o / (1 - Eavg).
    // The mu_o integral here is an independent composite Gauss-Legendre rule
    // (panels graded towards grazing), Eavg is the model's albedo_avg.
    double gx[24], gw[24];
    bt_gauss_legendre_rule(24, gx, gw);
    const double edges[] = {0, 0.01, 0.04, 0.12, 0.3, 0.6, 1};
    for (int dist : kDists)
        for (int sh : kShadows)
            for (double alpha : {0.1, 0.4, 1.0}) {
                Options op(dist, sh, RD_FRESNEL_NONE, RD_LOBE_REFLECTION);
                double integral = 0;
                for (int k = 0; k + 1 < 7; ++k)
                    for (int j = 0; j < 24; ++j) {
                        const double L = edges[k + 1] - edges[k];
                        const double mu = edges[k] + L * 0.5 * (gx[j] + 1);
                        integral += 0.5 * L * gw[j] * 2 * mu *
                                    (1 - quad(RD_Q_ALBEDO_R, mu, alpha, 1.5, 16, op.o));
                    }
                const double eavg = quad(RD_Q_ALBEDO_AVG, 1, alpha, 1.5, 24, op.o);
                // The graded mu rule against the same independent integral.
                Options graded = op;
                graded.o[RD_OPT_MU_RULE] = RD_MU_RULE_GRADED;
                const double eavg_graded = quad(RD_Q_ALBEDO_AVG, 1, alpha, 1.5, 24, graded.o);
                INFO("Eavg graded " << eavg_graded << " vs 1 - integral " << 1 - integral);
                CHECK(std::fabs(eavg_graded - (1 - integral)) <= 2e-6);
                for (double mu_i : {0.02, 0.5, 1.0}) {
                    const double e = quad(RD_Q_ALBEDO_R, mu_i, alpha, 1.5, 16, op.o);
                    const double furnace = e + (1 - e) * integral / (1 - eavg);
                    INFO("dist " << dist << " sh " << sh << " alpha " << alpha << " mu_i " << mu_i
                                 << ": E " << e << " Eavg " << eavg << " 1 - 2 int E mu "
                                 << integral << " furnace " << furnace);
                    CHECK(std::fabs(furnace - 1) <= 2e-5);
                }
            }
}

TEST_CASE("split sum: A + B = E at F0 = 1; Schlick albedo = F0 A + B")
{
    for (int dist : kDists)
        for (int sh : kShadows)
            for (double mu : {0.02, 0.3, 1.0, -0.5})
                for (double alpha : {0.01, 0.3, 1.0}) {
                    Options none(dist, sh, RD_FRESNEL_NONE), schlick(dist, sh, RD_FRESNEL_SCHLICK);
                    const double a = quad(RD_Q_SPLIT_A, mu, alpha, 1.5, 12, none.o);
                    const double b = quad(RD_Q_SPLIT_B, mu, alpha, 1.5, 12, none.o);
                    const double e = quad(RD_Q_ALBEDO_R, mu, alpha, 1.5, 12, none.o);
                    INFO("dist " << dist << " sh " << sh << " mu " << mu << " alpha " << alpha);
                    CHECK(a >= 0);
                    CHECK(b >= 0);
                    CHECK(std::fabs(a + b - e) <= 1e-12);
                    // The split quantities ignore eta and the fresnel option.
                    CHECK(quad(RD_Q_SPLIT_B, mu, alpha, 3.0, 12, schlick.o) == b);
                    if (mu > 0)
                        for (double eta : {1.2, 1.5, 2.4}) {
                            const double r = (eta - 1) / (eta + 1), f0 = r * r;
                            const double s = quad(RD_Q_ALBEDO_R, mu, alpha, eta, 12, schlick.o);
                            CHECK(std::fabs(s - (f0 * a + b)) <= 1e-12);
                        }
                    // RQMC: A + B = E sample by sample.
                    double p[8] = {std::acos(mu), 0, 0, 0, alpha, 1.5, 12, 0};
                    for (uint k = 0; k < 64; ++k) {
                        bt_sampler s = brdftab::test::make_sampler(BT_METHOD_RQMC, 5, 6, 9, 0, k);
                        const double sa = rough_dielectric_sample(p, none.o, RD_Q_SPLIT_A, &s);
                        const double sb = rough_dielectric_sample(p, none.o, RD_Q_SPLIT_B, &s);
                        const double se = rough_dielectric_sample(p, none.o, RD_Q_ALBEDO_R, &s);
                        CHECK(std::fabs(sa + sb - se) <= 1e-14);
                    }
                }
}

TEST_CASE("split_b against a brute-force integral of the closed-form f_r")
{
    // int f_r(i, o) (1 - o.h)^5 cos(theta_o) do with F = 1, f_r the model's
    // closed form (eq. 20), on a 2-D Gauss-Legendre product rule in
    // (cos theta_o, phi_o) with 40 panels x 16 nodes each way.
    double gx[16], gw[16];
    bt_gauss_legendre_rule(16, gx, gw);
    for (int sh : kShadows)
        for (double alpha : {0.3, 0.7})
            for (double mu : {0.4, 0.9}) {
                Options op(BT_MF_GGX, sh, RD_FRESNEL_NONE);
                const double ti = std::acos(mu);
                bt_vec3 i = bt_v3(std::sin(ti), 0, mu);
                double sum_b = 0, sum_e = 0;
                const int panels = 40;
                for (int pc = 0; pc < panels; ++pc)
                    for (int jc = 0; jc < 16; ++jc) {
                        const double c = (pc + 0.5 * (gx[jc] + 1)) / panels;
                        const double wc = 0.5 * gw[jc] / panels;
                        for (int pp = 0; pp < panels; ++pp)
                            for (int jp = 0; jp < 16; ++jp) {
                                const double phi = kPi * (pp + 0.5 * (gx[jp] + 1)) / panels;
                                const double wp = 2 * kPi * 0.5 * gw[jp] / panels;  // phi in [0, pi], x2 by symmetry
                                const double s = std::sqrt(1 - c * c);
                                double p[8] = {ti, 0, std::acos(c), phi, alpha, 1.5, 12, 0};
                                const double f = rough_dielectric_fr(p, op.o);
                                bt_vec3 o = bt_v3(s * std::cos(phi), s * std::sin(phi), c);
                                bt_vec3 h = bt_v3_normalize(bt_v3_add(i, o));
                                const double k = 1 - bt_v3_dot(o, h), k5 = k * k * k * k * k;
                                sum_b += wc * wp * f * c * k5;
                                sum_e += wc * wp * f * c;
                            }
                    }
                const double b = quad(RD_Q_SPLIT_B, mu, alpha, 1.5, 16, op.o);
                const double e = quad(RD_Q_ALBEDO_R, mu, alpha, 1.5, 16, op.o);
                INFO("sh " << sh << " alpha " << alpha << " mu " << mu << ": B " << b << " vs "
                           << sum_b << ", E " << e << " vs " << sum_e);
                CHECK(std::fabs(b - sum_b) <= 1e-5);
                CHECK(std::fabs(e - sum_e) <= 1e-5);
            }
}

// Adaptive Gauss-Kronrod (7/15 points, bisection until |K15 - G7| <= tol)
// for the oracle below: no splits, no change of variable, no knowledge of
// where the integrand has kinks.
namespace gk {
const double xk[8] = {0.991455371120812639, 0.949107912342758525, 0.864864423359769073, 0.741531185599394440,
                      0.586087235467691130, 0.405845151377397167, 0.207784955007898468, 0.0};
const double wk[8] = {0.022935322010529225, 0.063092092629978553, 0.104790010322250184, 0.140653259715525919,
                      0.169004726639267903, 0.190350578064785410, 0.204432940075298892, 0.209482141084727828};
const double wg[4] = {0.129484966168869693, 0.279705391489276668, 0.381830050505118945, 0.417959183673469388};
template <class Fn> double gk15(Fn&& f, double a, double b, double* err) {
    const double c = 0.5 * (a + b), h = 0.5 * (b - a);
    const double fc = f(c);
    double k = wk[7] * fc, g = wg[3] * fc;
    for (int j = 0; j < 7; ++j) {
        const double s = f(c - h * xk[j]) + f(c + h * xk[j]);
        k += wk[j] * s;
        if (j % 2 == 1) g += wg[j / 2] * s;
    }
    *err = std::fabs((k - g) * h);
    return k * h;
}
template <class Fn> double adaptive(Fn&& f, double a, double b, double tol, int depth = 0) {
    double err;
    const double v = gk15(f, a, b, &err);
    if (err <= tol || depth >= 40) return v;
    const double m = 0.5 * (a + b);
    return adaptive(f, a, m, 0.5 * tol, depth + 1) + adaptive(f, m, b, 0.5 * tol, depth + 1);
}
}  // namespace gk

TEST_CASE("tir_rule = sqrt: light from inside just below the critical cosine, against an adaptive integral")
{
    // IOR 1.05, alpha 0.05 (GGX, height-correlated), light from inside at
    // mu = 0.30, just below mu_c = sqrt(1 - 1/1.05^2) = 0.3049: most facets
    // reflect totally, and on every row the refracted-horizon level sits
    // within ~1e-5 of the TIR level.  Oracle: the albedo as an integral over
    // microfacet normals, A = int D(m) |i.m|/|i.n| (F G(i,o_r,m) + (1 - F)
    // G(i,o_t,m)) dw_m (f cos dw_o with the Jacobians of eqs. 14 and 17), in
    // plain spherical coordinates (theta_m, phi) about the macro normal, each
    // direction by adaptive Gauss-Kronrod; D, G, F from the closed forms.
    const double mu = 0.30, alpha = 0.05, ior = 1.05, eta = 1 / ior;
    bt_microfacet mf = bt_microfacet_make(BT_MF_GGX, 0, BT_SHADOW_HEIGHT_CORRELATED, alpha, alpha);
    const bt_vec3 i = bt_v3(std::sqrt(1 - mu * mu), 0, mu);
    auto row = [&](double th) {
        const double st = std::sin(th), ct = std::cos(th);
        auto integrand = [&](double phi) {
            const bt_vec3 m = bt_v3(st * std::cos(phi), st * std::sin(phi), ct);
            const double im = bt_v3_dot(i, m);
            if (!(im > 0)) return 0.0;
            const double F = bt_fresnel_dielectric(im, eta);
            double w = 0;
            const bt_vec3 o_r = bt_reflect(i, m);
            if (o_r.z > 0) w += F * bt_mf_g(&mf, i, o_r, m);
            bt_vec3 o_t;
            if (F < 1 && bt_refract(i, m, eta, &o_t) && o_t.z < 0) w += (1 - F) * bt_mf_g(&mf, i, o_t, m);
            return bt_mf_d(&mf, m) * im / mu * w * st;
        };
        return 2 * gk::adaptive(integrand, 0.0, kPi, 1e-9);  // phi in [0, pi], even
    };
    double oracle = 0;
    const double cuts[] = {0, alpha, 4 * alpha, 16 * alpha, kPi / 2};  // D's width, for speed only
    for (int k = 0; k < 4; ++k) oracle += gk::adaptive(row, cuts[k], cuts[k + 1], 1e-8);
    // Tightening both tolerances 1000-fold moves the oracle by 4e-9.
    Options op(BT_MF_GGX, BT_SHADOW_HEIGHT_CORRELATED, RD_FRESNEL_DIELECTRIC);
    const double split = quad(RD_Q_ALBEDO, -mu, alpha, ior, 16, op.o);
    op.o[RD_OPT_TIR_RULE] = RD_TIR_RULE_SQRT;
    const double sqrt_rule = quad(RD_Q_ALBEDO, -mu, alpha, ior, 16, op.o);
    const double sqrt_coarse = quad(RD_Q_ALBEDO, -mu, alpha, ior, 8, op.o);
    INFO("oracle " << oracle << ", split " << split << ", sqrt " << sqrt_rule << ", sqrt at 8 nodes "
                   << sqrt_coarse);
    CHECK(std::fabs(split - oracle) > 1e-6);       // the split rule misses 1e-6 here (1.8e-5)
    CHECK(std::fabs(sqrt_rule - oracle) <= 1e-7);  // the sqrt rule meets it
    CHECK(std::fabs(sqrt_coarse - sqrt_rule) <= 1e-6);  // and so does its error estimate
}

TEST_CASE("g1 = schlick: Karis' G1 closed form, and the split sum against a brute-force integral")
{
    // G1(v) = n.v / (n.v (1 - k) + k), k = alpha/2 (Karis 2013, image lighting).
    for (double alpha : {0.04, 0.25, 1.0})
        for (double mu : {0.05, 0.5, 1.0}) {
            bt_microfacet mf = bt_microfacet_make(BT_MF_GGX, BT_G1_SCHLICK, BT_SHADOW_SEPARABLE, alpha, alpha);
            const bt_vec3 v = bt_v3(std::sqrt(1 - mu * mu), 0, mu);
            const double k = alpha / 2;
            CHECK(bt_mf_g1_nochi(&mf, v) == doctest::Approx(mu / (mu * (1 - k) + k)).epsilon(1e-14));
            const bt_vec3 o = bt_v3(-0.6, 0, 0.8);
            const bt_vec3 m = bt_v3_normalize(bt_v3_add(v, o));
            const double g = mu / (mu * (1 - k) + k) * 0.8 / (0.8 * (1 - k) + k);
            CHECK(bt_mf_g(&mf, v, o, m) == doctest::Approx(g).epsilon(1e-14));
        }
    // split_a, split_b with G = G1(i) G1(o) (Schlick's G1, separable) by the
    // model's quadrature, against int f_r (1 - (1 - o.h)^5 or (1 - o.h)^5) cos
    // do with f_r the closed form (eq. 20) on a 40 x 40-panel Gauss-Legendre
    // product rule in (cos theta_o, phi_o) as above.
    double gx[16], gw[16];
    bt_gauss_legendre_rule(16, gx, gw);
    for (double alpha : {0.3, 0.7})
        for (double mu : {0.4, 0.9}) {
            Options op(BT_MF_GGX, BT_SHADOW_SEPARABLE, RD_FRESNEL_NONE);
            op.o[RD_OPT_G1] = BT_G1_SCHLICK;
            const double ti = std::acos(mu);
            bt_vec3 i = bt_v3(std::sin(ti), 0, mu);
            double sum_a = 0, sum_b = 0;
            const int panels = 40;
            for (int pc = 0; pc < panels; ++pc)
                for (int jc = 0; jc < 16; ++jc) {
                    const double c = (pc + 0.5 * (gx[jc] + 1)) / panels;
                    const double wc = 0.5 * gw[jc] / panels;
                    for (int pp = 0; pp < panels; ++pp)
                        for (int jp = 0; jp < 16; ++jp) {
                            const double phi = kPi * (pp + 0.5 * (gx[jp] + 1)) / panels;
                            const double wp = 2 * kPi * 0.5 * gw[jp] / panels;
                            const double s = std::sqrt(1 - c * c);
                            double p[8] = {ti, 0, std::acos(c), phi, alpha, 1.5, 12, 0};
                            const double f = rough_dielectric_fr(p, op.o);
                            bt_vec3 o = bt_v3(s * std::cos(phi), s * std::sin(phi), c);
                            bt_vec3 h = bt_v3_normalize(bt_v3_add(i, o));
                            const double kk = 1 - bt_v3_dot(o, h), k5 = kk * kk * kk * kk * kk;
                            sum_a += wc * wp * f * c * (1 - k5);
                            sum_b += wc * wp * f * c * k5;
                        }
                }
            const double a = quad(RD_Q_SPLIT_A, mu, alpha, 1.5, 16, op.o);
            const double b = quad(RD_Q_SPLIT_B, mu, alpha, 1.5, 16, op.o);
            INFO("alpha " << alpha << " mu " << mu << ": A " << a << " vs " << sum_a << ", B " << b
                          << " vs " << sum_b);
            CHECK(std::fabs(a - sum_a) <= 1e-5);
            CHECK(std::fabs(b - sum_b) <= 1e-5);
            // and it is not the exact Smith G1's result
            Options smith(BT_MF_GGX, BT_SHADOW_SEPARABLE, RD_FRESNEL_NONE);
            CHECK(std::fabs(quad(RD_Q_SPLIT_A, mu, alpha, 1.5, 16, smith.o) - a) > 1e-3);
        }
}

TEST_CASE("reciprocity of the averages: eta^2 T_avg(inside) = T_avg(outside)")
{
    // From f_t(i, o) / eta_o^2 = f_t(o, i) / eta_i^2 (Walter eq. 21),
    // integrated over both hemispheres with cos_i cos_o.
    for (int dist : kDists)
        for (int sh : kShadows)
            for (double eta : {1.2, 1.5, 2.4})
                for (double alpha : {0.1, 0.5}) {
                    Options out(dist, sh, RD_FRESNEL_DIELECTRIC, RD_LOBE_TRANSMISSION, 0);
                    Options in(dist, sh, RD_FRESNEL_DIELECTRIC, RD_LOBE_TRANSMISSION, 1);
                    const double t_out = quad(RD_Q_ALBEDO_AVG, 1, alpha, eta, 16, out.o);
                    const double t_in = quad(RD_Q_ALBEDO_AVG, 1, alpha, eta, 16, in.o);
                    INFO("dist " << dist << " sh " << sh << " eta " << eta << " alpha " << alpha
                                 << ": T_out " << t_out << " eta^2 T_in " << eta * eta * t_in);
                    CHECK(std::fabs(t_out - eta * eta * t_in) <= 2e-4 * t_out);
                }
}

TEST_CASE("Schlick: F0 at normal incidence, 1 at grazing, total internal reflection from inside")
{
    for (double eta : {1.33, 1.5, 2.4}) {
        const double r = (eta - 1) / (eta + 1);
        CHECK(rd_fresnel(RD_FRESNEL_SCHLICK, 1.0, eta) == doctest::Approx(r * r).epsilon(1e-15));
        CHECK(rd_fresnel(RD_FRESNEL_SCHLICK, 0.0, eta) == doctest::Approx(1.0));
        // Light inside (canonical index 1/eta): total internal reflection
        // below the critical cosine, Schlick at the refracted cosine above.
        const double ci = std::sqrt(1 - 1 / (eta * eta));
        CHECK(rd_fresnel(RD_FRESNEL_SCHLICK, 0.9 * ci, 1 / eta) == 1.0);
        const double c = 0.5 * (1 + ci), ct = std::sqrt(1 - eta * eta * (1 - c * c));
        CHECK(rd_fresnel(RD_FRESNEL_SCHLICK, c, 1 / eta) ==
              doctest::Approx(rd_fresnel(RD_FRESNEL_SCHLICK, ct, eta)).epsilon(1e-12));
    }
}

// ------------------------------------------------------------------ layouts

namespace {

double clamp(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }

const brdftab::TableSpec& table_of(const brdftab::Spec& s, const std::string& name) {
    for (const auto& t : s.tables)
        if (t.name == name) return t;
    FAIL("no table " << name);
    return s.tables.front();
}

// The axis values, checked against the formula f(k) for k = 0 .. n - 1.
template <class F>
void check_nodes(const brdftab::Axis& a, std::size_t n, F f) {
    REQUIRE(a.count == n);
    for (std::size_t k = 0; k < n; ++k) {
        INFO("axis " << a.name << " node " << k);
        CHECK(a.values[k] == doctest::Approx(f(double(k) / double(n - 1))).epsilon(1e-14));
    }
}

}  // namespace

TEST_CASE("Cycles preset: node placement is Cycles' formula, axes in Cycles' array order")
{
    // cycles_precompute.cpp: roughness r = clamp(x/(nx-1), 1e-4, 1) with
    // alpha = r^2, mu = clamp(y/(ny-1), 1e-4, 1), IOR = (1 + z^2)/(1 - z^2)
    // (ior_from_F0(z^4)) with z = clamp(z/(nz-1), 1e-4, 0.99); index
    // z nx ny + y nx + x: axes (IOR, mu, roughness) outermost first.
    const brdftab::Spec s =
        brdftab::parse_spec_file(std::string(BT_SOURCE_DIR) + "/tables/renderers/cycles.toml");
    auto alpha = [](double t) { return std::pow(clamp(t, 1e-4, 1), 2); };
    auto mu = [](double t) { return clamp(t, 1e-4, 1); };
    auto ior = [](double t) {
        const double z = clamp(t, 1e-4, 0.99);
        return (1 + z * z) / (1 - z * z);
    };
    auto theta_inside = [&](double t) { return 180 - std::acos(mu(t)) * 180 / kPi; };
    const auto& e = table_of(s, "ggx_E");
    REQUIRE(e.axes.size() == 2);
    CHECK(e.axes[0].name == "mu_i");
    check_nodes(e.axes[0], 32, mu);
    check_nodes(e.axes[1], 32, alpha);
    CHECK(e.options["fresnel"] == "none");
    check_nodes(table_of(s, "ggx_Eavg").axes.at(0), 32, alpha);
    for (const char* name : {"ggx_glass_E", "ggx_glass_inv_E"}) {
        const auto& g = table_of(s, name);
        REQUIRE(g.axes.size() == 3);
        CHECK(g.axes[0].name == "eta");
        check_nodes(g.axes[0], 16, ior);
        if (std::string(name) == "ggx_glass_E") {
            CHECK(g.axes[1].name == "mu_i");
            check_nodes(g.axes[1], 16, mu);
        } else {
            CHECK(g.axes[1].name == "theta_i");  // light from inside
            check_nodes(g.axes[1], 16, theta_inside);
        }
        check_nodes(g.axes[2], 16, alpha);
        CHECK(g.quantity == "albedo");
        CHECK(g.options["fresnel"] == "dielectric");
        CHECK(g.options["shadowing"] == "height-correlated");
    }
    for (const char* name : {"ggx_glass_Eavg", "ggx_glass_inv_Eavg"}) {
        const auto& g = table_of(s, name);
        REQUIRE(g.axes.size() == 2);
        check_nodes(g.axes[0], 16, ior);
        check_nodes(g.axes[1], 16, alpha);
        CHECK(g.options["side"] == (std::string(name) == "ggx_glass_Eavg" ? "outside" : "inside"));
    }
}

TEST_CASE("Filament preset: texel placement as cmgen and CubemapIBL::DFG define it")
{
    // Column x: NoV = (x + 0.5)/128.  Image row y: c = saturate((128 - y + 0.5)/128),
    // alpha = c^2; GL row j is image row 127 - j, so c_j = min(1, (j + 1.5)/128).
    const brdftab::Spec s =
        brdftab::parse_spec_file(std::string(BT_SOURCE_DIR) + "/tables/renderers/filament-dfg.toml");
    for (const char* name : {"dfg_x", "dfg_y"}) {
        const auto& t = table_of(s, name);
        REQUIRE(t.axes.size() == 2);
        CHECK(t.axes[0].name == "alpha");
        CHECK(t.axes[1].name == "mu_i");
        REQUIRE(t.axes[0].count == 128);
        REQUIRE(t.axes[1].count == 128);
        for (std::size_t k = 0; k < 128; ++k) {
            const double y = 127.0 - double(k);
            const double c = std::min(1.0, (128.0 - y + 0.5) / 128.0);
            CHECK(t.axes[0].values[k] == doctest::Approx(c * c).epsilon(1e-14));
            CHECK(t.axes[1].values[k] == doctest::Approx((double(k) + 0.5) / 128.0).epsilon(1e-14));
        }
        CHECK(t.options["shadowing"] == "height-correlated");
        CHECK(t.options["distribution"] == "ggx");
    }
    CHECK(table_of(s, "dfg_x").quantity == "split_b");
    CHECK(table_of(s, "dfg_y").quantity == "albedo_r");
    CHECK(table_of(s, "dfg_y").options["fresnel"] == "none");
    CHECK(table_of(s, "dfg_z").quantity == "sheen_albedo");  // the cloth channel, same texels
    CHECK(table_of(s, "dfg_z").axes[0].values == table_of(s, "dfg_x").axes[0].values);
    CHECK(table_of(s, "dfg_z").axes[1].values == table_of(s, "dfg_x").axes[1].values);
}

TEST_CASE("UE4 preset: texel centres in (NoV, roughness), alpha = roughness^2, UE4's visibility")
{
    // UE4's PreintegratedGF (SystemTextures.cpp): 128 x 32, columns NoV = (x + 0.5)/128,
    // rows roughness = (y + 0.5)/32, alpha = roughness^2; GGX with
    // Vis_SmithJointApprox, i.e. Schlick's G1 (k = alpha/2) combined height-correlated.
    const brdftab::Spec s =
        brdftab::parse_spec_file(std::string(BT_SOURCE_DIR) + "/tables/renderers/ue4-splitsum.toml");
    for (const char* name : {"ue4_a", "ue4_b"}) {
        const auto& t = table_of(s, name);
        REQUIRE(t.axes.size() == 2);
        CHECK(t.axes[0].name == "alpha");
        CHECK(t.axes[1].name == "mu_i");
        REQUIRE(t.axes[0].count == 32);
        REQUIRE(t.axes[1].count == 128);
        for (std::size_t k = 0; k < 32; ++k) {
            const double c = (double(k) + 0.5) / 32.0;
            CHECK(t.axes[0].values[k] == doctest::Approx(c * c).epsilon(1e-14));
        }
        for (std::size_t k = 0; k < 128; ++k)
            CHECK(t.axes[1].values[k] == doctest::Approx((double(k) + 0.5) / 128.0).epsilon(1e-14));
        CHECK(t.options["distribution"] == "ggx");
        CHECK(t.options["g1"] == "schlick");
        CHECK(t.options["shadowing"] == "height-correlated");
    }
    // The model's f_r with these options is UE4's D Vis: Vis = 0.5 / (n.l (n.v (1 - a)
    // + a) + n.v (n.l (1 - a) + a)), written out here from the engine's formula.
    Options op(BT_MF_GGX, BT_SHADOW_HEIGHT_CORRELATED, RD_FRESNEL_NONE);
    op.o[RD_OPT_G1] = BT_G1_SCHLICK;
    for (double a : {0.05, 0.3, 0.9})
        for (double ti : {10.0, 50.0, 80.0})
            for (double to : {5.0, 40.0, 85.0}) {
                const double d2r = kPi / 180, nv = std::cos(ti * d2r), nl = std::cos(to * d2r);
                double p[8] = {ti * d2r, 0, to * d2r, 2.0, a, 1.5, 16, 0};
                bt_sampler sm = quad_sampler();
                const double fr = rough_dielectric_sample(p, op.o, RD_Q_BRDF, &sm);
                // h and D_GGX(h)
                const double hx = std::sin(ti * d2r) + std::sin(to * d2r) * std::cos(2.0),
                             hy = std::sin(to * d2r) * std::sin(2.0), hz = nv + nl;
                const double nh = hz / std::sqrt(hx * hx + hy * hy + hz * hz);
                const double a2 = a * a, dd = nh * nh * (a2 - 1) + 1, D = a2 / (kPi * dd * dd);
                const double vis = 0.5 / (nl * (nv * (1 - a) + a) + nv * (nl * (1 - a) + a));
                INFO("alpha " << a << " theta_i " << ti << " theta_o " << to);
                CHECK(fr == doctest::Approx(D * vis).epsilon(1e-12));
            }
    CHECK(table_of(s, "ue4_a").quantity == "split_a");
    CHECK(table_of(s, "ue4_b").quantity == "split_b");
}

TEST_CASE("renderer layouts: element order and the tables each layout accepts")
{
    using namespace brdftab;
    auto table = [](std::vector<std::pair<std::string, std::size_t>> axes, double offset) {
        TableData t;
        t.name = "t";
        std::size_t cells = 1;
        for (const auto& [name, n] : axes) {
            std::vector<double> v;
            for (std::size_t k = 0; k < n; ++k) v.push_back(0.1 + double(k));
            t.axes.push_back(make_axis(name, "1", 0, 1, n, Spacing::Explicit, v));
            cells *= n;
        }
        for (std::size_t k = 0; k < cells; ++k) t.value.push_back(offset + double(k));
        return t;
    };
    RendererExportOptions cycles;
    cycles.layout = RendererLayout::Cycles;
    // (IOR 2, mu 3, alpha 4): Cycles' index z*12 + y*4 + x is the row-major index.
    const TableData g = table({{"eta", 2}, {"mu_i", 3}, {"alpha", 4}}, 0);
    const auto v = renderer_layout_values({g}, cycles);
    REQUIRE(v.size() == 24);
    for (std::size_t z = 0; z < 2; ++z)
        for (std::size_t y = 0; y < 3; ++y)
            for (std::size_t x = 0; x < 4; ++x) CHECK(v[z * 12 + y * 4 + x] == g.value[z * 12 + y * 4 + x]);
    CHECK_THROWS_AS(renderer_layout_values({table({{"alpha", 4}, {"mu_i", 3}}, 0)}, cycles), InputError);
    CHECK_THROWS_AS(renderer_layout_values({g, g}, cycles), InputError);
    // Two-channel textures: R, G interleaved per texel, NoV fastest.
    RendererExportOptions fil;
    fil.layout = RendererLayout::Filament;
    const TableData r = table({{"alpha", 3}, {"mu_i", 5}}, 0), gch = table({{"alpha", 3}, {"mu_i", 5}}, 100);
    const auto tex = renderer_layout_values({r, gch}, fil);
    REQUIRE(tex.size() == 30);
    for (std::size_t k = 0; k < 15; ++k) {
        CHECK(tex[2 * k] == r.value[k]);
        CHECK(tex[2 * k + 1] == gch.value[k]);
    }
    CHECK_THROWS_AS(renderer_layout_values({r}, fil), InputError);
    CHECK_THROWS_AS(renderer_layout_values({r, table({{"mu_i", 5}, {"alpha", 3}}, 0)}, fil), InputError);
    // Filament's texture is binary16 or float, never 16-bit unorm (UE4's type).
    fil.type = HeaderValueType::Uint16;
    fil.type_given = true;
    CHECK_THROWS_AS(export_renderer_header({r, gch}, "unused.h", fil), InputError);
}

TEST_CASE("ue4 layout storage: 16-bit unorm, q = round(65535 clamp(v, 0, 1))")
{
    // UE4 writes PreintegratedGF as (int32)(clamp(v, 0, 1) * 65535 + 0.5) per channel
    // (SystemTextures.cpp, PF_G16R16): nearest, ties upwards, clamped.
    using brdftab::renderer_unorm16;
    CHECK(renderer_unorm16(0.0) == 0u);
    CHECK(renderer_unorm16(1.0) == 65535u);
    CHECK(renderer_unorm16(-0.25) == 0u);
    CHECK(renderer_unorm16(1.75) == 65535u);
    CHECK(renderer_unorm16(0.5) == 32768u);  // 32767.5: the tie goes up
    CHECK(renderer_unorm16(1000.49 / 65535) == 1000u);
    CHECK(renderer_unorm16(1000.51 / 65535) == 1001u);
    CHECK(renderer_unorm16(1.0 / 65535) == 1u);
    // Every value in [0, 1] reads back within half a quantum.
    for (int k = 0; k <= 1000; ++k) {
        const double v = std::pow(double(k) / 1000, 3);
        CHECK(std::fabs(renderer_unorm16(v) / 65535.0 - v) <= 0.5 / 65535 + 1e-15);
    }
}

// ---------------------------------------------------------------- sheen (cloth)

namespace {

// Estevez & Kulla's Charlie D and Neubelt's V, written out here (not the kernel's).
double charlie_d(double nh, double alpha) {
    const double s2 = std::max(1 - nh * nh, 0.0);
    return (2 + 1 / alpha) * std::pow(s2, 0.5 / alpha) / (2 * kPi);
}

// int D V n.l dl over the l hemisphere, midpoint rule on (n.l, phi_l) with
// n x 2n cells (phi over [0, pi], doubled by symmetry).
double sheen_brute(double nv, double alpha, int n) {
    const double sv = std::sqrt(1 - nv * nv);
    double sum = 0;
    for (int a = 0; a < n; ++a) {
        const double cl = (a + 0.5) / n, sl = std::sqrt(1 - cl * cl);
        for (int b = 0; b < 2 * n; ++b) {
            const double phi = kPi * (b + 0.5) / (2 * n);
            const double hx = sv + sl * std::cos(phi), hy = sl * std::sin(phi), hz = nv + cl;
            const double nh = hz / std::sqrt(hx * hx + hy * hy + hz * hz);
            const double vis = 1 / (4 * (cl + nv - cl * nv));
            sum += charlie_d(nh, alpha) * vis * cl;
        }
    }
    return 2 * sum * (1.0 / n) * (kPi / (2 * n));  // dl = d(n.l) dphi
}

double sheen_quad(double nv, double alpha, int n) {
    const Options op(BT_MF_GGX, BT_SHADOW_HEIGHT_CORRELATED, RD_FRESNEL_DIELECTRIC);
    return quad(RD_Q_SHEEN_ALBEDO, nv, alpha, 1.5, n, op.o);
}

}  // namespace

TEST_CASE("sheen_albedo: closed form at normal view, E = 2^(-k/2) / (k + 4), k = 1/alpha")
{
    // At v = n, h = l's half-vector with theta_h = theta_l / 2: E = (2 + k)
    // int_0^(1/sqrt 2) s^(k+1) (1 - 2 s^2) ds = 2^(-k/2) / (k + 4).
    for (double alpha : {1.0, 0.7, 0.5, 0.25, 0.1, 0.02}) {
        const double k = 1 / alpha, exact = std::pow(2.0, -k / 2) / (k + 4);
        INFO("alpha " << alpha << ": quadrature " << sheen_quad(1.0, alpha, 16) << ", closed form " << exact);
        CHECK(std::fabs(sheen_quad(1.0, alpha, 16) - exact) <= 1e-10);
    }
}

TEST_CASE("sheen_albedo: against a brute-force integral over outgoing directions")
{
    for (double alpha : {1.0, 0.3, 0.1})
        for (double nv : {0.2, 0.6, 0.9}) {
            const double b1 = sheen_brute(nv, alpha, 400), b2 = sheen_brute(nv, alpha, 800);
            const double q = sheen_quad(nv, alpha, 16);
            INFO("alpha " << alpha << " n.v " << nv << ": quadrature " << q << ", midpoint " << b1 << " / " << b2);
            // the midpoint rule's error at 800 is bounded by its change from 400
            CHECK(std::fabs(q - b2) <= 2 * std::fabs(b2 - b1) + 1e-9);
            CHECK(std::fabs(b2 - b1) <= 1e-4 * b2);  // the brute force itself is converged
        }
}

TEST_CASE("sheen_albedo: RQMC (Filament's uniform-h estimator) agrees with the quadrature")
{
    const Options op(BT_MF_GGX, BT_SHADOW_HEIGHT_CORRELATED, RD_FRESNEL_DIELECTRIC);
    for (double alpha : {0.8, 0.05})
        for (double nv : {0.05, 0.5}) {
            double p[8] = {std::acos(nv), 0, 0, 0, alpha, 1.5, 16, 0};
            brdftab::test::RunningStat st;
            for (uint b = 0; b < 16; ++b) {
                double sum = 0;
                for (uint k = 0; k < (1u << 14); ++k) {
                    bt_sampler r = brdftab::test::make_sampler(BT_METHOD_RQMC, 3, 4, 0, b, k);
                    sum += rough_dielectric_sample(p, op.o, RD_Q_SHEEN_ALBEDO, &r);
                }
                st.add(sum / (1u << 14));
            }
            const double q = sheen_quad(nv, alpha, 16);
            INFO("alpha " << alpha << " n.v " << nv << ": quadrature " << q << ", RQMC " << st.mean << " +- " << st.se());
            CHECK(std::fabs(q - st.mean) <= 4 * st.se() + 1e-9);
        }
}

// ---------------------------------------------------------------- layout certificates

namespace {

// A 2-D table (alpha outer, mu_i inner) of rough-dielectric albedo_r with
// F = 1 at the given nodes, computed here by the host quadrature.
brdftab::TableData e_table(const std::vector<double>& alphas, const std::vector<double>& mus, int nodes) {
    brdftab::TableData t;
    t.name = "e";
    t.model = "rough-dielectric";
    t.quantity = "albedo_r";
    t.parameters = {{"distribution", "ggx"}, {"shadowing", "height-correlated"}, {"fresnel", "none"},
                    {"eta", 1.5}, {"nodes", double(nodes)}};
    brdftab::Axis a, m;
    a.name = "alpha";
    a.values = alphas;
    a.count = alphas.size();
    a.spacing = brdftab::Spacing::Explicit;
    m.name = "mu_i";
    m.values = mus;
    m.count = mus.size();
    m.spacing = brdftab::Spacing::Explicit;
    t.axes = {a, m};
    const Options op(BT_MF_GGX, BT_SHADOW_HEIGHT_CORRELATED, RD_FRESNEL_NONE);
    for (double al : alphas)
        for (double mu : mus) t.value.push_back(quad(RD_Q_ALBEDO_R, mu, al, 1.5, nodes, op.o));
    return t;
}

}  // namespace

TEST_CASE("layout certificate: Cycles' bilinear read at cell centres, Filament's texel offset at the nodes")
{
    auto backend = brdftab::make_backend("host", brdftab::Precision::Double);
    const Options op(BT_MF_GGX, BT_SHADOW_HEIGHT_CORRELATED, RD_FRESNEL_NONE);
    SUBCASE("cycles: node k of n at k/(n-1), roughness r = sqrt(alpha)") {
        const int n = 5;
        std::vector<double> alphas, mus;
        for (int k = 0; k < n; ++k) {
            const double t = std::max(double(k) / (n - 1), 1e-4);
            alphas.push_back(t * t);
            mus.push_back(t);
        }
        const brdftab::TableData t = e_table(alphas, mus, 12);
        const brdftab::LayoutCertificate c = brdftab::certify_layout(t, brdftab::RendererLayout::Cycles, *backend);
        // The oracle: at each cell centre (r, mu) = ((i + 1/2)/(n-1), (j + 1/2)/(n-1)) the
        // bilinear read is the mean of the cell's corners.
        double worst = 0, worst_alpha = 0, worst_mu = 0, sum2 = 0;
        for (int i = 0; i + 1 < n; ++i)
            for (int j = 0; j + 1 < n; ++j) {
                const double r = (i + 0.5) / (n - 1), mu = (j + 0.5) / (n - 1);
                const double mean = 0.25 * (t.value[i * n + j] + t.value[i * n + j + 1] + t.value[(i + 1) * n + j] +
                                            t.value[(i + 1) * n + j + 1]);
                const double e = std::fabs(mean - quad(RD_Q_ALBEDO_R, mu, r * r, 1.5, 12, op.o));
                sum2 += e * e;
                if (e > worst) {
                    worst = e;
                    worst_alpha = r * r;
                    worst_mu = mu;
                }
            }
        CHECK(c.cell_probes == std::size_t((n - 1) * (n - 1)));
        CHECK(c.node_probes == 0);  // every node was computed where Cycles reads it
        CHECK(c.max_error == doctest::Approx(worst).epsilon(1e-9));
        CHECK(c.rms_error == doctest::Approx(std::sqrt(sum2 / ((n - 1) * (n - 1)))).epsilon(1e-9));
        CHECK(c.max_at.at("alpha") == doctest::Approx(worst_alpha));
        CHECK(c.max_at.at("mu_i") == doctest::Approx(worst_mu));
        CHECK(worst > 1e-3);  // a 5 x 5 grid is coarse: the certificate sees it
    }
    SUBCASE("filament: texel k of n at (k + 1/2)/n, rows computed one texel up") {
        const int n = 6;
        std::vector<double> alphas, mus;
        for (int k = 0; k < n; ++k) {
            const double c = std::min(1.0, (k + 1.5) / n);  // cmgen's row coordinate
            alphas.push_back(c * c);
            mus.push_back((k + 0.5) / n);
        }
        const brdftab::TableData t = e_table(alphas, mus, 12);
        const brdftab::LayoutCertificate c = brdftab::certify_layout(t, brdftab::RendererLayout::Filament, *backend);
        CHECK(c.node_probes == std::size_t(n * n));
        // At texel (row k, column j) the shader reads the stored value at
        // perceptual roughness (k + 1/2)/n: its error is the offset's.
        double node_worst = 0;
        for (int k = 0; k < n; ++k)
            for (int j = 0; j < n; ++j) {
                const double u = (k + 0.5) / n;
                node_worst = std::max(node_worst, std::fabs(t.value[k * n + j] -
                                                            quad(RD_Q_ALBEDO_R, mus[j], u * u, 1.5, 12, op.o)));
            }
        CHECK(c.node_max == doctest::Approx(node_worst).epsilon(1e-9));
        CHECK(node_worst > 1e-3);
    }
    SUBCASE("an axis the layout does not know is refused") {
        brdftab::TableData t = e_table({0.1, 0.2}, {0.5, 0.6}, 8);
        t.axes[1].name = "theta_o";
        CHECK_THROWS_AS(brdftab::certify_layout(t, brdftab::RendererLayout::Ue4, *backend), brdftab::InputError);
    }
}

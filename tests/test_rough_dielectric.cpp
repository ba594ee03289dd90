// test_rough_dielectric.cpp — kernels/models/rough_dielectric.h compiled as
// C++ (the same source the OpenCL kernel uses).  Oracles: reciprocity
// identities, energy conservation, the smooth-interface limit (Fresnel from
// the independent s/p formula), a closed form (GGX alpha = 1: 1 - ln 2), the
// no-interface limit (eta = 1), the internal/external hemispherical
// reflectance identity, and brute-force quadrature of f cos over the sphere
// against the importance-sampled albedo estimator.
#include <doctest/doctest.h>

#include "test_sampling.h"
#include "test_support.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "kernels/models/rough_dielectric.h"

namespace {

using Stat = brdftab::test::RunningStat;

bt_sampler mc(uint cell, uint sample) { return brdftab::test::mc_sampler(0xC0FFEEu, 0x5EEDu, cell, sample); }

using brdftab::test::kPi;
using brdftab::test::kDeg;

using brdftab::test::fresnel_sp;

// Mean of quantity q over n MC samples.
Stat estimate(const double* p, const int* o, int q, int n, uint cell)
{
    Stat st;
    for (int k = 0; k < n; ++k) {
        bt_sampler s = mc(cell, (uint)k);
        st.add(rough_dielectric_sample(p, o, q, &s));
    }
    return st;
}

}  // namespace

TEST_CASE("reciprocity: f_r(i,o) = f_r(o,i), f_t(i,o)/eta_o^2 = f_t(o,i)/eta_i^2")
{
    // Exact identities of eqs. 20-21; only rounding separates the two sides.
    for (int dist = 0; dist < 3; ++dist)
        for (int g1 = 0; g1 < 2; ++g1)
            for (int sh = 0; sh < 2; ++sh)
                for (double eta : {1.5, 1 / 1.33, 2.4}) {
                    int o[RD_OPT_COUNT] = {dist, g1, sh, 0, 0};
                    int checked_t = 0;
                    for (int k = 0; k < 200; ++k) {
                        bt_sampler s = mc(1000 + dist * 100 + g1 * 10 + sh, (uint)k);
                        double ti = std::acos(bt_uniform(&s, 0)), to = std::acos(bt_uniform(&s, 1));
                        double pi_ = 2 * kPi * bt_uniform(&s, 2), po = 2 * kPi * bt_uniform(&s, 3);
                        double alpha = 0.05 + 0.8 * bt_uniform(&s, 4);
                        // Reflection above and below.
                        for (int side = 0; side < 2; ++side) {
                            double a = side ? kPi - ti : ti, b = side ? kPi - to : to;
                            double p1[6] = {a, pi_, b, po, alpha, eta};
                            double p2[6] = {b, po, a, pi_, alpha, eta};
                            double f1 = rough_dielectric_fr(p1, o), f2 = rough_dielectric_fr(p2, o);
                            REQUIRE(std::isfinite(f1));
                            REQUIRE(f1 == doctest::Approx(f2).epsilon(1e-10));
                            CHECK(rough_dielectric_ft(p1, o) == 0.0);
                        }
                        // Transmission: i outside (index 1), o inside (index eta).
                        double p1[6] = {ti, pi_, kPi - to, po, alpha, eta};
                        double p2[6] = {kPi - to, po, ti, pi_, alpha, eta};
                        double f1 = rough_dielectric_ft(p1, o), f2 = rough_dielectric_ft(p2, o);
                        REQUIRE(std::isfinite(f1));
                        REQUIRE(f1 / (eta * eta) == doctest::Approx(f2).epsilon(1e-10));
                        checked_t += f1 > 0;
                        CHECK(rough_dielectric_fr(p1, o) == 0.0);
                        CHECK(rough_dielectric_fs(p1, o) == f1);
                    }
                    CHECK(checked_t > 10);  // the identity was exercised on non-zero values (measured >= 20 of 200)
                }
}

TEST_CASE("albedo estimators (visible and Walter sampling) agree with brute-force quadrature")
{
    // Independent paths: the closed-form f_r/f_t (half vectors eqs. 13/16,
    // Jacobians eqs. 14/17) integrated over outgoing directions on a fine
    // grid, versus the estimators (sampling m; visible normals: weight
    // F G/G1(i); Walter: eqs. 39-41).  Quadrature: 5-pt Gauss-Legendre on
    // 400 uniform theta panels per hemisphere and 800 phi points.  Halving
    // the grid changes R by < 1e-6 and T by at most 1.4e-4 (GGX
    // transmission, heavy tails), so the quadrature error is ~1e-4.
    // Estimators: 40000 MC samples each; tolerance 5 stderr + 3e-4.  The
    // configurations cover both G forms and, for Beckmann, Walter's G1 fit,
    // where the visible-normal weight carries the factor G1fit/G1exact.
    const double glx[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831,
                           0.9061798459386640};
    const double glw[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889,
                           0.4786286704993665, 0.2369268850561891};
    struct Cfg {
        int dist, g1, sh;
    };
    const Cfg cfgs[] = {{BT_MF_BECKMANN, 0, 1}, {BT_MF_GGX, 0, 1}, {BT_MF_PHONG, 0, 1},
                        {BT_MF_BECKMANN, 1, 0}, {BT_MF_GGX, 0, 0}};
    for (const Cfg& c : cfgs)
        for (double ti_deg : {30.0, 70.0, 150.0}) {
            const double alpha = 0.5, eta = 1.5;
            double ti = ti_deg * kDeg;
            double R = 0, T = 0;
            const int panels = 400, nphi = 800;
            int oq[RD_OPT_COUNT] = {c.dist, c.g1, c.sh, 0, 0, 0};
            for (int hemi = 0; hemi < 2; ++hemi)
                for (int pnl = 0; pnl < panels; ++pnl)
                    for (int q = 0; q < 5; ++q) {
                        double th = (pnl + 0.5 + 0.5 * glx[q]) * (kPi / 2) / panels;
                        double w = 0.5 * glw[q] * (kPi / 2) / panels;
                        double tho = hemi ? kPi - th : th;
                        double ring = 0;
                        for (int k = 0; k < nphi; ++k) {
                            double p[7] = {ti, 0, tho, 2 * kPi * (k + 0.5) / nphi, alpha, eta};
                            ring += rough_dielectric_fs(p, oq);
                        }
                        double v = ring * (2 * kPi / nphi) * std::sin(th) * std::cos(th) * w;
                        bool same = (ti > kPi / 2) == (hemi == 1);
                        (same ? R : T) += v;
                    }
            double p[7] = {ti, 0, 0, 0, alpha, eta};
            for (int sampling : {RD_SAMPLING_VISIBLE, RD_SAMPLING_WALTER}) {
                int o[RD_OPT_COUNT] = {c.dist, c.g1, c.sh, 0, 0, sampling};
                Stat er = estimate(p, o, RD_Q_ALBEDO_R, 40000, 7 + c.dist);
                Stat et = estimate(p, o, RD_Q_ALBEDO_T, 40000, 7 + c.dist);
                INFO("dist " << c.dist << " g1 " << c.g1 << " sh " << c.sh << " sampling "
                             << sampling << " theta_i " << ti_deg << " quad R " << R << " T " << T
                             << " est R " << er.mean << " +- " << er.se() << " T " << et.mean
                             << " +- " << et.se());
                CHECK(std::fabs(er.mean - R) < 5 * er.se() + 3e-4);
                CHECK(std::fabs(et.mean - T) < 5 * et.se() + 3e-4);
            }
        }
}

TEST_CASE("energy: albedo_r + albedo_t <= 1")
{
    // With an exact Smith G <= G1(i,m), the identity int G1 (i.m)+ D dm = i.n
    // bounds R + T by 1.  Per-sample sums (same m for both lobes) over 10000
    // MC samples; allowed excess 4 stderr.
    // Walter's sampling (o[5] = 1): its weights are not bounded per sample,
    // so this checks the mean; with visible-normal sampling R + T <= 1 holds
    // sample by sample (next test case).
    // Phong is only tested at alpha <= 0.3: its G1 is Walter's Beckmann fit,
    // not the Smith G1 of the Phong D, and the identity fails for rough Phong
    // (measured: F = 1 reflection albedo 1.06 at alpha 0.5, 1.32 at alpha 1,
    // near grazing) — a property of the model choice, see rough_dielectric.h.
    for (int dist = 0; dist < 3; ++dist)
        for (int sh = 0; sh < 2; ++sh)
            for (double alpha : {0.01, 0.3, 1.0, 2.0})
                for (double eta : {1.5, 1 / 1.5, 1.05, 3.0})
                    for (double ti_deg : {0.0, 45.0, 80.0, 89.0, 100.0, 135.0, 179.0}) {
                        if (dist == BT_MF_PHONG && alpha > 0.3) continue;
                        int o[RD_OPT_COUNT] = {dist, 0, sh, 0, 0, RD_SAMPLING_WALTER};
                        double p[7] = {ti_deg * kDeg, 0.3, 0, 0, alpha, eta};
                        Stat st;
                        for (int k = 0; k < 10000; ++k) {
                            bt_sampler s = mc(55, (uint)k);
                            st.add(rough_dielectric_sample(p, o, RD_Q_ALBEDO_R, &s) +
                                   rough_dielectric_sample(p, o, RD_Q_ALBEDO_T, &s));
                        }
                        INFO("dist " << dist << " alpha " << alpha << " eta " << eta << " theta "
                                     << ti_deg << " R+T " << st.mean);
                        CHECK(st.mean <= 1 + 4 * st.se());
                        CHECK(st.mean > 0);
                    }
}

TEST_CASE("visible-normal sampling: every weight <= 1 (exact G1), <= 1.0035 (Walter's fit)")
{
    // Derivation in rough_dielectric.h: w_r = F G/G1(i), w_t = (1 - F) G'/G1(i)
    // with G/G1(i) in [0, 1], so w_r, w_t and w_r + w_t (same m: R and T
    // quantities use the same sampler state) are <= 1 up to rounding.  With
    // Walter's rational G1 the factor G1fit(i)/G1exact(i) enters, bounded by
    // the fit's accuracy (0.35 %, test_microfacet).  A weight of eq. 41 form
    // (|i.m|/(|i.n||m.n|)) exceeds 1 for most samples at grazing light, so
    // this fails if the estimator ever took the Walter path by mistake.
    const double thetas[] = {0.0, 30 * kDeg, 60 * kDeg, 85 * kDeg, 89.99 * kDeg, kPi / 2,
                             120 * kDeg, 179 * kDeg};
    const double alphas[] = {1e-4, 0.05, 0.5, 2.0, 4.0};
    const double etas[] = {1.5, 1 / 1.5, 1.0, 3.0, 1.05, 0.2};
    double max_w = 0, max_fit = 0;
    uint cell = 0;
    for (int dist : {BT_MF_BECKMANN, BT_MF_GGX})
        for (int g1 = 0; g1 < 2; ++g1)
            for (int sh = 0; sh < 2; ++sh)
                for (double a : alphas)
                    for (double e : etas)
                        for (double ti : thetas) {
                            if (g1 == 1 && dist == BT_MF_GGX) continue;  // GGX ignores g1
                            int o[RD_OPT_COUNT] = {dist, g1, sh, RD_LOBE_BOTH, ti > kPi / 2 ? 1 : 0,
                                        RD_SAMPLING_VISIBLE};
                            double p[7] = {ti, 0.3, 0, 0, a, e};
                            double bound = g1 ? 1.0035 : 1 + 1e-12;
                            ++cell;
                            for (int k = 0; k < 150; ++k) {
                                bt_sampler s = mc(cell, (uint)k);
                                double r = rough_dielectric_sample(p, o, RD_Q_ALBEDO_R, &s);
                                double t = rough_dielectric_sample(p, o, RD_Q_ALBEDO_T, &s);
                                double avg = rough_dielectric_sample(p, o, RD_Q_ALBEDO_AVG, &s);
                                REQUIRE(r >= 0);
                                REQUIRE(t >= 0);
                                REQUIRE(r + t <= bound);
                                REQUIRE(avg <= bound);
                                (g1 ? max_fit : max_w) = std::fmax(g1 ? max_fit : max_w, r + t);
                            }
                        }
    // The bound is attained closely (F -> 1 at grazing facets, G1(o) -> 1).
    CHECK(max_w > 0.99);
    INFO("max weight exact G1 " << max_w << ", fit " << max_fit);
    CHECK(max_fit > 0.99);
}

TEST_CASE("visible and Walter sampling estimate the same albedos")
{
    // Two unbiased estimators of the same integral with different weights;
    // agreement within 5 combined stderr + 1e-3 (Walter's heavy tail makes its
    // own stderr unreliable at grazing light, hence the absolute slack).
    // Includes normal and near-grazing light, light from inside (TIR) and
    // the hemispherical average.  alpha 2 is outside the quadrature test.
    for (int dist : {BT_MF_BECKMANN, BT_MF_GGX})
        for (double alpha : {0.1, 1.0, 2.0})
            for (double ti_deg : {0.0, 60.0, 85.0, 135.0}) {
                double p[7] = {ti_deg * kDeg, 0.1, 0, 0, alpha, 1.5};
                for (int q : {RD_Q_ALBEDO_R, RD_Q_ALBEDO_T, RD_Q_ALBEDO_AVG}) {
                    if (q == RD_Q_ALBEDO_AVG && ti_deg > 0) continue;  // no theta_i
                    int ov[RD_OPT_COUNT] = {dist, 0, 0, RD_LOBE_BOTH, 1, RD_SAMPLING_VISIBLE};
                    int ow[RD_OPT_COUNT] = {dist, 0, 0, RD_LOBE_BOTH, 1, RD_SAMPLING_WALTER};
                    uint cell = (uint)(dist * 1000 + alpha * 10 + ti_deg);
                    Stat v = estimate(p, ov, q, 10000, cell);
                    Stat w = estimate(p, ow, q, 40000, cell + 50000);
                    double tol = 5 * std::sqrt(v.se() * v.se() + w.se() * w.se());
                    INFO("dist " << dist << " alpha " << alpha << " theta " << ti_deg << " q " << q
                                 << " visible " << v.mean << " +- " << v.se() << " walter "
                                 << w.mean << " +- " << w.se());
                    CHECK(std::fabs(v.mean - w.mean) < tol + 1e-3);
                    // (No check that visible sampling has the smaller spread: it
                    // is not a theorem; measured, it loses slightly for reflection
                    // at normal incidence and under TIR from inside.)
                }
            }
}

TEST_CASE("smooth limit: alpha -> 0 gives albedo_r = F(theta_i), R + T = 1")
{
    // alpha = 1e-4: facet normals within ~1e-4 rad of n, so F varies by
    // O(1e-4) and G = 1 to 1e-6 (a = cot(theta)/alpha >= 1700).  Tolerance
    // 1e-3 absolute.  Includes light from inside, where eta -> 1/eta and
    // 60 deg is beyond the critical angle (41.8 deg): total reflection.
    for (int dist = 0; dist < 3; ++dist)
        for (double ti_deg : {0.0, 30.0, 60.0, 80.0, 150.0, 120.0}) {
            const double eta = 1.5;
            int o[RD_OPT_COUNT] = {dist, 0, 0, 0, 0};
            double p[7] = {ti_deg * kDeg, 0, 0, 0, 1e-4, eta};
            bool inside = ti_deg > 90;
            double c = std::fabs(std::cos(ti_deg * kDeg));
            double F = fresnel_sp(c, inside ? 1 / eta : eta);
            Stat r = estimate(p, o, RD_Q_ALBEDO_R, 2000, 3);
            Stat t = estimate(p, o, RD_Q_ALBEDO_T, 2000, 3);
            INFO("dist " << dist << " theta " << ti_deg << " F " << F << " R " << r.mean);
            CHECK(r.mean == doctest::Approx(F).epsilon(1e-3 / F));
            CHECK(r.mean + t.mean == doctest::Approx(1.0).epsilon(1e-3));
        }
}

TEST_CASE("GGX alpha = 1, normal incidence, F = 1: albedo = 1 - ln 2")
{
    // D = 1/pi for GGX alpha = 1, G1(n) = 1 and G1(o) = 2 cos/(cos + 1), so
    // int f_r/F cos do = int_{1/sqrt2}^1 2(2t^2 - 1)/t dt = 1 - ln 2 for both
    // G forms (Lambda(n) = 0).  200000 MC samples; 4.5 stderr.
    // Both samplers (visible normals: weight G1(o) <= 1; Walter: eq. 41).
    for (int sampling : {RD_SAMPLING_VISIBLE, RD_SAMPLING_WALTER})
    for (int sh = 0; sh < 2; ++sh) {
        bt_microfacet mf = bt_microfacet_make(BT_MF_GGX, BT_G1_EXACT, sh, 1.0, 1.0);
        Stat st;
        for (int k = 0; k < 200000; ++k) {
            bt_sampler s = mc(77, (uint)k);
            double wr, wt;
            rd_albedo_weights(&mf, bt_v3(0, 0, 1), 1.5, sampling, bt_uniform(&s, 0),
                              bt_uniform(&s, 1), 1, &wr, &wt);
            CHECK(wt == 0.0);
            st.add(wr);
        }
        INFO("sampling " << sampling << " estimate " << st.mean << " +- " << st.se());
        CHECK(std::fabs(st.mean - (1 - std::log(2.0))) < 4.5 * st.se());
        CHECK(st.se() < 2e-3);
    }
}

TEST_CASE("eta = 1: no reflection, transmission straight through")
{
    // With eta = 1 every facet sends i to -i (checked in test_microfacet), so
    // albedo_t = int G(i,-i,m) (i.m)+ D dm / i.n.  Smith's identity turns this
    // into G1(i) for separable G (G = G1(i)^2) and (1 + L)/(1 + 2L) for
    // height-correlated G (L = Lambda(i) = 1/G1(i) - 1): closed forms from the
    // exact G1, independent of the sampling.  4000 MC samples, 5 stderr.
    for (int dist = 0; dist < 2; ++dist)
        for (int sh = 0; sh < 2; ++sh)
            for (double alpha : {1e-3, 0.5})
                for (double ti_deg : {0.0, 40.0, 75.0, 140.0}) {
                    int o[RD_OPT_COUNT] = {dist, 0, sh, 0, 0};
                    double p[7] = {ti_deg * kDeg, 0.2, 0, 0, alpha, 1.0};
                    Stat r = estimate(p, o, RD_Q_ALBEDO_R, 500, 9);
                    Stat t = estimate(p, o, RD_Q_ALBEDO_T, 4000, 9);
                    CHECK(r.mean == 0.0);
                    bt_microfacet mf = bt_microfacet_make(dist, 0, sh, alpha, alpha);
                    double g1 = bt_mf_g1_nochi(&mf, bt_from_spherical(ti_deg * kDeg, 0.2));
                    double lam = 1 / g1 - 1;
                    double expect = sh == BT_SHADOW_SEPARABLE ? g1 : (1 + lam) / (1 + 2 * lam);
                    INFO("dist " << dist << " sh " << sh << " alpha " << alpha << " theta "
                                 << ti_deg << " T " << t.mean << " expect " << expect);
                    CHECK(std::fabs(t.mean - expect) < 5 * t.se() + 1e-9);
                    if (alpha < 0.01) CHECK(t.mean == doctest::Approx(1.0).epsilon(1e-3));
                    // The BTDF of eta = 1 is a Dirac delta: documented as 0 everywhere.
                    double q[6] = {ti_deg * kDeg, 0.2, kPi - ti_deg * kDeg, 0.2 + kPi, alpha, 1.0};
                    CHECK(rough_dielectric_ft(q, o) == 0.0);
                }
}

TEST_CASE("albedo_avg: smooth-limit hemispherical reflectances and their identity")
{
    // Oracles: r_e = 2 int F(mu, eta) mu dmu by 1-D quadrature (s/p formula),
    // and the internal reflectance r_i = 1 - (1 - r_e)/eta^2 (reciprocity of
    // the smooth interface).  alpha = 1e-4; 100000 samples; the dominant
    // error is MC (stderr ~1e-3) -> tolerance 5 stderr + 1e-3 bias allowance.
    const double eta = 1.5;
    double re = 0;
    const int n = 200000;
    for (int k = 0; k < n; ++k) {
        double mu = (k + 0.5) / n;
        re += 2 * fresnel_sp(mu, eta) * mu / n;
    }
    double ri = 1 - (1 - re) / (eta * eta);
    for (int dist = 0; dist < 3; ++dist) {
        double p[7] = {0, 0, 0, 0, 1e-4, eta};
        int out_r[RD_OPT_COUNT] = {dist, 0, 0, RD_LOBE_REFLECTION, 0};
        int in_r[RD_OPT_COUNT] = {dist, 0, 0, RD_LOBE_REFLECTION, 1};
        int out_both[RD_OPT_COUNT] = {dist, 0, 0, RD_LOBE_BOTH, 0};
        Stat a = estimate(p, out_r, RD_Q_ALBEDO_AVG, 100000, 21);
        Stat b = estimate(p, in_r, RD_Q_ALBEDO_AVG, 100000, 22);
        Stat c = estimate(p, out_both, RD_Q_ALBEDO_AVG, 20000, 23);
        INFO("re " << re << " est " << a.mean << "; ri " << ri << " est " << b.mean);
        CHECK(std::fabs(a.mean - re) < 5 * a.se() + 1e-3);
        CHECK(std::fabs(b.mean - ri) < 5 * b.se() + 1e-3);
        CHECK(c.mean == doctest::Approx(1.0).epsilon(2e-3));
    }
}

TEST_CASE("no NaN or Inf on extreme inputs")
{
    const double thetas[] = {0.0, 1e-6, 45 * kDeg, 89.99 * kDeg, kPi / 2 - 1e-9, kPi / 2, kPi / 2 + 1e-9,
                             135 * kDeg, kPi - 1e-7, kPi};
    const double alphas[] = {1e-4, 0.01, 0.5, 2.0, 4.0};  // registry allows (0, 4]
    const double etas[] = {1.0, 1.0 + 1e-9, 1.5, 1 / 1.5, 3.0, 0.2};
    long n = 0;
    for (int dist = 0; dist < 3; ++dist)
        for (int g1 = 0; g1 < 2; ++g1)
            for (int sh = 0; sh < 2; ++sh)
                for (double a : alphas)
                    for (double e : etas)
                        for (double ti : thetas)
                            for (double to : thetas)
                                for (double dphi : {0.0, kPi, 1.0}) {
                                    int o[RD_OPT_COUNT] = {dist, g1, sh, (int)(n % 3), (int)(n % 2),
                                                (int)((n / 2) % 2)};
                                    double p[7] = {ti, 0.4, to, 0.4 + dphi, a, e};
                                    for (int q = 0; q < 6; ++q) {
                                        // Integrals: a few samples each (incl. u = 0).
                                        int ns = q < 3 ? 1 : 3;
                                        for (int k = 0; k < ns; ++k) {
                                            bt_sampler s = mc((uint)n, (uint)k);
                                            if (k == 2) s.method = BT_METHOD_CLOSED;
                                            double v = rough_dielectric_sample(p, o, q, &s);
                                            REQUIRE(std::isfinite(v));
                                            REQUIRE(v >= 0);
                                        }
                                    }
                                    ++n;
                                }
    // u = 0 exactly in every dimension (Sobol point 0 unscrambled is 0): the
    // sampling maps and mu = sqrt(0) must stay finite.
    bt_microfacet mf = bt_microfacet_make(BT_MF_PHONG, 0, 0, 2.0, 2.0);
    double wr, wt;
    rd_albedo_weights(&mf, bt_v3(0, 0, 1), 1.5, RD_SAMPLING_WALTER, 0.0, 0.0, 0, &wr, &wt);
    CHECK(std::isfinite(wr));
    CHECK(std::isfinite(wt));
    // Visible-normal samplers at u = 0 and at the largest u, grazing and
    // normal light, extreme widths (the Beckmann inverse CDFs clamp the
    // slope range instead of returning -inf).
    for (int dist : {BT_MF_BECKMANN, BT_MF_GGX})
        for (double a : {1e-4, 1.0, 4.0})
            for (double cz : {1.0, 0.5, 1e-9}) {
                bt_microfacet v = bt_microfacet_make(dist, 0, 0, a, a);
                bt_vec3 i = bt_v3(std::sqrt(1 - cz * cz), 0, cz);
                for (double u0 : {0.0, 0.5, 1 - 0x1p-32})
                    for (double u1 : {0.0, 0.25, 1 - 0x1p-32}) {
                        bt_vec3 m = bt_mf_sample_visible(&v, i, u0, u1);
                        REQUIRE(std::isfinite(m.x));
                        REQUIRE(std::isfinite(m.y));
                        REQUIRE(std::isfinite(m.z));
                        REQUIRE(m.z >= 0);
                        rd_albedo_weights(&v, i, 1.5, RD_SAMPLING_VISIBLE, u0, u1, 0, &wr, &wt);
                        REQUIRE(std::isfinite(wr));
                        REQUIRE(std::isfinite(wt));
                        REQUIRE(wr + wt <= 1 + 1e-12);
                    }
            }
}

TEST_CASE("Phong, alpha < 1 (issue #15): D normalised, sampler follows D |m.n|, albedos bounded")
{
    // The estimator's Phong D (eq. 30 with alpha_p = 2/alpha^2 - 2) against
    // the projected-area identity  int D(m) (m.n) dm = 1, by composite
    // Simpson in u = cos(theta_m) (independent of the sampler and of eq. 32):
    //   2 pi int_0^1 D(u) u du.
    // Phong is refused for alpha >= 1 (host/models/rough_dielectric.cpp).
    auto d_of = [](const bt_microfacet& mf, double u) {
        return bt_mf_d(&mf, bt_v3(std::sqrt(std::max(0.0, 1 - u * u)), 0.0, u));
    };
    auto projected_area_below = [&](const bt_microfacet& mf, double t) {
        const int n = 200000;  // even
        const double h = t / n;
        double s = d_of(mf, 0) * 0 + d_of(mf, t) * t;
        for (int k = 1; k < n; ++k) {
            const double u = k * h;
            s += (k % 2 ? 4 : 2) * d_of(mf, u) * u;
        }
        return 2 * kPi * s * h / 3;
    };
    for (double alpha : {0.05, 0.3, 0.7, 0.9, 0.99}) {
        const bt_microfacet mf = bt_microfacet_make(BT_MF_PHONG, 0, 0, alpha, alpha);
        INFO("alpha " << alpha);
        CHECK(projected_area_below(mf, 1.0) == doctest::Approx(1.0).epsilon(1e-6));

        // Eq. 32's sampler: the fraction of stratified u0 whose normal has
        // cos(theta_m) < t equals the quadrature's projected area below t.
        const int n = 100000;
        for (double t : {0.2, 0.5, 0.8, 0.95, 0.99}) {
            int below = 0;
            for (int k = 0; k < n; ++k) {
                double pdf = 0;
                const bt_vec3 m = bt_mf_sample(&mf, (k + 0.5) / n, 0.25, &pdf);
                below += m.z < t;
            }
            // cos(theta_m) is monotone in u0: the count is exact to 1/n.
            INFO("t " << t);
            CHECK(std::fabs(static_cast<double>(below) / n - projected_area_below(mf, t)) < 1e-4);
        }
    }

    // Average reflection albedo with F = 1 (light cosine-weighted over the
    // hemisphere, mu = sqrt(xi)): finite, <= 1 here (measured 0.995 at
    // alpha 0.1 down to 0.58 at 0.99), and its standard error halves when the
    // sample count quadruples (finite variance: no divergence).
    std::mt19937_64 rng(15);
    std::uniform_real_distribution<double> uni(0, 1);
    for (double alpha : {0.1, 0.5, 0.9, 0.99}) {
        const bt_microfacet mf = bt_microfacet_make(BT_MF_PHONG, 0, 0, alpha, alpha);
        Stat small, large;
        int nonfinite = 0;
        for (int k = 0; k < 80000; ++k) {
            const double mu = std::max(std::sqrt(uni(rng)), 1e-9);
            const bt_vec3 i = bt_v3(std::sqrt(1 - mu * mu), 0.0, mu);
            double wr = 0, wt = 0;
            const double u0 = uni(rng), u1 = uni(rng);
            rd_albedo_weights(&mf, i, 1.5, RD_SAMPLING_WALTER, u0, u1, 1, &wr, &wt);
            nonfinite += !std::isfinite(wr);
            if (k < 20000) small.add(wr);
            large.add(wr);
        }
        INFO("alpha " << alpha << " F=1 average albedo " << large.mean << " +- " << large.se());
        CHECK(nonfinite == 0);
        CHECK(large.mean <= 1 + 4 * large.se());
        CHECK(large.mean > 0.5);
        CHECK(large.se() / small.se() == doctest::Approx(0.5).epsilon(0.3));
    }
}

TEST_CASE("Phong near alpha = 1 (issue #15): R + T above 1 is the fitted G1, not the estimator")
{
    // Per sample, w_r + w_t = |i.m|/(|i.n| |m.n|) (F G(i,o_r,m) + (1 - F)
    // G(i,o_t,m)) <= |i.m| G1(i) / (|i.n| |m.n|), so with m ~ D |m.n|
    //   R + T <= B(i) = G1(i) int (i.m)+ D(m) dm / (i.n).
    // For the Smith G1 of D, B = 1 (Smith's identity); Phong's G1 is Walter's
    // Beckmann fit (eq. 31 with eq. 27), and B, computed here by midpoint
    // quadrature over the hemisphere of m (independent of the sampler),
    // exceeds 1: 1.10 at alpha 0.9 and 1.17 at 0.99 for theta_i = 45 deg,
    // 1.27 and 1.41 at 70 deg.  The estimates stay below B: what exceeds 1 is
    // the model (docs/models/rough-dielectric.md, departure 3).
    for (double alpha : {0.9, 0.99})
        for (double ti_deg : {45.0, 70.0, 85.0}) {
            const bt_microfacet mf = bt_microfacet_make(BT_MF_PHONG, 0, 0, alpha, alpha);
            const bt_vec3 i = bt_v3(std::sin(ti_deg * kDeg), 0.0, std::cos(ti_deg * kDeg));
            const int nu = 1000, nphi = 1000;
            double q = 0;
            for (int a = 0; a < nu; ++a) {
                const double u = (a + 0.5) / nu, st = std::sqrt(1 - u * u);
                for (int b = 0; b < nphi; ++b) {
                    const double phi = 2 * kPi * (b + 0.5) / nphi;
                    const bt_vec3 m = bt_v3(st * std::cos(phi), st * std::sin(phi), u);
                    q += std::max(0.0, bt_v3_dot(i, m)) * bt_mf_d(&mf, m);
                }
            }
            q *= (1.0 / nu) * (2 * kPi / nphi);
            const double bound = bt_mf_g1_nochi(&mf, i) * q / i.z;
            int o[RD_OPT_COUNT] = {BT_MF_PHONG, 0, 0, 0, 0, RD_SAMPLING_WALTER};
            double p[7] = {ti_deg * kDeg, 0, 0, 0, alpha, 1.5};
            Stat st;
            for (int k = 0; k < 20000; ++k) {
                bt_sampler s = mc(77, (uint)k);
                st.add(rough_dielectric_sample(p, o, RD_Q_ALBEDO_R, &s) +
                       rough_dielectric_sample(p, o, RD_Q_ALBEDO_T, &s));
            }
            INFO("alpha " << alpha << " theta_i " << ti_deg << " R+T " << st.mean << " +- "
                          << st.se() << " bound " << bound);
            CHECK(bound > 1.05);  // the fitted G1 breaks Smith's identity here
            CHECK(st.mean <= bound + 4 * st.se());
        }
}

// ------------------------------------------------------------------------
// Deterministic quadrature of the albedos (method quadrature, the default;
// rd_albedo_quadrature).  Oracles: RQMC with 2^20 Owen-scrambled Sobol
// points (an independent estimator of the same integral), the smooth-surface
// Fresnel limit (independent s/p formula), eta = 1, energy, and a much finer
// rule for the honesty of the two-rule error estimate.

namespace {

bt_sampler quad_sampler(uint batch) {
    return brdftab::test::make_sampler(BT_METHOD_QUADRATURE, 0, 0, 0, batch, 0);
}

// Quadrature value with n nodes (batch 0: the accurate rule).
double quad_value(double theta_i, double alpha, double eta, int q, int n, const int* o) {
    double p[8] = {theta_i, 0, 0, 0, alpha, eta, (double)n, 0};
    bt_sampler s = quad_sampler(0);
    return rough_dielectric_sample(p, o, q, &s);
}

// RQMC albedos (both lobes from the same points): 16 independently
// scrambled batches of 2^16 Sobol points, stderr from the batch means.
void rqmc_albedos(double theta_i, double alpha, double eta, const int* o, uint cell, Stat* r,
                  Stat* t, uint batch_size) {
    bt_microfacet mf = bt_microfacet_make(o[RD_OPT_DISTRIBUTION], o[RD_OPT_G1],
                                          o[RD_OPT_SHADOWING], alpha, alpha);
    bt_vec3 i;
    bt_direction(theta_i, 0, RD_MIN_COS, BT_DIR_SIGNED_COS, &i);
    double e = eta;
    if (i.z < 0) {
        i.z = -i.z;
        e = 1 / eta;
    }
    for (uint b = 0; b < 16; ++b) {
        double sr = 0, st = 0;
        for (uint k = 0; k < batch_size; ++k) {
            bt_sampler s = brdftab::test::make_sampler(BT_METHOD_RQMC, 0xAB, 0xCD, cell, b, k);
            double wr, wt;
            rd_albedo_weights(&mf, i, e, RD_SAMPLING_VISIBLE, bt_uniform(&s, 0u), bt_uniform(&s, 1u),
                              0, &wr, &wt);
            sr += wr;
            st += wt;
        }
        r->add(sr / batch_size);
        t->add(st / batch_size);
    }
}

}  // namespace

TEST_CASE("quadrature agrees with RQMC at 2^20 points (GGX, Beckmann, both G forms, both sides)")
{
    // 2^20 points (16 batches of 2^16) on the full grid for GGX with the
    // separable G (the presets' model), 2^18 on a thinner grid otherwise.
    // Within 5 RQMC stderr + 3e-6: the slack covers events RQMC barely sees
    // at 2^20 points (measured: GGX tails of probability ~1e-6 past the TIR
    // edge at alpha = 0.001; a 1.5e-7 offset at alpha 0.1, eta 1.0001 where a
    // brute-force 4e6-point integral in theta_m agrees with the quadrature).
    uint cell = 0;
    int checked = 0;
    for (int dist : {BT_MF_GGX, BT_MF_BECKMANN})
        for (int sh : {BT_SHADOW_SEPARABLE, BT_SHADOW_HEIGHT_CORRELATED}) {
            // the full grid for GGX separable (the presets' model), a thinner one otherwise
            const bool full = dist == BT_MF_GGX && sh == BT_SHADOW_SEPARABLE;
            for (double mu : {0.02, 0.5, 1.0, -0.02, -0.5, -0.95})
                for (double alpha : {0.001, 0.3, 1.0})
                    for (double eta : {1.0001, 1.5, 3.0}) {
                        if (!full && (alpha == 0.3 || eta == 1.5)) continue;
                        const int o[RD_OPT_COUNT] = {dist, 0, sh, 0, 0, RD_SAMPLING_VISIBLE};
                        const double ti = std::acos(mu);
                        Stat r, t;
                        rqmc_albedos(ti, alpha, eta, o, ++cell, &r, &t, full ? 1u << 16 : 1u << 14);
                        const double qr = quad_value(ti, alpha, eta, RD_Q_ALBEDO_R, 12, o);
                        const double qt = quad_value(ti, alpha, eta, RD_Q_ALBEDO_T, 12, o);
                        INFO("dist " << dist << " shadowing " << sh << " mu " << mu << " alpha "
                                     << alpha << " eta " << eta << ": r " << qr << " vs " << r.mean
                                     << " +- " << r.se() << ", t " << qt << " vs " << t.mean
                                     << " +- " << t.se());
                        CHECK(std::fabs(qr - r.mean) <= 5 * r.se() + 3e-6);
                        CHECK(std::fabs(qt - t.mean) <= 5 * t.se() + 3e-6);
                        ++checked;
                    }
        }
    CHECK(checked == 54 + 3 * 24);
}

TEST_CASE("quadrature: alpha -> 0 gives the Fresnel reflectance, eta = 1 no reflection")
{
    for (int dist : {BT_MF_GGX, BT_MF_BECKMANN}) {
        const int o[RD_OPT_COUNT] = {dist, 0, 0, 0, 0, 0};
        for (double eta : {1.33, 1.5, 2.4})
            for (double mu : {0.1, 0.5, 0.9, 1.0, -0.3, -0.7, -0.9, -1.0}) {
                const double ti = std::acos(mu);
                // the smooth interface seen from the side of the light
                const double f = fresnel_sp(mu, mu > 0 ? eta : 1 / eta);
                const double r = quad_value(ti, 1e-4, eta, RD_Q_ALBEDO_R, 12, o);
                const double t = quad_value(ti, 1e-4, eta, RD_Q_ALBEDO_T, 12, o);
                INFO("dist " << dist << " eta " << eta << " mu " << mu << ": r " << r << " F " << f
                             << " t " << t);
                // masking vanishes as alpha -> 0: R = F, T = 1 - F
                CHECK(std::fabs(r - f) < 2e-5);
                CHECK(std::fabs(t - (1 - f)) < 2e-5);
            }
        for (double mu : {0.05, 0.5, 1.0, -0.5})
            for (double alpha : {0.01, 0.5, 2.0}) {
                const double ti = std::acos(mu);
                CHECK(quad_value(ti, alpha, 1.0, RD_Q_ALBEDO_R, 16, o) == 0.0);
                // eta = 1: albedo_t = G1(i) (Smith's identity, separable G)
                bt_microfacet mf = bt_microfacet_make(dist, 0, 0, alpha, alpha);
                bt_vec3 i = bt_v3(std::sqrt(1 - mu * mu), 0, std::fabs(mu));
                CHECK(quad_value(ti, alpha, 1.0, RD_Q_ALBEDO_T, 16, o) ==
                      doctest::Approx(bt_mf_g1_nochi(&mf, i)).epsilon(1e-7));
            }
    }
}

TEST_CASE("quadrature: energy, and the two-rule error estimate is honest")
{
    // Error estimate: |Q_n - Q_(n/2)| (the engine's stderr for quadrature),
    // at the default n = 12.  True error: |Q_n - Q_32|.  Over a grid of both
    // sides, both distributions and G forms: never above 10x the estimate,
    // and at most 5 % of the cells above it.  Cells with a true error below
    // 1e-9 (rounding and the fine rule's own error) are skipped.
    int cells = 0, above = 0;
    double worst_ratio = 0;
    for (int dist : {BT_MF_GGX, BT_MF_BECKMANN})
        for (int sh : {BT_SHADOW_SEPARABLE, BT_SHADOW_HEIGHT_CORRELATED})
            for (double mu : {0.02, 0.3, 1.0, -0.05, -0.4, -0.8})
                for (double alpha : {0.003, 0.05, 0.3, 1.0})
                    for (double eta : {1.05, 1.5, 2.5}) {
                        if (sh == BT_SHADOW_HEIGHT_CORRELATED && alpha == 0.05) continue;
                        const int o[RD_OPT_COUNT] = {dist, 0, sh, 0, 0, 0};
                        const double ti = std::acos(mu);
                        const int n = 12;
                        double acc[2], r_t[2];
                        for (int k = 0; k < 2; ++k) {
                            const int q = k ? RD_Q_ALBEDO_T : RD_Q_ALBEDO_R;
                            acc[k] = quad_value(ti, alpha, eta, q, n, o);
                            const double fine = quad_value(ti, alpha, eta, q, 32, o);
                            const double coarse = quad_value(ti, alpha, eta, q, RD_QUAD_COARSE(n), o);
                            const double err = std::fabs(acc[k] - fine);
                            const double est = std::fabs(acc[k] - coarse);
                            r_t[k] = acc[k];
                            if (err < 1e-9) continue;
                            ++cells;
                            if (err > est) ++above;
                            worst_ratio = std::fmax(worst_ratio, err / est);
                            INFO("dist " << dist << " sh " << sh << " mu " << mu << " alpha " << alpha
                                         << " eta " << eta << " q " << q << ": error " << err
                                         << " estimate " << est);
                            CHECK(err <= 10 * est);
                        }
                        CHECK(r_t[0] >= 0);
                        CHECK(r_t[1] >= 0);
                        CHECK(r_t[0] + r_t[1] <= 1 + 1e-12);
                    }
    INFO(above << " of " << cells << " cells above their estimate, worst ratio " << worst_ratio);
    CHECK(cells > 50);
    CHECK(above <= cells / 20);
}

TEST_CASE("quadrature: albedo_avg and Phong agree with RQMC; batch 1 is the coarse rule")
{
    // albedo_avg: 3-D; RQMC over (m, mu) with 2^18 points.
    for (int side : {0, 1})
        for (double alpha : {0.05, 0.5}) {
            const int o[RD_OPT_COUNT] = {BT_MF_GGX, 0, 0, RD_LOBE_BOTH, side, RD_SAMPLING_VISIBLE};
            double p[8] = {0, 0, 0, 0, alpha, 1.5, 16, 0};
            Stat st;
            for (uint b = 0; b < 16; ++b) {
                double sum = 0;
                for (uint k = 0; k < (1u << 14); ++k) {
                    bt_sampler s = brdftab::test::make_sampler(BT_METHOD_RQMC, 3, 4, 77 + side, b, k);
                    sum += rough_dielectric_sample(p, o, RD_Q_ALBEDO_AVG, &s);
                }
                st.add(sum / (1u << 14));
            }
            bt_sampler sq = quad_sampler(0);
            const double q = rough_dielectric_sample(p, o, RD_Q_ALBEDO_AVG, &sq);
            INFO("side " << side << " alpha " << alpha << ": " << q << " vs " << st.mean << " +- "
                         << st.se());
            CHECK(std::fabs(q - st.mean) <= 5 * st.se() + 2e-5);
        }
    // Phong (real theta_m rows, Walter-weight normalisation) against its own
    // RQMC (Walter's sampling: Phong has no visible-normal sampler).
    for (double mu : {0.3, 0.9, -0.6}) {
        const int o[RD_OPT_COUNT] = {BT_MF_PHONG, 0, 0, 0, 0, RD_SAMPLING_WALTER};
        double p[8] = {std::acos(mu), 0, 0, 0, 0.3, 1.5, 16, 0};
        for (int q : {RD_Q_ALBEDO_R, RD_Q_ALBEDO_T}) {
            Stat st;
            for (uint b = 0; b < 16; ++b) {
                double sum = 0;
                for (uint k = 0; k < (1u << 15); ++k) {
                    bt_sampler s = brdftab::test::make_sampler(BT_METHOD_RQMC, 5, 6, 90, b, k);
                    sum += rough_dielectric_sample(p, o, q, &s);
                }
                st.add(sum / (1u << 15));
            }
            bt_sampler sq = quad_sampler(0);
            const double v = rough_dielectric_sample(p, o, q, &sq);
            INFO("phong mu " << mu << " q " << q << ": " << v << " vs " << st.mean << " +- " << st.se());
            CHECK(std::fabs(v - st.mean) <= 5 * st.se() + 2e-5);
        }
    }
    // batch 1 evaluates the coarse rule (the engine's error estimate).
    const int o[RD_OPT_COUNT] = {BT_MF_GGX, 0, 0, 0, 0, 0};
    double p[8] = {0.7, 0, 0, 0, 0.2, 1.5, 16, 0};
    bt_sampler s1 = quad_sampler(1);
    CHECK(rough_dielectric_sample(p, o, RD_Q_ALBEDO_R, &s1) ==
          quad_value(0.7, 0.2, 1.5, RD_Q_ALBEDO_R, RD_QUAD_COARSE(16), o));
    // nodes = 2: the coarse rule has one node (not two, which made the
    // estimate 0); the estimate is at least half the 2-node rule's error
    // against 32 nodes (measured here: 5.1 x it for albedo_t, 0.92 x it for
    // albedo_avg), for a directional albedo and for albedo_avg.
    for (int q : {RD_Q_ALBEDO_T, RD_Q_ALBEDO_AVG}) {
        double p2[8] = {0.7, 0, 0, 0, 0.2, 1.5, 2, 0};
        bt_sampler a = quad_sampler(0), b = quad_sampler(1);
        const double q2 = rough_dielectric_sample(p2, o, q, &a), q1 = rough_dielectric_sample(p2, o, q, &b);
        p2[RD_PARAM_NODES] = 32;
        bt_sampler c = quad_sampler(0);
        const double q32 = rough_dielectric_sample(p2, o, q, &c);
        INFO("quantity " << q << ": Q2 " << q2 << ", Q1 " << q1 << ", Q32 " << q32);
        CHECK(std::fabs(q2 - q32) > 0);
        CHECK(std::fabs(q2 - q1) >= 0.5 * std::fabs(q2 - q32));
    }
}

// test_interfaced_lambertian.cpp — kernels/models/interfaced_lambertian.h
// (compiled as C++, the --device host path) and its OpenCL build.
//
// Oracles, all written here independently of the code under test:
//  - Fresnel from the s/p amplitude formulas; D (eqs. 13, 15, 20), the
//    Torrance-Sparrow GAF (eq. 14) and Smith Lambda (eqs. 19, 21) re-typed
//    from the paper; brute-force midpoint quadrature of eq. 12 over the
//    hemisphere of normals.
//  - r_e / r_i: direct quadrature of eq. 9 with the s/p Fresnel; r_e(1.5) =
//    0.0918 (the paper; docs/models/interfaced-lambertian.md).
//  - Limits: sigma -> 0 gives the flat interfaced Lambertian T(i) T(o);
//    ni = 1 with Gaussian + TS gives Oren-Nayar's direct term (docs/models/oren-nayar.md,
//    evaluated here by 2-D quadrature, GAF = max(0, min(1, X, Y))).
//  - Energy: flat surface with Kd = 1 has body + specular albedo exactly 1;
//    rough ones stay <= 1.  V-cavities with ni = 1, Kd = 1 lose no energy:
//    the all-order albedo is 1.
//  - V-cavity: order 1 = body integral with TS GAF times the prefactor;
//    ni = 1 order 2 = Oren-Nayar's L2 (docs/models/oren-nayar.md, IF closed form,
//    quadrature here); order 0 = sum of orders.
//  - Symmetries: reciprocity, isotropy (value depends on phi_o - phi_i only),
//    anisotropic swap (alpha_x, alpha_y, phi) <-> (alpha_y, alpha_x, phi + 90).
//  - Device (PoCL) vs host through brdftab::estimate(); float build sanity.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "host/engine/engine.h"
#include "host/models/registry.h"
#include "kernels/models/interfaced_lambertian.h"
#include "test_support.h"

namespace {

using brdftab::test::kPi;
using brdftab::test::kDeg;

enum { GAUSS_TS = 0, BECK_TS = 1, BECK_SMITH = 2, GGX_SMITH = 3 };

// ---------------------------------------------------------------- oracles

using brdftab::test::fresnel_sp;

struct V {
    double x, y, z;
};
double dot(V a, V b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
V sph(double t, double p) { return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)}; }

// 1/C of eq. 13 by composite Simpson (independent of the kernel's Gauss rule).
double gauss_norm(double sigma)
{
    const int n = 20000;
    double b = kPi / 2, h = b / n, s = 0;
    for (int k = 0; k <= n; ++k) {
        double t = k * h, w = (k == 0 || k == n) ? 1 : (k % 2 ? 4 : 2);
        s += w * std::exp(-t * t / (2 * sigma * sigma)) * std::sin(t);
    }
    return 1 / (2 * kPi * s * h / 3);
}

struct Surf {
    int dist;
    double sigma, ax, ay, C;
};

double D(const Surf& s, V m)
{
    if (m.z <= 0) return 0;
    if (s.dist == GAUSS_TS) {
        double t = std::acos(std::min(1.0, m.z));
        return s.C * std::exp(-t * t / (2 * s.sigma * s.sigma)) / m.z; /* eq. 13 */
    }
    double t2 = (m.x * m.x / (s.ax * s.ax) + m.y * m.y / (s.ay * s.ay)) / (m.z * m.z);
    double z4 = m.z * m.z * m.z * m.z;
    if (s.dist == GGX_SMITH) return 1 / (kPi * s.ax * s.ay * z4 * (1 + t2) * (1 + t2));
    return std::exp(-t2) / (kPi * s.ax * s.ay * z4); /* eq. 15 */
}

double lambda(const Surf& s, V u)
{
    double a = u.z / std::sqrt(s.ax * s.ax * u.x * u.x + s.ay * s.ay * u.y * u.y);
    if (s.dist == GGX_SMITH) return (-1 + std::sqrt(1 + 1 / (a * a))) / 2; /* eq. 21 */
    return (std::erf(a) - 1) / 2 + std::exp(-a * a) / (2 * a * std::sqrt(kPi)); /* eq. 19 */
}

double G(const Surf& s, V i, V o, V m)
{
    double im = dot(i, m), om = dot(o, m);
    if (im <= 0 || om <= 0) return 0;
    if (s.dist == GAUSS_TS || s.dist == BECK_TS)
        return std::max(0.0, std::min({1.0, 2 * i.z * m.z / im, 2 * o.z * m.z / om}));
    return 1 / (1 + lambda(s, i)) / (1 + lambda(s, o));
}

// Brute-force eq. 12 integral (no prefactor): midpoint rule on (theta_m, phi_m).
double body_quadrature(const Surf& s, V i, V o, double ni, int nt = 500, int np = 1000)
{
    double sum = 0, ht = (kPi / 2) / nt, hp = 2 * kPi / np;
    for (int a = 0; a < nt; ++a) {
        double t = (a + 0.5) * ht, st = std::sin(t);
        for (int b = 0; b < np; ++b) {
            V m = sph(t, (b + 0.5) * hp);
            double im = dot(i, m), om = dot(o, m);
            if (im <= 0 || om <= 0) continue;
            sum += (1 - fresnel_sp(im, ni)) * (1 - fresnel_sp(om, ni)) * D(s, m) * G(s, i, o, m) *
                   im * om / (i.z * o.z) * st;
        }
    }
    return sum * ht * hp;
}

// Oren-Nayar direct term / (rho/pi) and two-bounce term (rho = 1), docs/models/oren-nayar.md.
void oren_nayar_terms(double sigma, V s, V v, double* direct, double* two, int nt = 400,
                      int np = 800)
{
    double C = gauss_norm(sigma), d1 = 0, d2 = 0, ht = (kPi / 2) / nt, hp = 2 * kPi / np;
    auto d = [](double x, double y, double c2) { return std::sqrt(x * x + 2 * x * y * c2 + y * y); };
    for (int a = 0; a < nt; ++a) {
        double ta = (a + 0.5) * ht;
        double P = C * std::exp(-ta * ta / (2 * sigma * sigma)); /* P = D cos(theta_a) */
        for (int b = 0; b < np; ++b) {
            double pa = (b + 0.5) * hp;
            V an = sph(ta, pa), ap = sph(ta, pa + kPi);
            double sa = dot(s, an), va = dot(v, an), an_n = an.z;
            double w = P * std::sin(ta) * ht * hp;
            if (sa > 0 && va > 0) {
                double X = 2 * s.z * an_n / sa, Y = 2 * v.z * an_n / va;
                double gaf = std::max(0.0, std::min({1.0, X, Y}));
                d1 += w * sa * va / (an_n * v.z * s.z) * gaf; /* L1 / (E0 cos theta_i) */
            }
            double aps = dot(ap, s);
            if (va > 0 && aps > 0) {
                double mv = std::min(1.0, std::max(0.0, -dot(ap, v) / va));
                double ms = std::min(1.0, std::max(0.0, -sa / aps));
                double c2 = std::cos(2 * ta);
                double IF = kPi / 2 * (d(1, mv, c2) + d(1, ms, c2) - d(ms, mv, c2) - d(1, 1, c2));
                d2 += w * aps * va / (an_n * v.z) * IF / (kPi * kPi) / s.z;
            }
        }
    }
    *direct = d1;
    *two = d2;
}

// ---------------------------------------------------------------- estimator

struct Stat {
    double mean = 0, se = 0;
};

// RQMC: `batches` independently scrambled copies of `n` Sobol points; the
// batch means are i.i.d., so their spread gives the standard error.
Stat est(const double* p, const int* o, int q, int n = 8192, int batches = 8, uint cell = 1)
{
    brdftab::test::RunningStat batch_means;
    for (int b = 0; b < batches; ++b) {
        double s = 0;
        for (int k = 0; k < n; ++k) {
            bt_sampler sm{0x1234u, 0x9876u, cell, (uint)b, (uint)k, BT_METHOD_RQMC};
            s += interfaced_lambertian_sample(p, o, q, &sm);
        }
        batch_means.add(s / n);
    }
    return {batch_means.mean, batch_means.se()};
}

struct Pt {
    double p[11];
    Pt(double ti, double pi_, double to, double po, double sigma_deg, double alpha, double ni,
       double kd = 1, double order = 0, double ax = 0, double ay = 0)
        : p{ti * kDeg, pi_ * kDeg, to * kDeg, po * kDeg, sigma_deg * kDeg, alpha, ax, ay, ni, kd,
            order}
    {
    }
};

}  // namespace

TEST_CASE("r_e and r_i: eq. 10 closed form vs quadrature of eq. 9")
{
    for (double ni : {1.0001, 1.001, 1.05, 1.2, 1.5, 2.0, 3.0, 4.0}) {
        // Independent: midpoint rule in mu with the s/p Fresnel, 200000 nodes.
        const int n = 200000;
        double re = 0, ri = 0;
        for (int k = 0; k < n; ++k) {
            double mu = (k + 0.5) / n;
            re += fresnel_sp(mu, ni) * 2 * mu / n;
            ri += fresnel_sp(mu, 1 / ni) * 2 * mu / n; /* eq. 9, internal side */
        }
        double p[11] = {0, 0, 0, 0, 0, 0.3, 0, 0, ni, 0.5, 0};
        int o[8] = {0};
        bt_sampler s{1, 2, 0, 0, 0, BT_METHOD_CLOSED};
        bt_sampler q0{1, 2, 0, 0, 0, BT_METHOD_QUADRATURE}, q1 = q0;
        q1.batch = 1;
        CAPTURE(ni);
        CHECK(interfaced_lambertian_sample(p, o, IL_Q_RE, &s) == doctest::Approx(re).epsilon(2e-6));
        CHECK(interfaced_lambertian_sample(p, o, IL_Q_RI, &s) == doctest::Approx(ri).epsilon(2e-6));
        double rei = interfaced_lambertian_sample(p, o, IL_Q_RE_INTEGRAL, &q0);
        double rii = interfaced_lambertian_sample(p, o, IL_Q_RI_INTEGRAL, &q0);
        CHECK(rei == doctest::Approx(re).epsilon(2e-6));
        CHECK(rii == doctest::Approx(ri).epsilon(2e-6));
        // The coarse rule is close too (its distance is the reported error).
        CHECK(std::fabs(interfaced_lambertian_sample(p, o, IL_Q_RI_INTEGRAL, &q1) - rii) < 1e-4);
        // ni^2 (1 - r_i) = 1 - r_e, independently of eq. 10.
        CHECK(ni * ni * (1 - ri) == doctest::Approx(1 - re).epsilon(1e-5));
        // Sampling weights (§4.1).
        CHECK(interfaced_lambertian_sample(p, o, IL_Q_RS, &s) == doctest::Approx(re).epsilon(2e-6));
        CHECK(interfaced_lambertian_sample(p, o, IL_Q_RB, &s) ==
              doctest::Approx((1 - re) * (1 - re) * 0.5 / (ni * ni * (1 - 0.5 * ri))).epsilon(1e-5));
    }
    double p[11] = {0, 0, 0, 0, 0, 0.3, 0, 0, 1.5, 0.5, 0};
    int o[8] = {0};
    bt_sampler s{1, 2, 0, 0, 0, BT_METHOD_CLOSED};
    CHECK(interfaced_lambertian_sample(p, o, IL_Q_RE, &s) == doctest::Approx(0.0918).epsilon(1e-3));
    p[8] = 1.0;
    CHECK(interfaced_lambertian_sample(p, o, IL_Q_RE, &s) == 0.0);
    CHECK(interfaced_lambertian_sample(p, o, IL_Q_RI, &s) == 0.0);
}

TEST_CASE("body integral vs brute-force quadrature of eq. 12 (all pairs, both samplings)")
{
    struct Case {
        int dist;
        double sigma_deg, alpha, ax, ay, ni, ti, pi_, to, po;
    };
    const Case cases[] = {
        {GAUSS_TS, 20, 0, 0, 0, 1.5, 30, 0, 50, 120},
        {GAUSS_TS, 35, 0, 0, 0, 2.2, 70, 0, 20, 10},
        {BECK_TS, 0, 0.4, 0, 0, 1.5, 60, 0, 45, 180},
        {BECK_SMITH, 0, 0.4, 0, 0, 1.5, 10, 0, 75, 30},
        {BECK_SMITH, 0, 0, 0.2, 0.6, 1.33, 50, 20, 40, 250},
        {GGX_SMITH, 0, 0.3, 0, 0, 1.5, 40, 0, 60, 90},
        {GGX_SMITH, 0, 0, 0.5, 0.15, 3.0, 80, 45, 30, 200},
    };
    for (const Case& c : cases) {
        Surf s{c.dist, c.sigma_deg * kDeg, c.ax > 0 ? c.ax : c.alpha, c.ay > 0 ? c.ay : c.alpha, 0};
        if (c.dist == GAUSS_TS) s.C = gauss_norm(s.sigma);
        V i = sph(c.ti * kDeg, c.pi_ * kDeg), o = sph(c.to * kDeg, c.po * kDeg);
        double ref = body_quadrature(s, i, o, c.ni);
        Pt pt(c.ti, c.pi_, c.to, c.po, c.sigma_deg, c.alpha, c.ni, 1, 0, c.ax, c.ay);
        for (int sampling = 0; sampling < 2; ++sampling) {
            int opt[8] = {c.dist, sampling, 0};
            Stat e = est(pt.p, opt, IL_Q_BODY, 8192, 8, 11);
            CAPTURE(c.dist);
            CAPTURE(sampling);
            CAPTURE(ref);
            CAPTURE(e.mean);
            CAPTURE(e.se);
            // Midpoint error measured < 2e-4 relative (halving the grid).
            CHECK(std::fabs(e.mean - ref) < 5 * e.se + 5e-4 * ref);
            CHECK(e.se < 0.01 * ref);
        }
        // brdf = prefactor * body + specular (eq. 11), the specular term from
        // the oracles: F D G / (4 |i.n||o.n|).
        V h{i.x + o.x, i.y + o.y, i.z + o.z};
        double hl = std::sqrt(dot(h, h));
        h = {h.x / hl, h.y / hl, h.z / hl};
        double fs = fresnel_sp(dot(i, h), c.ni) * D(s, h) * G(s, i, o, h) / (4 * i.z * o.z);
        bt_sampler cs{1, 2, 0, 0, 0, BT_METHOD_CLOSED};
        int opt[8] = {c.dist, 0, 0};
        double spec = interfaced_lambertian_sample(pt.p, opt, IL_Q_SPECULAR, &cs);
        CHECK(spec == doctest::Approx(fs).epsilon(1e-6));
        double kd = 0.7;
        pt.p[9] = kd;
        double ri = 1 - (1 - [&] {
                        double re = 0;
                        for (int k = 0; k < 100000; ++k) {
                            double mu = (k + 0.5) / 100000;
                            re += fresnel_sp(mu, c.ni) * 2 * mu / 100000;
                        }
                        return re;
                    }()) / (c.ni * c.ni);
        Stat b = est(pt.p, opt, IL_Q_BRDF, 4096, 8, 11);
        double want = kd / (kPi * c.ni * c.ni * (1 - ri * kd)) * ref + fs;
        CHECK(std::fabs(b.mean - want) < 5 * b.se + 5e-4 * want);
    }
}

TEST_CASE("limits: sigma -> 0 is the flat interfaced Lambertian; ni = 1 is Oren-Nayar's direct term")
{
    // Flat: the body integral tends to T(i) T(o) (eq. 8 on one facet n).
    for (int dist = 0; dist < 4; ++dist)
        for (double ni : {1.0, 1.5, 3.0})
            for (double ti : {0.0, 45.0, 85.0}) {
                Pt pt(ti, 0, 60, 140, 0.01, 1e-4, ni);
                int opt[8] = {dist, 0, 0};
                Stat e = est(pt.p, opt, IL_Q_BODY, 256, 4);
                double want = (1 - fresnel_sp(std::cos(ti * kDeg), ni)) *
                              (1 - fresnel_sp(std::cos(60 * kDeg), ni));
                CAPTURE(dist);
                CAPTURE(ni);
                CAPTURE(ti);
                CHECK(e.mean == doctest::Approx(want).epsilon(2e-3));
            }
    // ni = 1, Gaussian + TS: body * rho/pi = Oren-Nayar direct term (rho/pi) * d1.
    struct G3 {
        double sigma, ti, to, pd;
    };
    for (G3 g : {G3{10, 30, 40, 0}, G3{30, 75, 75, 0}, G3{30, 60, 20, 180}, G3{45, 80, 50, 90}}) {
        V s = sph(g.ti * kDeg, 0), v = sph(g.to * kDeg, g.pd * kDeg);
        double d1, d2;
        oren_nayar_terms(g.sigma * kDeg, s, v, &d1, &d2);
        Pt pt(g.ti, 0, g.to, g.pd, g.sigma, 0.3, 1.0);
        int opt[8] = {GAUSS_TS, 1, 0};
        Stat e = est(pt.p, opt, IL_Q_BODY, 8192, 8);
        CAPTURE(g.sigma);
        CAPTURE(g.ti);
        CHECK(std::fabs(e.mean - d1) < 5 * e.se + 5e-4 * d1);
    }
}

TEST_CASE("symmetries: reciprocity, isotropy, anisotropic axis swap")
{
    for (int dist = 0; dist < 4; ++dist) {
        int opt[8] = {dist, 0, 0};
        // Reciprocity.
        Pt a(25, 10, 65, 200, 25, 0.35, 1.5), b(65, 200, 25, 10, 25, 0.35, 1.5);
        Stat ea = est(a.p, opt, IL_Q_BODY, 4096, 8, 3), eb = est(b.p, opt, IL_Q_BODY, 4096, 8, 4);
        CAPTURE(dist);
        CHECK(std::fabs(ea.mean - eb.mean) < 5 * std::hypot(ea.se, eb.se));
        // Isotropy: only phi_o - phi_i matters.
        Pt c(25, 10 + 77, 65, 200 + 77, 25, 0.35, 1.5);
        Stat ec = est(c.p, opt, IL_Q_BODY, 4096, 8, 5);
        CHECK(std::fabs(ea.mean - ec.mean) < 5 * std::hypot(ea.se, ec.se));
        if (dist == GAUSS_TS) continue;
        // alpha_x = alpha_y equals the isotropic alpha; swapping the axes
        // equals rotating both azimuths by 90 degrees.
        Pt d(25, 10, 65, 200, 0, 0.9, 1.5, 1, 0, 0.35, 0.35);
        Stat ed = est(d.p, opt, IL_Q_BODY, 4096, 8, 6);
        CHECK(std::fabs(ea.mean - ed.mean) < 5 * std::hypot(ea.se, ed.se));
        Pt e(25, 10, 65, 200, 0, 0.9, 1.5, 1, 0, 0.15, 0.5);
        Pt f(25, 100, 65, 290, 0, 0.9, 1.5, 1, 0, 0.5, 0.15);
        Stat ee = est(e.p, opt, IL_Q_BODY, 4096, 8, 7), ef = est(f.p, opt, IL_Q_BODY, 4096, 8, 8);
        CHECK(std::fabs(ee.mean - ef.mean) < 5 * std::hypot(ee.se, ef.se));
        CHECK(std::fabs(ee.mean - ea.mean) > 5 * std::hypot(ee.se, ea.se));  // anisotropy shows
    }
}

TEST_CASE("energy: body + specular albedo with Kd = 1")
{
    for (int dist = 0; dist < 4; ++dist)
        for (double ni : {1.0, 1.5, 2.5})
            for (double ti : {0.0, 50.0, 85.0}) {
                int opt[8] = {dist, 0, 0};
                CAPTURE(dist);
                CAPTURE(ni);
                CAPTURE(ti);
                // Flat: T(i) + F(i) = 1 exactly.
                Pt flat(ti, 0, 0, 0, 0.01, 1e-4, ni, 1.0);
                Stat b = est(flat.p, opt, IL_Q_ALBEDO_BODY, 1024, 4);
                Stat s = est(flat.p, opt, IL_Q_ALBEDO_SPECULAR, 1024, 4);
                CHECK(b.mean + s.mean == doctest::Approx(1.0).epsilon(3e-3));
                CHECK(s.mean == doctest::Approx(fresnel_sp(std::cos(ti * kDeg), ni)).epsilon(3e-3));
                // Rough: <= 1 (single scattering loses energy, never gains).
                for (double r : {0.3, 1.0}) {
                    Pt rough(ti, 0, 0, 0, r * 40, r, ni, 1.0);
                    for (int sampling = 0; sampling < 2; ++sampling) {
                        opt[1] = sampling;
                        Stat rb = est(rough.p, opt, IL_Q_ALBEDO_BODY, 2048, 8);
                        Stat rs = est(rough.p, opt, IL_Q_ALBEDO_SPECULAR, 2048, 8);
                        CHECK(rb.mean + rs.mean < 1 + 3 * std::hypot(rb.se, rs.se));
                    }
                    opt[1] = 0;
                }
            }
    // albedo_body = prefactor * int body(i,o) cos dw_o: outgoing directions
    // drawn here (cosine), one body sample each.
    for (int dist = 0; dist < 4; ++dist) {
        int opt[8] = {dist, 0, 0};
        const double ni = 1.5, kd = 0.6, ti = 55;
        Pt a(ti, 30, 0, 0, 30, 0.5, ni, kd);
        Stat ea = est(a.p, opt, IL_Q_ALBEDO_BODY, 4096, 8);
        brdftab::test::RunningStat paths;
        const int n = 200000;
        for (int k = 0; k < n; ++k) {
            bt_sampler sm{7, 8, 99, 0, (uint)k, BT_METHOD_MC};
            double u = bt_uniform(&sm, 20), v = bt_uniform(&sm, 21);
            double to = std::acos(std::sqrt(1 - u)) / kDeg, po = 360 * v;
            Pt b(ti, 30, to, po, 30, 0.5, ni, kd);
            double x = kPi * interfaced_lambertian_sample(b.p, opt, IL_Q_BODY, &sm);
            paths.add(x);
        }
        const double mean = paths.mean, se = paths.se();
        double re = 0;
        for (int k = 0; k < 100000; ++k) {
            double mu = (k + 0.5) / 100000;
            re += fresnel_sp(mu, ni) * 2 * mu / 100000;
        }
        double ri = 1 - (1 - re) / (ni * ni);
        double pref = kd / (kPi * ni * ni * (1 - ri * kd));
        CAPTURE(dist);
        CHECK(std::fabs(ea.mean - pref * mean) < 5 * std::hypot(ea.se, pref * se));
    }
}

TEST_CASE("V-cavity: order 1 = TS body, ni = 1 order 2 = Oren-Nayar L2, energy, order sums")
{
    // Order 1 = prefactor * body with the TS GAF.
    for (int dist : {GAUSS_TS, BECK_TS})
        for (double ni : {1.0, 1.5}) {
            Pt p(40, 0, 60, 150, 25, 0.45, ni, 0.8, 1);
            int opt[8] = {dist, 1, 0};
            Stat v = est(p.p, opt, IL_Q_VCAVITY, 8192, 8, 21);
            Surf s{dist, 25 * kDeg, 0.45, 0.45, dist == GAUSS_TS ? gauss_norm(25 * kDeg) : 0};
            double ref = body_quadrature(s, sph(40 * kDeg, 0), sph(60 * kDeg, 150 * kDeg), ni);
            double re = 0;
            for (int k = 0; k < 100000; ++k) {
                double mu = (k + 0.5) / 100000;
                re += fresnel_sp(mu, ni) * 2 * mu / 100000;
            }
            double ri = 1 - (1 - re) / (ni * ni);
            ref *= 0.8 / (kPi * ni * ni * (1 - ri * 0.8));
            CAPTURE(dist);
            CAPTURE(ni);
            CHECK(std::fabs(v.mean - ref) < 5 * v.se + 5e-4 * ref);
        }
    // ni = 1, Kd = 1, Gaussian: order 2 = Oren-Nayar's L2 / (E0 cos theta_i).
    struct G3 {
        double sigma, ti, to, pd;
    };
    for (G3 g : {G3{30, 60, 60, 0}, G3{30, 75, 30, 180}, G3{45, 40, 70, 90}, G3{20, 20, 10, 45}}) {
        V s = sph(g.ti * kDeg, 0), v = sph(g.to * kDeg, g.pd * kDeg);
        double d1, d2;
        oren_nayar_terms(g.sigma * kDeg, s, v, &d1, &d2);
        Pt p(g.ti, 0, g.to, g.pd, g.sigma, 0.3, 1.0, 1.0, 2);
        int opt[8] = {GAUSS_TS, 1, 0};
        Stat e = est(p.p, opt, IL_Q_VCAVITY, 16384, 8, 22);
        CAPTURE(g.sigma);
        CAPTURE(g.ti);
        CAPTURE(g.to);
        CAPTURE(g.pd);
        CAPTURE(d2);
        CHECK(std::fabs(e.mean - d2) < 5 * e.se + 1e-3 * d2);
        // Order 1 likewise equals the direct term (rho/pi) d1.
        p.p[10] = 1;
        Stat e1 = est(p.p, opt, IL_Q_VCAVITY, 8192, 8, 23);
        CHECK(std::fabs(e1.mean - d1 / kPi) < 5 * e1.se + 5e-4 * d1 / kPi);
    }
    // Energy: ni = 1, Kd = 1 V-cavities lose nothing, so the all-order albedo
    // is 1.  The cut-off at 128 bounces loses < 1e-3 (measured with 2e6 paths:
    // Gaussian sigma = 40 deg, 64 bounces 0.9987 +- 0.001, 2000 bounces 1.0001 +- 0.001).
    for (int dist = 0; dist < 4; ++dist)
        for (double ti : {dist % 2 ? 0.0 : 60.0, 85.0}) {
            int opt[8] = {dist, 0, 0};
            brdftab::test::RunningStat paths;
            const int n = 40000;
            for (int k = 0; k < n; ++k) {
                bt_sampler sm{3, 4, 77, 0, (uint)k, BT_METHOD_MC};
                double u = bt_uniform(&sm, 300), w = bt_uniform(&sm, 301);
                double to = std::acos(std::sqrt(1 - u)) / kDeg;
                Pt p(ti, 0, to, 360 * w, 40, 0.8, 1.0, 1.0, 0);
                double x = kPi * interfaced_lambertian_sample(p.p, opt, IL_Q_VCAVITY, &sm);
                paths.add(x);
            }
            const double mean = paths.mean, se = paths.se();
            CAPTURE(dist);
            CAPTURE(ti);
            CAPTURE(se);
            CHECK(std::fabs(mean - 1) < 4 * se + 2e-3);
        }
    // ni = 1.5, Kd = 1: each facet conserves energy (body albedo T, specular
    // F), so the V-cavity body paths (with body -> specular -> o) plus the
    // single specular bounce must stay <= 1; the rest is paths with several
    // specular hits, which neither quantity counts.  Dropping specular light
    // inside the groove (interreflection = body) can only lose more.
    for (double ti : {0.0, 60.0}) {
        double alb[2];
        for (int mode = 0; mode < 2; ++mode) {
            int opt[8] = {BECK_TS, 1, mode};
            brdftab::test::RunningStat paths;
            const int n = 40000;
            for (int k = 0; k < n; ++k) {
                bt_sampler sm{3, 4, 78, 0, (uint)k, BT_METHOD_MC};
                double u = bt_uniform(&sm, 3000), w = bt_uniform(&sm, 3001);
                Pt p(ti, 0, std::acos(std::sqrt(1 - u)) / kDeg, 360 * w, 0, 0.8, 1.5, 1.0, 0);
                double x = kPi * interfaced_lambertian_sample(p.p, opt, IL_Q_VCAVITY, &sm);
                paths.add(x);
            }
            const double mean = paths.mean, se = paths.se();
            Pt p(ti, 0, 0, 0, 0, 0.8, 1.5, 1.0, 0);  // (n = 40000 paths above)
            Stat spec = est(p.p, opt, IL_Q_ALBEDO_SPECULAR, 4096, 8);
            alb[mode] = mean + spec.mean;
            CAPTURE(ti);
            CAPTURE(mode);
            CHECK(alb[mode] < 1 + 3 * std::hypot(se, spec.se));
        }
        CHECK(alb[0] > alb[1]);
    }
    // Order 0 sample = sum of the order-k samples (same random numbers), and
    // ni = 1 order k scales as Kd^k.
    for (int mode = 0; mode < 2; ++mode)
        for (int k = 0; k < 100; ++k) {
            int opt[8] = {BECK_SMITH, 0, mode};
            bt_sampler sm{5, 6, 1, 0, (uint)k, BT_METHOD_MC};
            Pt p(70, 0, 50, 20, 0, 0.9, 1.4, 0.9, 0);
            double all = interfaced_lambertian_sample(p.p, opt, IL_Q_VCAVITY, &sm), parts = 0;
            for (int ord = 1; ord <= IL_MAX_BOUNCES; ++ord) {
                p.p[10] = ord;
                parts += interfaced_lambertian_sample(p.p, opt, IL_Q_VCAVITY, &sm);
            }
            CHECK(all == doctest::Approx(parts).epsilon(1e-12));
        }
    for (int ord = 1; ord <= 4; ++ord) {
        int opt[8] = {GAUSS_TS, 0, 0};
        Pt a(50, 0, 50, 0, 40, 0.3, 1.0, 1.0, ord), b(50, 0, 50, 0, 40, 0.3, 1.0, 0.5, ord);
        Stat ea = est(a.p, opt, IL_Q_VCAVITY, 512, 4), eb = est(b.p, opt, IL_Q_VCAVITY, 512, 4);
        CHECK(eb.mean == doctest::Approx(ea.mean * std::pow(0.5, ord)).epsilon(1e-12));
    }
}

TEST_CASE("vcavity's two stages compose to its sample function (host build)") {
    // The staged sample-parallel launch (kernels/common/estimator.h, "Staged
    // samples") runs interfaced_lambertian_stage, stores its values, and
    // runs interfaced_lambertian_rest on them: together they must give
    // interfaced_lambertian_sample's bits for every option, order (the
    // negative one included), direction (below the horizon included) and
    // sample.
    std::size_t nonzero = 0, checked = 0;
    for (int dist : {GAUSS_TS, BECK_TS, BECK_SMITH, GGX_SMITH})
        for (int sampling : {IL_SAMPLING_VISIBLE, IL_SAMPLING_DISTRIBUTION})
            for (int mode : {IL_INTERREFLECTION_FULL, IL_INTERREFLECTION_BODY})
                for (double order : {-1.0, 0.0, 1.0, 3.0})
                    for (double ti : {0.0, 40.0, 89.5, 95.0})
                        for (double to : {10.0, 75.0, 100.0}) {
                            double p[16] = {0};
                            p[0] = ti * kDeg;
                            p[1] = 0.3;
                            p[2] = to * kDeg;
                            p[3] = 0.3 + 2.2;
                            p[IL_PARAM_SIGMA] = 0.4;
                            p[IL_PARAM_ALPHA] = 0.5;
                            p[IL_PARAM_NI] = 1.5;
                            p[IL_PARAM_KD] = 0.8;
                            p[IL_PARAM_ORDER] = order;
                            const int o[8] = {dist, sampling, mode};
                            for (unsigned k = 0; k < 16; ++k) {
                                bt_sampler smp{};
                                smp.key0 = 7;
                                smp.key1 = 9;
                                smp.method = k % 2 ? BT_METHOD_RQMC : BT_METHOD_MC;
                                smp.cell = 3;
                                smp.sample = k;
                                const double direct = interfaced_lambertian_sample(p, o, IL_Q_VCAVITY, &smp);
                                double st[IL_VCAVITY_STAGE];
                                interfaced_lambertian_stage(p, o, IL_Q_VCAVITY, &smp, st);
                                const double staged = interfaced_lambertian_rest(p, o, IL_Q_VCAVITY, &smp, st);
                                CAPTURE(dist);
                                CAPTURE(sampling);
                                CAPTURE(mode);
                                CAPTURE(order);
                                CAPTURE(ti);
                                CAPTURE(to);
                                CAPTURE(k);
                                CHECK(std::memcmp(&direct, &staged, sizeof direct) == 0);
                                nonzero += direct != 0.0 ? 1 : 0;
                                ++checked;
                            }
                        }
    // A quarter of the cases are order -1, more than half of the rest have
    // a direction below the horizon: 22 % of values are non-zero (measured).
    CHECK(nonzero > checked / 8);  // the walks do reach o
}

TEST_CASE("no NaN/Inf at grazing angles, ni in [1, 4], roughness ~0 to 1")
{
    for (int dist = 0; dist < 4; ++dist)
        for (int sampling = 0; sampling < 2; ++sampling)
            for (double ni : {1.0, 1.000001, 1.5, 3.0, 4.0})
                for (double r : {1e-7, 0.01, 0.5, 1.0})
                    for (double ti : {0.0, 89.9999, 90.0})
                        for (double to : {0.0, 90.0}) {
                            Pt p(ti, 0, to, 180, r * 57, r, ni, 1.0, 0);
                            int opt[8] = {dist, sampling, 0};
                            for (int q = 0; q <= IL_Q_VCAVITY; ++q)
                                for (int k = 0; k < 16; ++k) {
                                    bt_sampler sm{1, 1, 0, (uint)(k % 2), (uint)k,
                                                  q >= IL_Q_RE && q <= IL_Q_RB
                                                      ? (q == IL_Q_RE_INTEGRAL || q == IL_Q_RI_INTEGRAL
                                                             ? BT_METHOD_QUADRATURE
                                                             : BT_METHOD_CLOSED)
                                                      : BT_METHOD_RQMC};
                                    double x = interfaced_lambertian_sample(p.p, opt, q, &sm);
                                    CAPTURE(dist);
                                    CAPTURE(ni);
                                    CAPTURE(r);
                                    CAPTURE(ti);
                                    CAPTURE(to);
                                    CAPTURE(q);
                                    REQUIRE(std::isfinite(x));
                                    REQUIRE(x >= 0);
                                }
                        }
    // Below the surface: opaque, 0.
    Pt below(120, 0, 30, 0, 20, 0.3, 1.5);
    int opt[8] = {0, 0, 0};
    bt_sampler sm{1, 1, 0, 0, 0, BT_METHOD_RQMC};
    CHECK(interfaced_lambertian_sample(below.p, opt, IL_Q_BODY, &sm) == 0.0);
}

TEST_CASE("OpenCL device agrees with the host reference (double and float)")
{
    using namespace brdftab;
    const ModelInfo& model = find_model("interfaced-lambertian");
    auto dev = make_backend("", Precision::Double);
    auto devf = make_backend("", Precision::Float);
    auto host = make_backend("host", Precision::Double);
    std::vector<std::map<std::string, double>> pts = {
        {{"theta_i", 30}, {"theta_o", 50}, {"phi_d", 120}, {"sigma", 20}, {"alpha", 0.3}, {"ni", 1.5}},
        {{"theta_i", 85}, {"theta_o", 10}, {"phi_d", 0}, {"sigma", 40}, {"alpha", 0.8}, {"ni", 1.1}},
        {{"theta_i", 0}, {"theta_o", 89}, {"phi_d", 200}, {"sigma", 5}, {"alpha", 0.05}, {"ni", 3}},
        {{"theta_i", 60}, {"theta_o", 60}, {"phi_d", 180}, {"sigma", 30}, {"alpha_x", 0.2},
         {"alpha_y", 0.6}, {"ni", 1.0}, {"order", 2}},
    };
    for (const char* quantity : {"body", "brdf", "specular", "re", "ri_integral", "albedo_body",
                                 "albedo_specular", "vcavity"})
        for (const char* dist : {"gaussian-ts", "beckmann-ts", "beckmann-smith", "ggx-smith"}) {
            const QuantityInfo& q = model.quantity(quantity);
            PointBuilder builder(model, q);
            auto opts = resolve_options(model, {{"distribution", dist}}, "test");
            IntegrationSettings s;
            s.samples = 1024;
            auto pf = [&](std::size_t c, double* out) { builder.build(pts[c], out); };
            auto a = estimate(*dev, model, q, opts, pts.size(), pf, s);
            auto b = estimate(*host, model, q, opts, pts.size(), pf, s);
            auto f = estimate(*devf, model, q, opts, pts.size(), pf, s);
            for (std::size_t k = 0; k < pts.size(); ++k) {
                const std::string qn = quantity, dn = dist;
                CAPTURE(qn);
                CAPTURE(dn);
                CAPTURE(k);
                REQUIRE(std::isfinite(a.value[k]));
                // PoCL contracts into FMA: last bits differ.
                CHECK(a.value[k] == doctest::Approx(b.value[k]).epsilon(1e-8));
                REQUIRE(std::isfinite(f.value[k]));
                // Float: the same estimator in single precision.
                CHECK(std::fabs(f.value[k] - b.value[k]) <=
                      1e-3 * std::fabs(b.value[k]) + 5 * b.stderr_[k] + 1e-6);
            }
        }
}

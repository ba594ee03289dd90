// test_oren_nayar.cpp — kernels/models/oren_nayar.h (compiled as C++) and its
// OpenCL build through the engine.  Oracles:
//  - eq. 19 (IF closed form) vs an independent 2-D Gauss-Legendre quadrature
//    of the kernel K' of eq. 14 written here (Duffy split at the singular
//    corner);
//  - the Gaussian integral (eq. 25) vs a brute-force midpoint rule written
//    here from the paper's angle forms (Table 1 right column, GAF of eq. 37 in
//    projected angles, IF of eq. 19 via eqs. 15-16) — a different formulation
//    and a different quadrature;
//  - the paper's closed form eq. 45 (exact in and perpendicular to the plane
//    of incidence) vs the numerical eq. 23;
//  - limits (sigma -> 0: rho/pi; albedo -> rho), reciprocity, albedo <= 1,
//    the paper's statements (functional approximation within a few percent at
//    sigma = 30, rho = 0.9, theta_i = 75; backward cut-off at theta_o = theta_i);
//  - sampling estimator (RQMC) vs quadrature, device vs host, float sanity,
//    no NaN/Inf up to 89.9 deg.
#include <doctest/doctest.h>

#include <cmath>
#include <map>
#include <random>
#include <vector>

#include "host/engine/engine.h"
#include "host/models/registry.h"
#include "kernels/models/oren_nayar.h"
#include "test_support.h"

using namespace brdftab;

namespace {

using brdftab::test::kPi;
using brdftab::test::kDeg;

bt_sampler quad_sampler(uint batch = 0)
{
    bt_sampler s;
    s.key0 = 1;
    s.key1 = 2;
    s.cell = 0;
    s.batch = batch;
    s.sample = 0;
    s.method = BT_METHOD_QUADRATURE;
    return s;
}

// Point in kernel units: degrees in, radians out.
std::vector<double> point(double ti, double to, double pd, double sigma, double rho = 1,
                          double nodes = 16, double theta_a = 20, double phi_a = 0)
{
    return {ti * kDeg, 0, to * kDeg, pd * kDeg, sigma * kDeg, rho, theta_a * kDeg,
            phi_a * kDeg, nodes};
}

double quad(int q, const std::vector<double>& p, const int* o = nullptr)
{
    int opts[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    bt_sampler s = quad_sampler();
    return oren_nayar_sample(p.data(), o ? o : opts, q, &s);
}

// Gauss-Legendre on [a, b] (independent of the kernel's: Golub-Welsch is
// overkill, Newton from the same asymptotic guess is standard; computed in
// long double here).
void gl(int n, double a, double b, std::vector<double>& x, std::vector<double>& w)
{
    x.resize(n);
    w.resize(n);
    for (int i = 0; i < n; ++i) {
        long double z = std::cos(kPi * (i + 0.75L) / (n + 0.5L)), pp = 1;
        for (int it = 0; it < 100; ++it) {
            long double p1 = 1, p2 = 0;
            for (int j = 1; j <= n; ++j) {
                long double p3 = p2;
                p2 = p1;
                p1 = ((2 * j - 1) * z * p2 - (j - 1) * p3) / j;
            }
            pp = n * (z * p1 - p2) / (z * z - 1);
            long double dz = p1 / pp;
            z -= dz;
            if (std::fabs((double)dz) < 1e-18) break;
        }
        x[i] = (double)(0.5L * (a + b) + 0.5L * (b - a) * z);
        w[i] = (double)((b - a) / ((1 - z * z) * pp * pp));
    }
}

// eq. 14
double kernel_k(double x, double y, double ta)
{
    double s2 = std::sin(2 * ta);
    double r2 = x * x + 2 * x * y * std::cos(2 * ta) + y * y;
    return kPi * s2 * s2 / 2 * x * y / (r2 * std::sqrt(r2));
}

// int_{mv}^1 int_{ms}^1 K'(t, r) dr dt.  K' is homogeneous of degree -1 and
// singular only at (0, 0): when mv = ms = 0 split the square along the
// diagonal and use r = t u (resp. t = r u), whose Jacobian cancels it.
double if_brute(double mv, double ms, double ta)
{
    std::vector<double> x, w, u, wu;
    double sum = 0;
    if (mv == 0 && ms == 0) {
        gl(60, 0, 1, x, w);
        gl(60, 0, 1, u, wu);
        for (int i = 0; i < 60; ++i)
            for (int j = 0; j < 60; ++j)  // two triangles, symmetric kernel
                sum += 2 * w[i] * wu[j] * x[i] * kernel_k(x[i], x[i] * u[j], ta);
        return sum;
    }
    std::vector<double> y, wy;
    gl(80, mv, 1, x, w);
    gl(80, ms, 1, y, wy);
    for (int i = 0; i < 80; ++i)
        for (int j = 0; j < 80; ++j) sum += w[i] * wy[j] * kernel_k(x[i], y[j], ta);
    return sum;
}

// Brute-force facet integrand from the paper's angle forms.  Per unit rho /
// rho^2, divided by E0 cos theta_i.  Light at phi_i = 0.
struct Angles {
    double ti, tr, pr;
};
double gaf_eq37(double t, double p, double ta, double pa)
{
    // 2 cos t cos ta / (cos t cos ta + sin t sin ta cos(p - pa)), eq. 37
    return 2 * std::cos(t) * std::cos(ta) /
           (std::cos(t) * std::cos(ta) + std::sin(t) * std::sin(ta) * std::cos(p - pa));
}
void facet_brute(const Angles& g, double ta, double pa, double& f1, double& f2)
{
    f1 = f2 = 0;
    double cti = std::cos(g.ti), ctr = std::cos(g.tr), ca = std::cos(ta);
    double ka = std::tan(ta);
    // cos-weighted dot products in Table 1's factored form
    double si = cti * ca * (1 + std::tan(g.ti) * ka * std::cos(0 - pa));      // <s,a>
    double vr = ctr * ca * (1 + std::tan(g.tr) * ka * std::cos(g.pr - pa));   // <v,a>
    double si2 = cti * ca * (1 - std::tan(g.ti) * ka * std::cos(0 - pa));     // <s,a'>
    double vr2 = ctr * ca * (1 - std::tan(g.tr) * ka * std::cos(g.pr - pa));  // <v,a'>
    if (si > 0 && vr > 0) {
        double gaf = std::max(0.0, std::min({1.0, gaf_eq37(g.ti, 0, ta, pa),
                                             gaf_eq37(g.tr, g.pr, ta, pa)}));
        f1 = si * vr / (ca * ctr) * gaf / kPi / cti;  // eq. 10 x GAF
    }
    if (vr > 0 && si2 > 0) {
        double mv = std::min(1.0, std::max(0.0, -vr2 / vr));  // eq. 15
        double ms = std::min(1.0, std::max(0.0, -si / si2));  // eq. 16
        auto d = [&](double x, double y) {
            return std::sqrt(x * x + 2 * x * y * std::cos(2 * ta) + y * y);
        };
        double itf = kPi / 2 * (d(1, mv) + d(1, ms) - d(ms, mv) - d(1, 1));  // eq. 19
        f2 = si2 * vr / (ca * ctr) * itf / (kPi * kPi) / cti;  // eq. 18
    }
}
// Midpoint rule in (theta_a, phi_a) over the truncated Gaussian, eqs. 25-26.
void gaussian_brute(const Angles& g, double sigma, int nt, int np, double& d, double& i2)
{
    double z = 0, s1 = 0, s2 = 0;
    for (int a = 0; a < nt; ++a) {
        double ta = (a + 0.5) * (kPi / 2) / nt;
        double wt = std::exp(-ta * ta / (2 * sigma * sigma)) * std::sin(ta);
        double r1 = 0, r2 = 0;
        for (int b = 0; b < np; ++b) {
            double pa = (b + 0.5) * 2 * kPi / np;
            double f1, f2;
            facet_brute(g, ta, pa, f1, f2);
            r1 += f1;
            r2 += f2;
        }
        z += wt;
        s1 += wt * r1 / np;
        s2 += wt * r2 / np;
    }
    d = s1 / z;
    i2 = s2 / z;
}

}  // namespace

TEST_CASE("eq. 19: IF closed form equals 2-D quadrature of the kernel eq. 14")
{
    const double cases[][3] = {{0.3, 0.2, 0.5}, {1.0, 0.1, 0.7}, {0.7, 0.0, 0.0},
                               {1.2, 0.5, 0.05}, {0.05, 0.3, 0.3}, {1.45, 0.9, 0.6},
                               {0.9, 0.0, 0.0}, {0.5, 0.99, 0.01}};
    for (const auto& c : cases) {
        double ta = c[0], mv = c[1], ms = c[2];
        double closed = on_if(mv, ms, std::cos(2 * ta));
        double brute = if_brute(mv, ms, ta);
        CAPTURE(ta);
        CAPTURE(mv);
        CAPTURE(ms);
        CHECK(closed == doctest::Approx(brute).epsilon(1e-9));
    }
}

TEST_CASE("sigma -> 0 gives Lambert: rho/pi, no interreflection")
{
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(0, 1);
    for (int k = 0; k < 20; ++k) {
        double ti = 89 * u(rng), to = 89 * u(rng), pd = 360 * u(rng);
        // exactly 0 (special case) and a tiny sigma through the quadrature
        for (double sigma : {0.0, 0.02}) {
            auto p = point(ti, to, pd, sigma, 0.7, 12);
            CHECK(quad(ON_Q_BRDF_DIRECT, p) == doctest::Approx(1 / kPi).epsilon(1e-6));
            CHECK(std::fabs(quad(ON_Q_BRDF_INTER, p)) < 1e-6);  // O(sigma^2)
            CHECK(quad(ON_Q_BRDF, p) == doctest::Approx(0.7 / kPi).epsilon(1e-6));
        }
    }
}

TEST_CASE("Gaussian integral: quadrature agrees with an independent brute-force rule")
{
    // Midpoint rule 400 x 800 on the paper's angle forms: accurate to ~1e-5
    // relative (first-order kinks), so 2e-4 leaves room but catches any
    // modelling or breakpoint error.
    const double cases[][4] = {{75, 30, 0, 30},  {75, 60, 180, 30}, {40, 70, 90, 20},
                               {10, 80, 135, 45}, {60, 60, 20, 60}, {85, 85, 0, 15}};
    for (const auto& c : cases) {
        Angles g{c[0] * kDeg, c[1] * kDeg, c[2] * kDeg};
        double bd, bi;
        gaussian_brute(g, c[3] * kDeg, 400, 800, bd, bi);
        auto p = point(c[0], c[1], c[2], c[3], 1, 16);
        CAPTURE(c[0]);
        CAPTURE(c[1]);
        CAPTURE(c[2]);
        CAPTURE(c[3]);
        CHECK(quad(ON_Q_BRDF_DIRECT, p) == doctest::Approx(bd).epsilon(2e-4));
        CHECK(quad(ON_Q_BRDF_INTER, p) == doctest::Approx(bi).epsilon(5e-4));
    }
}

TEST_CASE("single slope: numerical eq. 23 equals the closed form eq. 45 in and across the plane")
{
    // Eqs. 40-43 are exact integrals; eq. 44 interpolates only at other azimuths.
    for (double ta : {10.0, 30.0, 50.0, 70.0})
        for (double ti : {0.0, 20.0, 50.0, 80.0})
            for (double to : {5.0, 35.0, 65.0, 85.0})
                for (double pd : {0.0, 90.0, 180.0}) {
                    auto p = point(ti, to, pd, 0, 1, 24, ta);
                    double num = quad(ON_Q_SS_DIRECT, p);
                    double cf = quad(ON_Q_SS_DIRECT_CF, p);
                    CAPTURE(ta);
                    CAPTURE(ti);
                    CAPTURE(to);
                    CAPTURE(pd);
                    CHECK(num == doctest::Approx(cf).epsilon(1e-9));
                }
}

TEST_CASE("single slope: the uni-directional surface averaged over phi_a is the isotropic one")
{
    // eq. 23 / eq. 46 are the phi_a-averages of eq. 22 (midpoint rule here).
    for (double ta : {15.0, 45.0})
        for (double pd : {0.0, 60.0, 180.0}) {
            double rho = 0.8;
            auto p = point(70, 40, pd, 0, rho, 24, ta);
            double iso = rho * quad(ON_Q_SS_DIRECT, p) + rho * rho * quad(ON_Q_SS_INTER, p);
            double sum = 0;
            const int n = 20000;
            for (int k = 0; k < n; ++k) {
                auto q = point(70, 40, pd, 0, rho, 24, ta, 360.0 * (k + 0.5) / n);
                sum += quad(ON_Q_UNI_SLOPE, q);
            }
            CHECK(sum / n == doctest::Approx(iso).epsilon(1e-6));
        }
}

TEST_CASE("reciprocity f(i, o) = f(o, i) over random directions")
{
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(0, 1);
    for (int k = 0; k < 40; ++k) {
        double ti = 89.9 * u(rng), to = 89.9 * u(rng), pd = 360 * u(rng), sg = 60 * u(rng);
        auto a = point(ti, to, pd, sg, 1, 12), b = point(to, ti, -pd, sg, 1, 12);
        CAPTURE(ti);
        CAPTURE(to);
        CAPTURE(pd);
        CAPTURE(sg);
        CHECK(quad(ON_Q_BRDF_DIRECT, a) == doctest::Approx(quad(ON_Q_BRDF_DIRECT, b)).epsilon(1e-7));
        CHECK(quad(ON_Q_BRDF_INTER, a) == doctest::Approx(quad(ON_Q_BRDF_INTER, b)).epsilon(1e-7));
        // anisotropic surface: swap the absolute azimuths too
        auto c = point(to, ti, 0, sg, 1, 12, 35, 70), d = point(ti, to, pd, sg, 1, 12, 35, 70);
        c[1] = pd * kDeg;
        CHECK(quad(ON_Q_UNI_SLOPE, c) == doctest::Approx(quad(ON_Q_UNI_SLOPE, d)).epsilon(1e-9));
    }
}

TEST_CASE("paper: functional approximation within ~3 % in the plane of incidence; cut-off")
{
    // sigma = 30, rho = 0.9, theta_i = 75 (Figs. 8, 12).  Measured: <= 2.1 %
    // backward and <= 3.3 % forward for theta_o <= 70; it grows beyond (6.6 %
    // at 75, 18 % at 85 forward), which the docs report.
    double worst = 0;
    for (double pd : {0.0, 180.0})
        for (double to = 0; to <= 70; to += 2.5) {
            auto p = point(75, to, pd, 30, 0.9, 12);
            double ex = quad(ON_Q_BRDF, p), fa = quad(ON_Q_FUNCTIONAL, p);
            worst = std::max(worst, std::fabs(fa / ex - 1));
        }
    CHECK(worst < 0.035);
    CHECK(worst > 0.005);  // the fit is not the integral
    // Backward cut-off exactly at theta_o = theta_i (Fig. 8): the slope drops
    // there (a kink, for every roughness).  Second differences with h = 0.25
    // deg: O(jump * h) at a kink, O(f'' h^2) where smooth.
    // (Its size needs facets steeper than 90 - theta_i deg, i.e. sigma not
    // much below (90 - theta_i) / 2: at sigma = 10, theta_i = 45 it vanishes.)
    const double combos[][2] = {{45, 30}, {60, 30}, {75, 30}, {75, 10}, {60, 20}, {80, 45}};
    for (const auto& cb : combos) {
            double ti = cb[0], sg = cb[1];
            auto f = [&](double to) { return quad(ON_Q_BRDF, point(ti, to, 0, sg, 0.9, 16)); };
            auto d2 = [&](double to) { return f(to + 0.25) - 2 * f(to) + f(to - 0.25); };
            CAPTURE(ti);
            CAPTURE(sg);
            CHECK(d2(ti) < 0);  // slope decreases
            CHECK(std::fabs(d2(ti)) > 10 * std::fabs(d2(ti - 3)));
            CHECK(std::fabs(d2(ti)) > 10 * std::fabs(d2(ti + 3)));
        }
    // Strongest at the paper's setting: slope falls by > 5x.
    auto f = [](double to) { return quad(ON_Q_BRDF, point(75, to, 0, 30, 0.9, 16)); };
    CHECK(f(75) - f(74) > 5 * std::fabs(f(76) - f(75)));
}

TEST_CASE("no NaN/Inf up to 89.9 deg, sigma 0..60, every quantity")
{
    int opts[8] = {1, 1, 0, 0, 0, 0, 0, 0};
    for (double ti : {0.0, 45.0, 89.0, 89.9, 90.0})
        for (double to : {0.0, 30.0, 89.9, 90.0})
            for (double pd : {0.0, 90.0, 180.0})
                for (double sg : {0.0, 1e-3, 5.0, 30.0, 60.0})
                    for (int q = 0; q <= ON_Q_ALBEDO_AVG_INTER; ++q) {
                        auto p = point(ti, to, pd, sg, 0.9, 8, 85, 10);
                        bt_sampler s = quad_sampler();
                        if (q >= ON_Q_ALBEDO) s.method = BT_METHOD_MC;
                        double v = oren_nayar_sample(p.data(), opts, q, &s);
                        CAPTURE(q);
                        CAPTURE(ti);
                        CAPTURE(to);
                        CAPTURE(sg);
                        CHECK(std::isfinite(v));
                        if (q != ON_Q_APPROX_ERROR) CHECK(v >= 0);
                    }
}

TEST_CASE("albedo sampler equals an outer quadrature of the brdf over the hemisphere")
{
    // Outer Gauss-Legendre over (theta_o in [0, 90], phi_o in [0, 180], even
    // in phi_d) of brdf cos sin, brdf by the kernel's quadrature; against the
    // albedo estimator (facet + cosine sampling, plain MC here).
    for (double ti : {30.0, 70.0})
        for (double sg : {20.0, 45.0}) {
            std::vector<double> xt, wt, xp, wp;
            gl(40, 0, kPi / 2, xt, wt);
            gl(40, 0, kPi, xp, wp);
            double e1 = 0, e2 = 0;
            for (int a = 0; a < 40; ++a)
                for (int b = 0; b < 40; ++b) {
                    auto p = point(ti, xt[a] / kDeg, xp[b] / kDeg, sg, 1, 8);
                    double jac = 2 * wt[a] * wp[b] * std::cos(xt[a]) * std::sin(xt[a]);
                    e1 += jac * quad(ON_Q_BRDF_DIRECT, p);
                    e2 += jac * quad(ON_Q_BRDF_INTER, p);
                }
            int opts[8] = {0};
            auto p = point(ti, 0, 0, sg, 1, 8);
            double m1 = 0, m2 = 0, q1 = 0, q2 = 0;
            const int n = 1 << 18;
            for (int k = 0; k < n; ++k) {
                bt_sampler s = quad_sampler();
                s.method = BT_METHOD_MC;
                s.sample = (uint)k;
                double x1 = oren_nayar_sample(p.data(), opts, ON_Q_ALBEDO_DIRECT, &s);
                double x2 = oren_nayar_sample(p.data(), opts, ON_Q_ALBEDO_INTER, &s);
                m1 += x1;
                q1 += x1 * x1;
                m2 += x2;
                q2 += x2 * x2;
            }
            m1 /= n;
            m2 /= n;
            double se1 = std::sqrt((q1 / n - m1 * m1) / n), se2 = std::sqrt((q2 / n - m2 * m2) / n);
            CAPTURE(ti);
            CAPTURE(sg);
            // 1e-3 relative: the outer rule crosses the brdf's kinks
            CHECK(std::fabs(m1 - e1) <= 4 * se1 + 1e-3 * e1);
            CHECK(std::fabs(m2 - e2) <= 4 * se2 + 1e-3 * e2);
        }
}

TEST_CASE("engine: albedo <= 1 at rho = 1, Lambert limit, device agrees with host")
{
    const ModelInfo& m = find_model("oren-nayar");
    auto opts = resolve_options(m, nlohmann::json::object(), "test");
    auto dev = make_backend("", Precision::Double);
    auto host = make_backend("host", Precision::Double);

    // Directional albedo at rho = 1 over theta_i and sigma (RQMC, 4-D).
    const QuantityInfo& qa = m.quantity("albedo");
    PointBuilder ba(m, qa);
    std::vector<std::map<std::string, double>> pts;
    for (double ti : {0.0, 30.0, 60.0, 80.0, 89.9})
        for (double sg : {0.0, 15.0, 30.0, 45.0, 60.0})
            pts.push_back({{"theta_i", ti}, {"sigma", sg}, {"rho", 1.0}});
    IntegrationSettings st;
    st.method = Method::Rqmc;
    st.samples = 1 << 15;
    auto ra = estimate(*dev, m, qa, opts, pts.size(),
                       [&](std::size_t c, double* out) { ba.build(pts[c], out); }, st);
    for (std::size_t c = 0; c < pts.size(); ++c) {
        CAPTURE(pts[c].at("theta_i"));
        CAPTURE(pts[c].at("sigma"));
        CHECK(ra.value[c] <= 1 + 3 * ra.stderr_[c]);
        CHECK(ra.value[c] > 0.5);  // a white rough surface reflects most light
        if (pts[c].at("sigma") == 0) CHECK(ra.value[c] == doctest::Approx(1).epsilon(2e-3));
    }

    // Quadrature brdf: device (PoCL, double) vs host, and float sanity.
    const QuantityInfo& qb = m.quantity("brdf");
    PointBuilder bb(m, qb);
    std::vector<std::map<std::string, double>> bp;
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(0, 1);
    for (int k = 0; k < 24; ++k)
        bp.push_back({{"theta_i", 89.9 * u(rng)}, {"theta_o", 89.9 * u(rng)},
                      {"phi_d", 180 * u(rng)}, {"sigma", 60 * u(rng)}, {"rho", u(rng)},
                      {"nodes", 10}});
    IntegrationSettings sq;
    sq.method = Method::Quadrature;
    auto pf = [&](std::size_t c, double* out) { bb.build(bp[c], out); };
    auto rd = estimate(*dev, m, qb, opts, bp.size(), pf, sq);
    auto rh = estimate(*host, m, qb, opts, bp.size(), pf, sq);
    auto ff = make_backend("", Precision::Float);
    auto rf = estimate(*ff, m, qb, opts, bp.size(), pf, sq);
    for (std::size_t c = 0; c < bp.size(); ++c) {
        CHECK(rd.value[c] == doctest::Approx(rh.value[c]).epsilon(1e-10));
        CHECK(rd.stderr_[c] == doctest::Approx(rh.stderr_[c]).epsilon(1e-6).scale(1e-12));
        CHECK(rf.value[c] == doctest::Approx(rh.value[c]).epsilon(2e-4));
    }

    // Sampling estimator (RQMC, host) is unbiased: within 4 stderr of the
    // quadrature (which is ~1e-6 accurate at 10 nodes).
    IntegrationSettings sr;
    sr.method = Method::Rqmc;
    sr.samples = 1 << 14;
    auto rr = estimate(*dev, m, qb, opts, bp.size(), pf, sr);
    for (std::size_t c = 0; c < bp.size(); ++c)
        CHECK(std::fabs(rr.value[c] - rh.value[c]) <=
              4 * rr.stderr_[c] + 1e-5 * std::fabs(rh.value[c]) + 1e-9);

    // Float sampling path, including small sigma (the normalisation series
    // must not overflow in float).
    std::vector<std::map<std::string, double>> sp;
    for (double sg : {0.3, 1.0, 3.0, 20.0, 60.0})
        sp.push_back({{"theta_i", 60}, {"theta_o", 30}, {"phi_d", 30}, {"sigma", sg},
                      {"rho", 0.9}, {"nodes", 12}});
    auto spf = [&](std::size_t c, double* out) { bb.build(sp[c], out); };
    auto sh = estimate(*host, m, qb, opts, sp.size(), spf, sq);
    auto sf = estimate(*ff, m, qb, opts, sp.size(), spf, sr);
    for (std::size_t c = 0; c < sp.size(); ++c) {
        CHECK(std::isfinite(sf.value[c]));
        CHECK(std::fabs(sf.value[c] - sh.value[c]) <= 4 * sf.stderr_[c] + 2e-6);
    }
}

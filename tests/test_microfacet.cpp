// test_microfacet.cpp — vec3.h, fresnel.h and microfacet.h compiled as C++.
// Oracles: deterministic 2-D quadrature of the defining integrals
// (normalisation of D, Smith's visible-area identity), the s/p-polarised
// Fresnel amplitudes (an independent formula), Snell's law, known marginals
// of the slope distributions, and chi-square against quadrature-computed
// bin probabilities (also for the visible-normal samplers, whose pdf
// G1 (v.m)+ D / v.z is integrated independently of the sampling code).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "kernels/common/fresnel.h"
#include "kernels/common/microfacet.h"
#include "kernels/common/sampler.h"
#include "kernels/common/vec3.h"
#include "test_support.h"

namespace {

using brdftab::test::kPi;

// 5-point Gauss-Legendre on [-1, 1].
const double kGlX[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831,
                        0.9061798459386640};
const double kGlW[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889,
                        0.4786286704993665, 0.2369268850561891};

// int over the upper hemisphere of f(m) dw.  theta: composite 5-point
// Gauss-Legendre on `panels` panels whose edges are graded as
// theta = (pi/2) s^2 (dense near the pole where narrow lobes live);
// phi: `nphi`-point midpoint rule, spectrally accurate for smooth periodic
// integrands.
double hemisphere_integral(const std::function<double(bt_vec3)>& f, int panels, int nphi)
{
    double total = 0;
    for (int p = 0; p < panels; ++p) {
        double s0 = double(p) / panels, s1 = double(p + 1) / panels;
        for (int q = 0; q < 5; ++q) {
            double s = 0.5 * (s0 + s1) + 0.5 * (s1 - s0) * kGlX[q];
            double th = 0.5 * kPi * s * s;
            double jac = kPi * s * 0.5 * (s1 - s0) * kGlW[q];  // dtheta/ds * ds
            double st = std::sin(th), ct = std::cos(th);
            double ring = 0;
            for (int k = 0; k < nphi; ++k) {
                double ph = 2 * kPi * (k + 0.5) / nphi;
                ring += f(bt_v3(st * std::cos(ph), st * std::sin(ph), ct));
            }
            total += ring * (2 * kPi / nphi) * st * jac;
        }
    }
    return total;
}

using brdftab::test::fresnel_sp;

struct Cfg {
    int dist;
    double ax, ay;
};

}  // namespace

TEST_CASE("D is normalised: int D(m) (m.n) dw = 1")
{
    // Quadrature error: 400 graded panels x 5-point GL resolve a lobe of
    // width 0.05 rad with ~10 panels; measured max error 3e-15 over these
    // cases.  Tolerance 1e-9 leaves room for other compilers/libms.
    std::vector<Cfg> cfgs = {
        {BT_MF_BECKMANN, 0.05, 0.05}, {BT_MF_BECKMANN, 0.3, 0.3}, {BT_MF_BECKMANN, 1.0, 1.0},
        {BT_MF_BECKMANN, 0.1, 0.5},   {BT_MF_GGX, 0.05, 0.05},    {BT_MF_GGX, 0.3, 0.3},
        {BT_MF_GGX, 1.0, 1.0},        {BT_MF_GGX, 0.7, 0.2},      {BT_MF_PHONG, 0.05, 0.05},
        {BT_MF_PHONG, 0.3, 0.3},      {BT_MF_PHONG, 1.0, 1.0},
    };
    for (const Cfg& c : cfgs) {
        bt_microfacet mf = bt_microfacet_make(c.dist, BT_G1_EXACT, BT_SHADOW_SEPARABLE, c.ax, c.ay);
        double integral =
            hemisphere_integral([&](bt_vec3 m) { return bt_mf_d(&mf, m) * m.z; }, 400, 256);
        INFO("dist " << c.dist << " ax " << c.ax << " ay " << c.ay);
        CHECK(integral == doctest::Approx(1.0).epsilon(1e-9));
        double pdf_integral =
            hemisphere_integral([&](bt_vec3 m) { return bt_mf_pdf(&mf, m); }, 400, 256);
        CHECK(pdf_integral == doctest::Approx(1.0).epsilon(1e-9));
    }
    // Phong's closed forms: alpha = 1 gives alpha_p = 0, D = 1/pi.
    CHECK(bt_phong_exponent(1.0) == 0.0);
    CHECK(bt_phong_d(0.3, 0.0) == doctest::Approx(1 / kPi));
    // D vanishes on the lower hemisphere and is finite at grazing.
    bt_microfacet g = bt_microfacet_make(BT_MF_BECKMANN, 0, 0, 1e-4, 1e-4);
    CHECK(bt_mf_d(&g, bt_v3(1, 0, 1e-30)) == 0.0);
    CHECK(bt_mf_d(&g, bt_v3(0, 0, -1)) == 0.0);
}

TEST_CASE("Smith identity: int G1(o,m) max(0,o.m) D(m) dw_m = o.n (exact G1)")
{
    // The integrand has a kink along o.m = 0, so convergence is algebraic:
    // measured max relative error 3.6e-9 on a 600x720 grid and a change of
    // 1.4e-8 between 300x360 and 600x720.  On the 300x360 grid used here the
    // error is thus ~2e-8; tolerance 1e-6 relative.  A wrong Lambda (e.g.
    // the Walter fit, 0.3 % off) fails by orders of magnitude.
    std::vector<Cfg> cfgs = {{BT_MF_BECKMANN, 0.1, 0.1}, {BT_MF_BECKMANN, 0.5, 0.5},
                             {BT_MF_BECKMANN, 1.0, 1.0}, {BT_MF_BECKMANN, 0.2, 0.6},
                             {BT_MF_GGX, 0.1, 0.1},      {BT_MF_GGX, 0.5, 0.5},
                             {BT_MF_GGX, 1.0, 1.0},      {BT_MF_GGX, 0.6, 0.2}};
    for (const Cfg& c : cfgs) {
        bt_microfacet mf = bt_microfacet_make(c.dist, BT_G1_EXACT, BT_SHADOW_SEPARABLE, c.ax, c.ay);
        for (double deg : {0.0, 30.0, 60.0, 75.0, 85.0}) {
            double th = deg * kPi / 180;
            bt_vec3 o = bt_from_spherical(th, 0.7);
            double integral = hemisphere_integral(
                [&](bt_vec3 m) {
                    return bt_mf_g1(&mf, o, m) * std::fmax(0.0, bt_v3_dot(o, m)) * bt_mf_d(&mf, m);
                },
                300, 360);
            INFO("dist " << c.dist << " ax " << c.ax << " ay " << c.ay << " theta " << deg);
            CHECK(integral == doctest::Approx(o.z).epsilon(1e-6));
        }
    }
}

TEST_CASE("Walter's rational G1 fit stays within its stated accuracy of the erf form")
{
    // Walter 2007 quotes the rational approximation of eq. 27 as accurate to
    // better than 0.35 % of eq. 26 (we measure 0.31 % at worst).
    for (double a = 1e-3; a < 5; a += 1e-3) {
        double exact = bt_beckmann_g1_exact_a(a), fit = bt_beckmann_g1_fit_a(a);
        REQUIRE(std::fabs(fit - exact) <= 3.5e-3 * exact);
    }
    CHECK(bt_beckmann_g1_exact_a(0.0) == 0.0);
    CHECK(bt_beckmann_g1_exact_a(1e30) == doctest::Approx(1.0));
}

TEST_CASE("G: chi+ factors, height-correlated form and bounds")
{
    for (int dist : {BT_MF_BECKMANN, BT_MF_GGX, BT_MF_PHONG}) {
        bt_microfacet sep = bt_microfacet_make(dist, BT_G1_EXACT, BT_SHADOW_SEPARABLE, 0.4, 0.4);
        bt_microfacet hc =
            bt_microfacet_make(dist, BT_G1_EXACT, BT_SHADOW_HEIGHT_CORRELATED, 0.4, 0.4);
        bt_vec3 m = bt_v3_normalize(bt_v3(0.2, 0.1, 1));
        bt_vec3 i = bt_from_spherical(1.2, 0.3), o = bt_from_spherical(0.9, 2.5);
        double gi = bt_mf_g1(&sep, i, m), go = bt_mf_g1(&sep, o, m);
        CHECK(bt_mf_g(&sep, i, o, m) == doctest::Approx(gi * go));
        // Height-correlated: 1/(1 + Lambda_i + Lambda_o), Lambda = 1/G1 - 1.
        double lam_i = 1 / gi - 1, lam_o = 1 / go - 1;
        CHECK(bt_mf_g(&hc, i, o, m) == doctest::Approx(1 / (1 + lam_i + lam_o)));
        CHECK(bt_mf_g(&hc, i, o, m) >= gi * go);
        CHECK(bt_mf_g(&hc, i, o, m) <= std::fmin(gi, go));
        // A direction that sees the back of m is masked completely.
        bt_vec3 back = bt_v3_normalize(bt_v3(-5, 0, 0.1));
        CHECK(bt_v3_dot(back, m) < 0);
        CHECK(bt_mf_g1(&sep, back, m) == 0.0);
        CHECK(bt_mf_g(&hc, back, o, m) == 0.0);
        // Transmission geometry: o below with o.m < 0 is visible (chi+ of the ratio).
        bt_vec3 below = bt_from_spherical(2.8, 0.1);
        CHECK(bt_mf_g1(&sep, below, m) > 0.0);
        // Normal direction: G1 = 1; grazing: G1 -> 0 without NaN.
        CHECK(bt_mf_g1(&sep, bt_v3(0, 0, 1), bt_v3(0, 0, 1)) == doctest::Approx(1.0));
        double gz = bt_mf_g1_nochi(&sep, bt_v3(1, 0, 0));
        CHECK(std::isfinite(gz));
        CHECK(gz == doctest::Approx(0.0));
    }
}

TEST_CASE("sampled normals follow D(m)|m.n| (chi-square against quadrature)")
{
    // Isotropic cases: K = 20 bins in theta, edges at quantiles of the
    // theta-marginal 2 pi D cos sin computed by quadrature (independent of
    // the sampler's inverse CDF).  N = 100000 MC samples; chi-square with
    // 19 dof has its 99.99 % quantile at 52.6 (deterministic seed, so this
    // either always passes or always fails).
    const int K = 20, N = 100000, fine = 200000;
    for (int dist : {BT_MF_BECKMANN, BT_MF_GGX, BT_MF_PHONG})
        for (double alpha : {0.08, 0.5}) {
            bt_microfacet mf = bt_microfacet_make(dist, 0, 0, alpha, alpha);
            // Marginal CDF on a fine midpoint grid in theta.
            std::vector<double> cdf(fine + 1, 0.0);
            for (int k = 0; k < fine; ++k) {
                double th = (k + 0.5) * (kPi / 2) / fine;
                bt_vec3 m = bt_v3(std::sin(th), 0, std::cos(th));
                cdf[k + 1] = cdf[k] + 2 * kPi * bt_mf_d(&mf, m) * m.z * std::sin(th) * (kPi / 2) / fine;
            }
            CHECK(cdf[fine] == doctest::Approx(1.0).epsilon(1e-4));
            std::vector<double> edges(K + 1, kPi / 2);
            edges[0] = 0;
            int b = 1;
            for (int k = 1; k <= fine && b < K; ++k)
                while (b < K && cdf[k] >= cdf[fine] * b / K) edges[b++] = k * (kPi / 2) / fine;
            std::vector<int> count(K, 0);
            for (int n = 0; n < N; ++n) {
                bt_sampler s;
                s.key0 = 1;
                s.key1 = 2;
                s.cell = (uint)(dist * 10 + (alpha < 0.1));
                s.batch = 0;
                s.sample = (uint)n;
                s.method = BT_METHOD_MC;
                double pdf;
                bt_vec3 m = bt_mf_sample(&mf, bt_uniform(&s, 0), bt_uniform(&s, 1), &pdf);
                REQUIRE(std::fabs(bt_v3_length(m) - 1) < 1e-12);
                REQUIRE(pdf == doctest::Approx(bt_mf_d(&mf, m) * m.z));
                double th = std::acos(std::fmin(1.0, m.z));
                int bin = K - 1;
                while (bin > 0 && th < edges[bin]) --bin;
                ++count[bin];
            }
            double chi2 = 0;
            for (int k = 0; k < K; ++k) {
                double e = double(N) / K;
                chi2 += (count[k] - e) * (count[k] - e) / e;
            }
            INFO("dist " << dist << " alpha " << alpha << " chi2 " << chi2);
            CHECK(chi2 < 52.6);
        }
}

TEST_CASE("anisotropic sampling stretches the slopes along the right axes")
{
    // Slope marginals of the stretched distributions (independent closed
    // forms): Beckmann slope x/alpha_x ~ N(0, 1/2), so P(|slope_x| < alpha_x)
    // = erf(1); GGX slope x/alpha_x has density 1/(2 (1 + t^2)^{3/2}), so
    // P(|slope_x| < alpha_x) = 1/sqrt(2).  N = 100000: binomial stderr
    // <= 0.0016; tolerance 5 sigma = 0.008.  Swapped axes would give
    // P(|slope_x| < alpha_x) far from these (alpha_x/alpha_y = 0.25).
    const int N = 100000;
    for (int dist : {BT_MF_BECKMANN, BT_MF_GGX}) {
        double ax = 0.1, ay = 0.4;
        bt_microfacet mf = bt_microfacet_make(dist, 0, 0, ax, ay);
        int inx = 0, iny = 0;
        for (int n = 0; n < N; ++n) {
            bt_sampler s;
            s.key0 = 3;
            s.key1 = 4;
            s.cell = (uint)dist;
            s.batch = 1;
            s.sample = (uint)n;
            s.method = BT_METHOD_MC;
            double pdf;
            bt_vec3 m = bt_mf_sample(&mf, bt_uniform(&s, 0), bt_uniform(&s, 1), &pdf);
            inx += std::fabs(m.x / m.z) < ax;
            iny += std::fabs(m.y / m.z) < ay;
        }
        double expect = dist == BT_MF_BECKMANN ? std::erf(1.0) : 1 / std::sqrt(2.0);
        CHECK(double(inx) / N == doctest::Approx(expect).epsilon(0.008 / expect));
        CHECK(double(iny) / N == doctest::Approx(expect).epsilon(0.008 / expect));
    }
}

// ------------------------------------------------------ visible normals

namespace {

struct VisCfg {
    int dist;
    double ax, ay, theta_deg;
};

// The configurations of the visible-normal tests: incidence up to 89 deg,
// widths 0.05..2, isotropic and anisotropic, view azimuth 0.7 rad (off the
// stretch axes, so a wrong rotation or stretch shows).
const VisCfg kVisCfgs[] = {
    {BT_MF_BECKMANN, 0.3, 0.3, 0},   {BT_MF_BECKMANN, 0.05, 0.05, 30}, {BT_MF_BECKMANN, 0.5, 0.5, 60},
    {BT_MF_BECKMANN, 1.0, 1.0, 80},  {BT_MF_BECKMANN, 2.0, 2.0, 89},   {BT_MF_BECKMANN, 0.1, 0.5, 70},
    {BT_MF_BECKMANN, 1.5, 0.2, 45},  {BT_MF_BECKMANN, 0.05, 0.3, 89},  {BT_MF_GGX, 0.3, 0.3, 0},
    {BT_MF_GGX, 0.05, 0.05, 30},     {BT_MF_GGX, 0.5, 0.5, 60},        {BT_MF_GGX, 1.0, 1.0, 80},
    {BT_MF_GGX, 2.0, 2.0, 89},       {BT_MF_GGX, 0.1, 0.5, 70},        {BT_MF_GGX, 1.5, 0.2, 45},
    {BT_MF_GGX, 0.05, 0.3, 89},
};

const double kViewPhi = 0.7;

// pdf of visible normals written out from its definition, independently of
// bt_mf_pdf_visible: G1 (exact Smith, bt_mf_g1 with the exact option)
// times max(0, v.m) D(m) / v.z.
double dv_oracle(const bt_microfacet& mf, bt_vec3 v, bt_vec3 m)
{
    return bt_mf_g1(&mf, v, m) * std::fmax(0.0, bt_v3_dot(v, m)) * bt_mf_d(&mf, m) / v.z;
}

}  // namespace

TEST_CASE("pdf of visible normals integrates to 1 (Smith's identity)")
{
    // int G1(v,m) (v.m)+ D(m) dm = v.z (Smith); quadrature as in the Smith
    // identity test (kink along v.m = 0: algebraic convergence).  Measured
    // worst error 5.4e-6 on this 300 x 360 grid (Beckmann alpha 2 at 89 deg,
    // mass near grazing m where the graded grid is coarse), 1.2e-8 on
    // 600 x 720 and 3e-9 on 1200 x 1440: quadrature error, not the pdf.
    // Tolerance 2e-5 absolute; a wrong normaliser (e.g. Walter's G1 fit,
    // up to 0.3 % off) misses it by orders of magnitude.
    // Also checks bt_mf_pdf_visible against the formula written out here.
    for (const VisCfg& c : kVisCfgs)
        for (double deg : {c.theta_deg, 89.0}) {
            bt_microfacet mf = bt_microfacet_make(c.dist, BT_G1_EXACT, 0, c.ax, c.ay);
            bt_vec3 v = bt_from_spherical(deg * kPi / 180, kViewPhi);
            double max_rel = 0;
            double integral = hemisphere_integral(
                [&](bt_vec3 m) {
                    double p = bt_mf_pdf_visible(&mf, v, m), q = dv_oracle(mf, v, m);
                    max_rel = std::fmax(max_rel, std::fabs(p - q) / std::fmax(q, 1e-300));
                    return p;
                },
                300, 360);
            INFO("dist " << c.dist << " ax " << c.ax << " ay " << c.ay << " theta " << deg);
            CHECK(max_rel < 1e-12);
            CHECK(std::fabs(integral - 1) < 2e-5);
        }
    // Precondition v.z > 0: 0, not NaN, otherwise.
    bt_microfacet mf = bt_microfacet_make(BT_MF_GGX, 0, 0, 0.5, 0.5);
    CHECK(bt_mf_pdf_visible(&mf, bt_v3(1, 0, 0), bt_v3(0, 0, 1)) == 0.0);
    CHECK(bt_mf_pdf_visible(&mf, bt_v3(0, 0, -1), bt_v3(0, 0, 1)) == 0.0);
}

TEST_CASE("visible-normal samples follow G1 (v.m)+ D / v.z (chi-square, theta_m x phi_m)")
{
    // Bins: 10 theta_m bins at quantiles of the theta marginal x 8 equal
    // phi_m bins.  Bin probabilities from a 1200 x 480 midpoint quadrature of
    // the oracle pdf (dv_oracle) on a graded theta grid (theta = pi/2 s^2);
    // the theta edges are cell edges of that grid.  Bins expecting < 5 samples
    // are pooled.  N = 40000 MC samples per case; threshold: the 99.99 %
    // quantile of chi-square (Wilson-Hilferty).  Deterministic seeds.
    const int NS = 1200, NP = 480, KT = 10, KP = 8, N = 40000;
    uint cell = 0;
    for (const VisCfg& c : kVisCfgs) {
        bt_microfacet mf = bt_microfacet_make(c.dist, BT_G1_EXACT, 0, c.ax, c.ay);
        bt_vec3 v = bt_from_spherical(c.theta_deg * kPi / 180, kViewPhi);
        std::vector<double> cellp((size_t)NS * NP);
        std::vector<double> th_edge(NS + 1);
        double total = 0;
        for (int i = 0; i <= NS; ++i) th_edge[i] = 0.5 * kPi * (double(i) / NS) * (double(i) / NS);
        for (int i = 0; i < NS; ++i) {
            double th = 0.5 * (th_edge[i] + th_edge[i + 1]), dth = th_edge[i + 1] - th_edge[i];
            for (int j = 0; j < NP; ++j) {
                double ph = 2 * kPi * (j + 0.5) / NP;
                bt_vec3 m = bt_v3(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph),
                                  std::cos(th));
                double p = dv_oracle(mf, v, m) * std::sin(th) * dth * (2 * kPi / NP);
                cellp[(size_t)i * NP + j] = p;
                total += p;
            }
        }
        INFO("dist " << c.dist << " ax " << c.ax << " ay " << c.ay << " theta " << c.theta_deg);
        CHECK(total == doctest::Approx(1.0).epsilon(2e-3));  // quadrature sanity
        // Theta bins at quantiles of the marginal.
        std::vector<int> tbin(NS);
        double acc = 0;
        for (int i = 0; i < NS; ++i) {
            double row = 0;
            for (int j = 0; j < NP; ++j) row += cellp[(size_t)i * NP + j];
            tbin[i] = std::min(KT - 1, (int)(KT * (acc + 0.5 * row) / total));
            acc += row;
        }
        std::vector<double> prob(KT * KP, 0.0);
        for (int i = 0; i < NS; ++i)
            for (int j = 0; j < NP; ++j) prob[tbin[i] * KP + j / (NP / KP)] += cellp[(size_t)i * NP + j];
        std::vector<int> count(KT * KP, 0);
        ++cell;
        for (int n = 0; n < N; ++n) {
            bt_sampler s;
            s.key0 = 11;
            s.key1 = 12;
            s.cell = cell;
            s.batch = 0;
            s.sample = (uint)n;
            s.method = BT_METHOD_MC;
            bt_vec3 m = bt_mf_sample_visible(&mf, v, bt_uniform(&s, 0), bt_uniform(&s, 1));
            REQUIRE(std::fabs(bt_v3_length(m) - 1) < 1e-12);
            REQUIRE(bt_v3_dot(v, m) >= 0);
            double th = std::acos(std::fmin(1.0, m.z));
            double ph = std::atan2(m.y, m.x);
            if (ph < 0) ph += 2 * kPi;
            int i = (int)(std::upper_bound(th_edge.begin(), th_edge.end(), th) - th_edge.begin()) - 1;
            i = std::max(0, std::min(NS - 1, i));
            int j = std::min(NP - 1, (int)(ph / (2 * kPi) * NP));
            ++count[tbin[i] * KP + j / (NP / KP)];
        }
        double chi2 = 0, pool_e = 0;
        int pool_o = 0, bins = 0;
        for (int b = 0; b < KT * KP; ++b) {
            double e = N * prob[b] / total;
            if (e < 5) {
                pool_e += e;
                pool_o += count[b];
                continue;
            }
            chi2 += (count[b] - e) * (count[b] - e) / e;
            ++bins;
        }
        if (pool_e > 0) {
            chi2 += (pool_o - pool_e) * (pool_o - pool_e) / std::fmax(pool_e, 5.0);
            ++bins;
        }
        double k = bins - 1, z = 3.719;  // 99.99 % normal quantile
        double limit = k * std::pow(1 - 2 / (9 * k) + z * std::sqrt(2 / (9 * k)), 3);
        INFO("chi2 " << chi2 << " dof " << k << " limit " << limit);
        CHECK(bins > 30);
        CHECK(chi2 < limit);
    }
}

TEST_CASE("Beckmann visible-slope inversions: CDF round trip and limits")
{
    // Oracles: the closed-form CDFs.  y: (1 + erf y)/2 = u.  x (slope along
    // the view azimuth, mu = cot theta): C(x)/C(mu) with
    // C(x) = (mu sqrt(pi)/2) erfc(-x) + exp(-x^2)/2 (integral of
    // (mu - t) exp(-t^2), checked here by quadrature too).
    for (double u = 1e-9; u < 1; u += 7.3e-4) {
        double y = bt_mf_erfinv_unit(u);
        REQUIRE(0.5 * (1 + std::erf(y)) == doctest::Approx(u).epsilon(1e-10));
    }
    for (double mu : {0.0, 1e-3, 0.3, 1.0, 3.0, 10.0, 1e15}) {
        double a = 0.5 * std::sqrt(kPi) * mu;
        auto C = [&](double x) { return a * std::erfc(-x) + 0.5 * std::exp(-x * x); };
        if (mu < 20) {  // C(mu) by midpoint quadrature of the density
            double q = 0, lo = -9, w = mu - lo;
            const int n = 200000;
            for (int k = 0; k < n; ++k) {
                double t = lo + w * (k + 0.5) / n;
                q += (mu - t) * std::exp(-t * t) * w / n;
            }
            CHECK(q == doctest::Approx(C(mu)).epsilon(1e-8));
        }
        for (double u = 1e-9; u < 1; u += 3.1e-3) {
            double x = bt_beckmann_visible_slope_x(mu, u);
            REQUIRE(x <= mu);
            REQUIRE(C(x) / C(mu) == doctest::Approx(u).epsilon(1e-10));
        }
        // u = 0 and the top u stay finite (range cut at -7 / min(mu, 7)).
        CHECK(std::isfinite(bt_beckmann_visible_slope_x(mu, 0.0)));
        CHECK(bt_beckmann_visible_slope_x(mu, 1 - 0x1p-32) <= std::fmin(mu, 7.0));
    }
    CHECK(std::isfinite(bt_mf_erfinv_unit(0.0)));
    CHECK(bt_mf_erfinv_unit(0.5) == 0.0);
}

TEST_CASE("visible-normal sampling at normal incidence reduces to D(m) m.z")
{
    // v = n: D_v = G1(n) (m.z) D / 1 = D m.z (G1(n) = 1), the distribution
    // Walter's sampler draws; for isotropic widths the theta_m marginal then
    // has a closed-form CDF: Beckmann 1 - exp(-tan^2/alpha^2), GGX
    // tan^2/(alpha^2 + tan^2).  Kolmogorov-Smirnov distance on 40000 samples
    // below 1.95/sqrt(N) (99.9 %).
    const int N = 40000;
    for (int dist : {BT_MF_BECKMANN, BT_MF_GGX})
        for (double alpha : {0.05, 0.7, 2.0}) {
            bt_microfacet mf = bt_microfacet_make(dist, 0, 0, alpha, alpha);
            std::vector<double> t2(N);
            for (int n = 0; n < N; ++n) {
                bt_sampler s;
                s.key0 = 21;
                s.key1 = 22;
                s.cell = (uint)(dist * 10 + alpha * 3);
                s.batch = 0;
                s.sample = (uint)n;
                s.method = BT_METHOD_MC;
                bt_vec3 m = bt_mf_sample_visible(&mf, bt_v3(0, 0, 1), bt_uniform(&s, 0),
                                                 bt_uniform(&s, 1));
                t2[n] = (m.x * m.x + m.y * m.y) / (m.z * m.z);
            }
            std::sort(t2.begin(), t2.end());
            double ks = 0;
            for (int n = 0; n < N; ++n) {
                double a2 = alpha * alpha;
                double F = dist == BT_MF_BECKMANN ? 1 - std::exp(-t2[n] / a2) : t2[n] / (a2 + t2[n]);
                ks = std::fmax(ks, std::fmax(std::fabs(F - double(n) / N), std::fabs(F - double(n + 1) / N)));
            }
            INFO("dist " << dist << " alpha " << alpha << " KS " << ks);
            CHECK(ks < 1.95 / std::sqrt(double(N)));
        }
}

TEST_CASE("Fresnel: normal incidence, TIR, eta = 1, symmetry, s/p oracle")
{
    for (double eta : {1.0001, 1.33, 1.5, 2.4, 1 / 1.5, 0.3}) {
        CHECK(bt_fresnel_dielectric(1.0, eta) ==
              doctest::Approx((eta - 1) * (eta - 1) / ((eta + 1) * (eta + 1))).epsilon(1e-12));
        CHECK(bt_fresnel_normal(eta) == doctest::Approx(bt_fresnel_dielectric(1.0, eta)));
        for (double c = 0.0005; c <= 1; c += 0.0005) {
            double f = bt_fresnel_dielectric(c, eta);
            REQUIRE(f >= 0);
            REQUIRE(f <= 1);
            REQUIRE(f == doctest::Approx(fresnel_sp(c, eta)).epsilon(1e-9));
            // Symmetry in the direction of travel: F(c_i, eta) = F(c_t, 1/eta).
            double st2 = (1 - c * c) / (eta * eta);
            if (st2 < 1) {
                double ct = std::sqrt(1 - st2);
                REQUIRE(bt_fresnel_dielectric(ct, 1 / eta) == doctest::Approx(f).epsilon(1e-9));
            }
        }
        // Grazing incidence reflects everything (eta != 1).
        CHECK(bt_fresnel_dielectric(0.0, eta) == doctest::Approx(1.0));
    }
    // TIR past the critical angle (from glass to air): sin(theta_c) = 1/1.5.
    double cos_c = std::sqrt(1 - 1 / (1.5 * 1.5));
    CHECK(bt_fresnel_dielectric(cos_c - 1e-6, 1 / 1.5) == 1.0);
    CHECK(bt_fresnel_dielectric(0.1, 1 / 1.5) == 1.0);
    CHECK(bt_fresnel_dielectric(cos_c + 1e-3, 1 / 1.5) < 1.0);
    // No interface: eta = 1 reflects nothing, at every angle including grazing.
    for (double c : {0.0, 1e-12, 0.3, 1.0}) CHECK(bt_fresnel_dielectric(c, 1.0) == 0.0);
    // eta -> 1: F ~ ((eta^2-1)/(g+c)^2)^2 stays accurate (s/p formula has no
    // cancellation issue at this eta either).
    CHECK(bt_fresnel_dielectric(0.5, 1 + 1e-7) ==
          doctest::Approx(fresnel_sp(0.5, 1 + 1e-7)).epsilon(1e-6));
    CHECK(bt_fresnel_dielectric(-0.5, 1.5) == bt_fresnel_dielectric(0.5, 1.5));
}

TEST_CASE("vec3: reflect, refract (Snell), spherical round trip")
{
    bt_vec3 m = bt_v3_normalize(bt_v3(0.3, -0.2, 1));
    for (double eta : {1.5, 1 / 1.5, 1.0, 2.0}) {
        for (double th : {0.0, 0.3, 0.7, 1.2}) {
            bt_vec3 i = bt_from_spherical(th, 0.4);
            if (bt_v3_dot(i, m) <= 0) continue;
            bt_vec3 r = bt_reflect(i, m);
            CHECK(bt_v3_dot(r, m) == doctest::Approx(bt_v3_dot(i, m)));
            CHECK(bt_v3_length(r) == doctest::Approx(1.0));
            bt_vec3 t;
            double ci = bt_v3_dot(i, m);
            double si = std::sqrt(1 - ci * ci);
            int ok = bt_refract(i, m, eta, &t);
            CHECK(ok == (si / eta < 1));
            if (!ok) continue;
            // Unit length, on the far side, Snell's law, coplanar with i and m.
            CHECK(bt_v3_length(t) == doctest::Approx(1.0));
            double ct = bt_v3_dot(t, m);
            CHECK(ct < 0);
            CHECK(std::sqrt(1 - ct * ct) * eta == doctest::Approx(si).epsilon(1e-12));
            CHECK(bt_v3_dot(t, bt_v3_cross(i, m)) == doctest::Approx(0.0));
            if (eta == 1.0) {  // no interface: straight through
                CHECK(t.x == doctest::Approx(-i.x));
                CHECK(t.y == doctest::Approx(-i.y));
                CHECK(t.z == doctest::Approx(-i.z));
            }
        }
    }
    bt_vec3 tir;
    CHECK(bt_refract(bt_from_spherical(1.2, 0), bt_v3(0, 0, 1), 1 / 1.5, &tir) == 0);
    double th, ph;
    bt_to_spherical(bt_from_spherical(2.1, -1.3), &th, &ph);
    CHECK(th == doctest::Approx(2.1));
    CHECK(ph == doctest::Approx(-1.3));
}

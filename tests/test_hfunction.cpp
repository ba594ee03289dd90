// test_hfunction.cpp — kernels/models/hfunction.h (Chandrasekhar H-functions
// from the Fock integral, d'Eon eqs. 13-20, 32).
//
// Oracles, all independent of the Fock-integral code path:
//  * a second solution method written here: Nystrom iteration of the
//    nonlinear integral equation in Chandrasekhar's alternative form
//      1/H(mu) = sqrt(1 - 2 int Psi) + int_0^1 mu' Psi(mu') H(mu') / (mu + mu') dmu'
//    on Gauss-Legendre nodes in log(mu') (the kernel mu'/(mu+mu') is a logistic
//    function of log mu' - log mu, so the rule converges geometrically);
//  * the residual of the defining equation H = 1 + mu H int Psi H/(mu+mu');
//  * H(0) = 1, H0(inf) = 12/sqrt((c-16)(c-1)(4c+9)) (eq. 32);
//  * Chandrasekhar's table value H(1) = 2.90781 for conservative isotropic
//    scattering; alpha_0 = (2/c)(1 - sqrt(1 - c)) for Psi = c/2, and the general
//    zeroth-moment identity int Psi H = 1 - sqrt(1 - 2 int Psi);
//  * K(t): closed forms (eqs. 18-20) against brute-force quadrature of eq. 17.
#include <doctest/doctest.h>

#include "test_support.h"

#include <cmath>
#include <map>
#include <vector>

#include "host/engine/engine.h"
#include "host/models/registry.h"
#include "kernels/models/hfunction.h"

using namespace brdftab;

namespace {

using brdftab::test::gauss_legendre;

// Psi as polynomial coefficients, written from eqs. 13-15 directly.
double psi_eval(int kind, double c, const double* poly, double mu) {
    double m2 = mu * mu;
    switch (kind) {
    case 0:
        return c / 384 * (-15 * (c - 1) * (4 * c + 9) * m2 * m2 + (c * (20 * c + 281) - 346) * m2 + 207);
    case 1: return -c / 192 * (m2 - 1) * (5 * (4 * c + 9) * m2 - 64);
    case 2: return 15 * c / 256 * (m2 - 1) * (m2 - 1);
    case 3: return c / 2;
    default: return poly[0] + poly[1] * m2 + poly[2] * m2 * m2 + poly[3] * m2 * m2 * m2;
    }
}

// The second method: H on nodes mu_j = exp(sigma_j), sigma in [-40, 0].
struct IterH {
    int kind;
    double c;
    const double* poly;
    std::vector<double> mu, wt, psi, H;  // wt includes dmu = mu dsigma
    double sqrt_a = 0;
    int iterations = 0;

    IterH(int kind_, double c_, const double* poly_, int n = 220) : kind(kind_), c(c_), poly(poly_) {
        std::vector<double> x, w;
        gauss_legendre(n, x, w);
        const double lo = -40, hi = 0;
        double psi0 = 0;
        for (int j = 0; j < n; ++j) {
            double s = 0.5 * (hi - lo) * x[j] + 0.5 * (hi + lo);
            mu.push_back(std::exp(s));
            wt.push_back(0.5 * (hi - lo) * w[j] * mu.back());
            psi.push_back(psi_eval(kind, c, poly, mu.back()));
            psi0 += wt.back() * psi.back();
        }
        // 1 - 2 int Psi by the same quadrature (exact for polynomials up to
        // rounding); clamp the conservative case to 0.
        double a = 1 - 2 * psi0;
        sqrt_a = a > 1e-13 ? std::sqrt(a) : 0;
        H.assign(n, 1.0);
        for (iterations = 0; iterations < 200000; ++iterations) {
            double change = 0;
            // Geometric mean of H and T(H): at c = 1 the plain map T has the
            // eigenvalue -1 along H -> lambda H (T(lambda H) = T(H)/lambda) and
            // oscillates forever; the mean has the same fixed point.
            std::vector<double> Hn(n);
            for (int i = 0; i < n; ++i) Hn[i] = std::sqrt(H[i] / inv_rhs(mu[i]));
            for (int i = 0; i < n; ++i) change = std::max(change, std::fabs(Hn[i] / H[i] - 1));
            H = Hn;
            if (change < 1e-15) break;
        }
    }
    double inv_rhs(double m) const {
        double s = sqrt_a;
        for (std::size_t j = 0; j < mu.size(); ++j) s += wt[j] * mu[j] * psi[j] * H[j] / (m + mu[j]);
        return s;
    }
    // Nystrom interpolation: the equation itself evaluated at any mu.
    double at(double m) const { return m == 0 ? 1.0 : 1 / inv_rhs(m); }
};

double kernel_h(int kind, double c, const double* poly, double mu, int coarse = 0) {
    hf_psi P = hf_make_psi(kind, c, poly);
    return hf_h(&P, mu, coarse);
}

const double kNoPoly[4] = {0, 0, 0, 0};
const double kPoly[4] = {0.3, 0.2, -0.1, 0.05};  // 1 - 2 int Psi = 0.2924 > 0

}  // namespace

TEST_CASE("K(t): closed forms eqs. 18-20 and the small-t series equal eq. 17 by brute force") {
    for (int kind = 0; kind < 3; ++kind)
        for (double c : {0.2, 0.9, 1.0}) {
            for (double t : {1e-4, 0.01, 0.3, 0.4999, 0.5, 0.8, 2.0, 30.0, 1e4, 1e9}) {
                // eq. 17 in real form, 1 - 2 int_0^1 Psi(x)/(1 + x^2 t^2) dx, by
                // composite 60-point GL on panels [0, 1/t, 4/t, 16/t, ..., 1]
                // (the integrand has a peak of width 1/t at x = 0).
                std::vector<double> x, w;
                gauss_legendre(60, x, w);
                std::vector<double> edges = {0};
                for (double e = 1 / t; e < 1; e *= 4) edges.push_back(e);
                edges.push_back(1);
                double s = 0;
                for (std::size_t e = 0; e + 1 < edges.size(); ++e) {
                    double lo = edges[e], hi = edges[e + 1];
                    for (int k = 0; k < 60; ++k) {
                        double xx = 0.5 * (hi - lo) * (x[k] + 1) + lo;
                        s += 0.5 * (hi - lo) * w[k] * psi_eval(kind, c, kNoPoly, xx) / (1 + xx * xx * t * t);
                    }
                }
                double brute = 1 - 2 * s;
                REAL p[16] = {0, 0, 0, 0, t, c, 0, 0, 0, 0, 0};
                int o[8] = {kind};
                bt_sampler smp{0, 0, 0, 0, 0, BT_METHOD_CLOSED};
                double k = hfunction_sample(p, o, HF_Q_K, &smp);
                CAPTURE(kind);
                CAPTURE(c);
                CAPTURE(t);
                // brute force is good to ~1e-15 absolute (its 1 - 2s cancels)
                CHECK(std::fabs(k - brute) < 1e-14);
            }
        }
}

TEST_CASE("K(t) at c = 1 near t = 0: relative accuracy of the series (K ~ b t^2)") {
    // m_j = int_0^1 Psi0 x^(2j) dx computed here from eq. 13 by exact monomial integrals.
    const double c = 1;
    const double a0 = 207 * c / 384, a1 = c * (c * (20 * c + 281) - 346) / 384,
                 a2 = -15 * c * (c - 1) * (4 * c + 9) / 384;
    auto m = [&](int j) { return a0 / (2 * j + 1) + a1 / (2 * j + 3) + a2 / (2 * j + 5); };
    CHECK(std::fabs(1 - 2 * m(0)) < 1e-15);  // conservative: K0(0) = 0
    for (double t : {1e-6, 1e-3, 0.1}) {
        double t2 = t * t;
        double expect = 2 * m(1) * t2 - 2 * m(2) * t2 * t2 + 2 * m(3) * t2 * t2 * t2 -
                        2 * m(4) * t2 * t2 * t2 * t2 + 2 * m(5) * std::pow(t2, 5);
        REAL p[16] = {0, 0, 0, 0, t, c};
        int o[8] = {0};
        bt_sampler smp{0, 0, 0, 0, 0, BT_METHOD_CLOSED};
        CHECK(hfunction_sample(p, o, HF_Q_K, &smp) == doctest::Approx(expect).epsilon(1e-11));
    }
}

TEST_CASE("H agrees with the independent Nystrom iteration to 1e-8 relative") {
    double worst = 0;
    for (int kind = 0; kind < 5; ++kind)
        for (double c : {1e-3, 0.3, 0.9, 0.999, 1.0}) {
            if (kind == 4 && c != 1.0) continue;  // poly ignores c
            const double* poly = kind == 4 ? kPoly : kNoPoly;
            IterH ref(kind, c, poly);
            for (double mu : {1e-8, 1e-4, 0.01, 0.1, 0.3, 0.5, 0.77, 1.0, 3.0, 100.0}) {
                double h = kernel_h(kind, c, poly, mu);
                double r = ref.at(mu);
                CAPTURE(kind);
                CAPTURE(c);
                CAPTURE(mu);
                CAPTURE(ref.iterations);
                CHECK(std::isfinite(h));
                CHECK(std::fabs(h / r - 1) < 1e-8);
                worst = std::max(worst, std::fabs(h / r - 1));
            }
        }
    MESSAGE("max relative difference Fock integral vs Nystrom iteration: " << worst);
}

TEST_CASE("residual of the defining equation H = 1 + mu H int Psi H/(mu + mu')") {
    std::vector<double> x, w;
    gauss_legendre(220, x, w);
    for (int kind = 0; kind < 5; ++kind)
        for (double c : {0.5, 1.0}) {
            const double* poly = kind == 4 ? kPoly : kNoPoly;
            // H from the kernel at log-spaced nodes (same mapping as IterH)
            std::vector<double> mu, wt, hk;
            for (std::size_t j = 0; j < x.size(); ++j) {
                double s = 20 * x[j] - 20;
                mu.push_back(std::exp(s));
                wt.push_back(20 * w[j] * mu.back());
                hk.push_back(kernel_h(kind, c, poly, mu.back()));
            }
            for (double m : {0.05, 0.5, 1.0}) {
                double integral = 0;
                for (std::size_t j = 0; j < mu.size(); ++j)
                    integral += wt[j] * psi_eval(kind, c, poly, mu[j]) * hk[j] / (m + mu[j]);
                double h = kernel_h(kind, c, poly, m);
                CAPTURE(kind);
                CAPTURE(c);
                CAPTURE(m);
                CHECK(std::fabs(h - (1 + m * h * integral)) < 1e-9 * h);
            }
        }
}

TEST_CASE("limits: H(0) = 1, H0(inf) (eq. 32), small c, Chandrasekhar's H(1) = 2.90781") {
    for (int kind = 0; kind < 5; ++kind) CHECK(kernel_h(kind, 0.7, kPoly, 0.0) == 1.0);
    for (double c : {0.0, 0.2, 0.8, 0.99}) {
        double hinf = 12 / std::sqrt((c - 16) * (c - 1) * (4 * c + 9));  // eq. 32
        // H(mu) -> H(inf) with an O(1/mu) remainder: mu = 1e12 is within 1e-9.
        CHECK(kernel_h(0, c, kNoPoly, 1e12) == doctest::Approx(hinf).epsilon(1e-9));
        REAL p[16] = {0, 0, 0, 0, 1, c};
        int o[8] = {0};
        bt_sampler smp{0, 0, 0, 0, 0, BT_METHOD_CLOSED};
        CHECK(hfunction_sample(p, o, HF_Q_HINF, &smp) == doctest::Approx(hinf).epsilon(1e-14));
    }
    // c = 1: H0 grows linearly, H(mu) ~ mu sqrt(1/b)... finite for finite mu.
    double big = kernel_h(0, 1.0, kNoPoly, 1e6);
    CHECK(std::isfinite(big));
    CHECK(big > 1e5);
    // Isotropic conservative scattering: Chandrasekhar (1960) Table XIII, H(1) = 2.90781.
    CHECK(std::fabs(kernel_h(3, 1.0, kNoPoly, 1.0) - 2.90781) < 6e-6);
    // First order in c: H = 1 + mu int Psi/(mu + mu') dmu' + O(c^2); isotropic:
    // (c/2) mu log(1 + 1/mu).
    const double c = 1e-7;
    for (double mu : {0.01, 0.5, 1.0}) {
        double first = 1 + c / 2 * mu * std::log(1 + 1 / mu);
        CHECK(std::fabs(kernel_h(3, c, kNoPoly, mu) - first) < 1e-13);
    }
}

TEST_CASE("H at tiny mu: 1 to double precision, finite down to the smallest double") {
    // H(mu) - 1 = O(mu log(1/mu)) (the first-order term above: (c/2) mu
    // log(1 + 1/mu) for isotropic scattering, at most ~mu log(1/mu) for
    // every Psi), far below half an ulp of 1 for mu <= 1e-20.  The trapezoid
    // rule's upper limit t = e^18 / mu used to overflow t^2 below mu ~ 5e-147
    // (H was NaN there).
    for (int kind = 0; kind < 5; ++kind)
        for (double c : {0.3, 0.99, 1.0})
            for (double mu : {1e-20, 1e-60, 1e-99, 1e-101, 1e-146, 1e-200, 1e-300, 4.9e-324}) {
                CAPTURE(kind);
                CAPTURE(c);
                CAPTURE(mu);
                for (int coarse : {0, 1}) {
                    const double h = kernel_h(kind, c, kPoly, mu, coarse);
                    CHECK(std::isfinite(h));
                    CHECK(std::fabs(h - 1.0) <= 2.3e-16);  // within an ulp of 1
                }
            }
}

TEST_CASE("moments: isotropic alpha_0 = (2/c)(1 - sqrt(1 - c)); int Psi H = 1 - sqrt(K(0))") {
    for (double c : {0.01, 0.5, 0.9, 1.0}) {
        hf_psi P = hf_make_psi(HF_PSI_ISOTROPIC, c, kNoPoly);
        CHECK(hf_alpha(&P, 0, 0) == doctest::Approx((2 / c) * (1 - std::sqrt(1 - c))).epsilon(1e-10));
    }
    for (int kind = 0; kind < 5; ++kind)
        for (double c : {0.4, 1.0}) {
            const double* poly = kind == 4 ? kPoly : kNoPoly;
            hf_psi P = hf_make_psi(kind, c, poly);
            double lhs = 0;
            for (int k = 0; k < HF_NCOEF; ++k) lhs += P.a[k] * hf_alpha(&P, 2 * k, 0);
            double m0 = 0;
            for (int k = 0; k < 4; ++k) m0 += (kind == 4 ? poly[k] : P.a[k]) / (2 * k + 1);
            double a = std::max(0.0, 1 - 2 * m0);
            CAPTURE(kind);
            CAPTURE(c);
            CHECK(std::fabs(lhs - (1 - std::sqrt(a))) < 1e-9);
        }
    // Higher moments against the Nystrom solution (same quadrature there).
    IterH ref(0, 0.95, kNoPoly);
    for (int n : {1, 2, 5}) {
        double s = 0;
        for (std::size_t j = 0; j < ref.mu.size(); ++j) s += ref.wt[j] * std::pow(ref.mu[j], n) * ref.H[j];
        hf_psi P = hf_make_psi(0, 0.95, kNoPoly);
        CHECK(hf_alpha(&P, n, 0) == doctest::Approx(s).epsilon(1e-9));
    }
}

TEST_CASE("poly path (generic K) equals the lambert closed forms for the same Psi") {
    for (int kind = 0; kind < 3; ++kind) {
        hf_psi L = hf_make_psi(kind, 0.93, kNoPoly);
        double coeffs[4] = {L.a[0], L.a[1], L.a[2], L.a[3]};
        for (double mu : {0.02, 0.4, 1.0})
            CHECK(kernel_h(4, 0, coeffs, mu) == doctest::Approx(kernel_h(kind, 0.93, kNoPoly, mu)).epsilon(1e-11));
    }
    // Impossible characteristic function (1 - 2 int Psi < 0): NaN, not a number that looks valid.
    const double bad[4] = {0.8, 0, 0, 0};
    CHECK(std::isnan(kernel_h(4, 0, bad, 0.5)));
}

TEST_CASE("device (double and float) and host agree through estimate()") {
    const ModelInfo& model = find_model("hfunction");
    auto host = make_backend("host", Precision::Double);
    auto dev = make_backend("", Precision::Double);
    auto devf = make_backend("", Precision::Float);
    for (const char* qname : {"H", "moment"}) {
        const QuantityInfo& q = model.quantity(qname);
        PointBuilder builder(model, q);
        std::vector<std::map<std::string, double>> pts;
        for (double c : {0.0, 0.5, 1.0})
            // 1e-13 and 1e-200: below the rule's reach in float and in
            // double (H = 1 there; it was NaN).
            for (double mu : {0.0, 1e-200, 1e-13, 1e-5, 0.5, 1.0, 1e6})
                pts.push_back({{"mu", mu}, {"c", c}, {"n", 2}});
        for (int psi = 0; psi < 4; ++psi) {
            std::vector<int> opts = {psi};
            IntegrationSettings s;
            auto run = [&](Backend& b) {
                return estimate(b, model, q, opts, pts.size(),
                                [&](std::size_t k, double* out) { builder.build(pts[k], out); }, s);
            };
            auto a = run(*dev), b = run(*host), f = run(*devf);
            CHECK(a.method == Method::Quadrature);
            for (std::size_t k = 0; k < pts.size(); ++k) {
                CAPTURE(qname);
                CAPTURE(psi);
                CAPTURE(k);
                CHECK(std::isfinite(a.value[k]));
                CHECK(std::isfinite(f.value[k]));
                CHECK(a.value[k] == doctest::Approx(b.value[k]).epsilon(1e-11));
                // float: ~200 log/atan terms summed in single precision
                CHECK(f.value[k] == doctest::Approx(b.value[k]).epsilon(2e-5));
                // coarse-rule error estimate is conservative but small
                CHECK(a.stderr_[k] < 1e-6 * std::fabs(a.value[k]) + 1e-12);
            }
        }
    }
}

TEST_CASE("psi = poly: H, moment and H_inf refuse 2 int max(Psi, 0) > 1, by brute force") {
    // The oracle: int_0^1 max(Psi, 0) by the midpoint rule on 2^20 cells
    // (error ~1e-6 at a sign change), against the model's cell check for
    // coefficients drawn in the parameters' range [-10, 10] and near the
    // boundary; cases within 1e-5 of it are skipped.
    const ModelInfo& model = find_model("hfunction");
    const bool has_check = model.check_cell != nullptr;
    REQUIRE(has_check);
    const std::vector<int> poly = {HF_PSI_POLY};
    std::uint64_t state = 12345;
    auto uniform = [&state](double lo, double hi) {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        return lo + (hi - lo) * double(state >> 11) * 0x1.0p-53;
    };
    int refused = 0, accepted = 0;
    for (int trial = 0; trial < 400; ++trial) {
        const double scale = trial < 200 ? 10.0 : 1.0;
        double a[4];
        for (double& x : a) x = uniform(-scale, scale);
        if (trial % 3 == 0) a[2] = a[3] = 0;
        const int n = 1 << 20;
        double positive = 0;
        for (int k = 0; k < n; ++k) {
            const double x = (k + 0.5) / n, y = x * x;
            positive += std::max(0.0, a[0] + y * (a[1] + y * (a[2] + y * a[3]))) / n;
        }
        if (std::fabs(2 * positive - 1) < 1e-5) continue;
        double point[16] = {0};
        point[HF_PARAM_MU] = 0.5;
        for (int k = 0; k < 4; ++k) point[HF_PARAM_PSI_0 + k] = a[k];
        const bool valid = 2 * positive <= 1;
        (valid ? accepted : refused) += 1;
        for (const char* name : {"H", "moment", "H_inf"}) {
            CAPTURE(name);
            CAPTURE(a[0]);
            CAPTURE(a[1]);
            CAPTURE(a[2]);
            CAPTURE(a[3]);
            const std::string problem = model.check_cell(model.quantity(name), point, poly);
            CHECK(problem.empty() == valid);
            if (!valid) CHECK(problem.find("allowed: at most 1") != std::string::npos);
        }
        // K is defined for any Psi.
        CHECK(model.check_cell(model.quantity("K"), point, poly).empty());
        // Where the check accepts, the kernel's H is a number.
        if (valid) {
            hf_psi P = hf_make_psi(HF_PSI_POLY, 0, a);
            CHECK(std::isfinite(hf_h(&P, 0.5, 0)));
        }
    }
    CHECK(accepted > 40);
    CHECK(refused > 40);
    // The other characteristic functions are not restricted (c in [0, 1]).
    double point[16] = {0};
    point[HF_PARAM_PSI_0] = 0.6;
    for (int psi : {HF_PSI_LAMBERT0, HF_PSI_ISOTROPIC})
        CHECK(model.check_cell(model.quantity("H"), point, {psi}).empty());
}

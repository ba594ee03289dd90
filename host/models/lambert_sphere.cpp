// Registry entries and host compilation of the `hfunction` and
// `lambert-sphere` models (kernels/models/hfunction.h,
// kernels/models/lambert_sphere.h; docs/models/lambert-sphere.md).
#include "kernels/models/lambert_sphere.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <sstream>
#include <tuple>
#include <unordered_map>
#include <string>
#include <vector>

#include "host/core/text.h"
#include "host/models/registry.h"
#include "kernels/common/compat.h"
#include "kernels/common/estimator.h"  // BT_MAX_OPTIONS
#include "kernels/common/sampler.h"

namespace brdftab::detail {

namespace {

const char* kCitation =
    "E. d'Eon. An analytic BRDF for materials with spherical Lambertian scatterers. "
    "Computer Graphics Forum 40(4) (EGSR 2021).";

// int_0^1 max(Psi(x), 0) dx for Psi(x) = sum_k a[k] x^(2k), exactly up to
// rounding: Psi is a cubic P in y = x^2, monotone between the roots of P' in
// (0, 1), so each such piece holds at most one root of P (found by bisection);
// the antiderivative sum_k a[k] x^(2k+1)/(2k+1) is summed over the pieces
// where Psi > 0.  Without a root in (0, 1) and with Psi >= 0 this is
// sum_k a[k]/(2k+1), summed as the kernel sums m_0.
double psi_positive_integral(const double* a) {
    auto P = [a](double y) { return a[0] + y * (a[1] + y * (a[2] + y * a[3])); };
    auto F = [a](double x) {
        double sum = 0, power = x;
        for (int k = 0; k < 4; ++k, power *= x * x) sum += a[k] * power / double(2 * k + 1);
        return sum;
    };
    std::vector<double> ends = {0.0};  // in y: 0, the roots of P' and of P in (0, 1), 1
    {
        // P'(y) = a1 + 2 a2 y + 3 a3 y^2
        const double A = 3 * a[3], B = 2 * a[2], C = a[1];
        std::vector<double> turns;
        if (A == 0) {
            if (B != 0) turns.push_back(-C / B);
        } else {
            const double d = B * B - 4 * A * C;
            if (d >= 0) {
                turns.push_back((-B - std::sqrt(d)) / (2 * A));
                turns.push_back((-B + std::sqrt(d)) / (2 * A));
            }
        }
        std::sort(turns.begin(), turns.end());
        for (double t : turns)
            if (t > 0 && t < 1) ends.push_back(t);
        ends.push_back(1.0);
    }
    std::vector<double> cuts = {0.0};
    for (std::size_t k = 0; k + 1 < ends.size(); ++k) {
        double lo = ends[k], hi = ends[k + 1];
        const bool rising = P(hi) > P(lo);
        if ((P(lo) < 0) != (P(hi) < 0) && P(lo) != 0 && P(hi) != 0) {
            for (int it = 0; it < 200 && hi - lo > 0; ++it) {
                const double mid = 0.5 * (lo + hi);
                if (mid <= lo || mid >= hi) break;
                ((P(mid) < 0) == rising ? lo : hi) = mid;
            }
            cuts.push_back(0.5 * (lo + hi));
        }
    }
    cuts.push_back(1.0);
    if (cuts.size() == 2) return P(0.5) > 0 || (P(0.5) == 0 && P(0) > 0) ? F(1.0) : 0.0;
    double positive = 0;
    for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
        const double x0 = std::sqrt(cuts[k]), x1 = std::sqrt(cuts[k + 1]);
        if (P(0.5 * (cuts[k] + cuts[k + 1])) > 0) positive += F(x1) - F(x0);
    }
    return positive;
}

// psi = poly: Psi's coefficients must admit an H-function.  eq. 16 needs
// K(t) = 1 - 2 int_0^1 Psi(x)/(1 + x^2 t^2) dx >= 0 for every t; since
// 0 < 1/(1 + x^2 t^2) <= 1, K(t) >= 1 - 2 int max(Psi, 0), so 2 int_0^1
// max(Psi, 0) <= 1 is sufficient: every non-negative Psi of albedo
// 2 int Psi <= 1 and Psi's that are negative in places, as Psi1 of eq. 14.
// Beyond it the kernel returned NaN (H, moment) or inf (H_inf).  K itself
// is defined for any Psi and is not checked.
std::string check_hfunction_poly(const QuantityInfo& q, const double* point,
                                 const std::vector<int>& options) {
    if (q.id == HF_Q_K || options.size() <= HF_OPT_PSI || options[HF_OPT_PSI] != HF_PSI_POLY)
        return "";
    const double a[4] = {point[HF_PARAM_PSI_0], point[HF_PARAM_PSI_1], point[HF_PARAM_PSI_2],
                         point[HF_PARAM_PSI_3]};
    double m0 = 0;  // as hf_make_psi sums it
    for (int k = 0; k < 4; ++k) m0 += a[k] / double(2 * k + 1);
    const double positive = psi_positive_integral(a);
    if (1 - 2 * positive >= 0 && 1 - 2 * m0 >= 0) return "";
    return "psi = poly with psi_0 = " + number_text(a[0]) + ", psi_1 = " +
                    number_text(a[1]) + ", psi_2 = " + number_text(a[2]) + ", psi_3 = " +
                    number_text(a[3]) + " has no H-function: 2 int_0^1 max(Psi, 0) dmu = " +
                    number_text(2 * std::max(positive, m0)) +
                    "; allowed: at most 1 (then K(t) >= 0 for every t, as eq. 16 needs; e.g. "
                    "psi_0 in [-10, 0.5] with psi_1 = psi_2 = psi_3 = 0)";
}

ModelInfo hfunction_model() {
    ModelBuilder b("hfunction", 40);
    b.citation(std::string(kCitation) + " S. Chandrasekhar, Radiative Transfer (1960), ch. V.");
    b.description(
        "Chandrasekhar H-functions H(mu) for even polynomial characteristic functions "
        "(the Lambert-sphere Psi0, Psi1, Psi2 of d'Eon eqs. 13-15, isotropic scattering "
        "Psi = c/2, or user coefficients), from the Fock integral (eq. 16) by a trapezoidal "
        "rule in log t; exact at c = 1 (the log K singularity is integrated analytically).");
    b.kernel("models/hfunction.h", "hfunction_sample", &hfunction_sample);
    b.counts(HF_PARAM_COUNT, HF_OPT_COUNT, HF_Q_COUNT);
    b.parameter(HF_PARAM_MU,
                parameter_info("mu", "1",
                               "argument of H (cosine; values > 1 give the analytic continuation, "
                               "large values approach H(inf))",
                               0, 1e12, 1.0));
    b.parameter(HF_PARAM_C,
                parameter_info(
                    "c", "1", "single-scattering albedo (lambert0/1/2, isotropic; ignored by poly)",
                    0, 1, 1.0));
    b.parameter(HF_PARAM_N,
                parameter_info("n", "1", "moment order of alpha_n (integer)", 0, 16, 0.0)
                    .whole());
    b.parameter(HF_PARAM_PSI_0,
                parameter_info("psi_0", "1", "poly: coefficient of mu^0 in Psi", -10, 10, 0.0));
    b.parameter(HF_PARAM_PSI_1,
                parameter_info("psi_1", "1", "poly: coefficient of mu^2 in Psi", -10, 10, 0.0));
    b.parameter(HF_PARAM_PSI_2,
                parameter_info("psi_2", "1", "poly: coefficient of mu^4 in Psi", -10, 10, 0.0));
    b.parameter(HF_PARAM_PSI_3,
                parameter_info("psi_3", "1", "poly: coefficient of mu^6 in Psi", -10, 10, 0.0));
    b.option(HF_OPT_PSI, {"psi",
                          "characteristic function: d'Eon eqs. 13-15 (lambert0/1/2), isotropic "
                          "scattering c/2, or the polynomial psi_0 + psi_1 mu^2 + psi_2 mu^4 + "
                          "psi_3 mu^6, for H, moment and H_inf restricted to 2 int_0^1 max(Psi, 0) "
                          "dmu <= 1 (K(t) >= 0 for every t; refused otherwise)",
                          {"lambert0", "lambert1", "lambert2", "isotropic", "poly"},
                          "lambert0"});
    const std::vector<std::string> none;
    const std::vector<std::string> psi = {"psi"};
    b.quantity(QuantityInfo{"H", HF_Q_H,
                            "H(mu) from eq. 16 (trapezoid in log t, error from the "
                            "half-resolution rule)",
                            "1", QuantityKind::Quadrature, none, psi, "eqs. 13-20 (d'Eon)",
                            Method::Quadrature, 0});
    // H's trapezoid sum runs one work item per node on OpenCL devices
    // (kernels/models/hfunction.h, hfunction_h_node_*; docs/benchmarks.md,
    // "Node-parallel quadrature").  `moment` (24 H's per cell) keeps the usual kernel.
    b.quantity_by_id(HF_Q_H).node_parallel = {
        "hfunction_h_node_count", "hfunction_h_node_prepare", "hfunction_h_node_term",
        "hfunction_h_node_finish", HF_NODE_STATE, &hfunction_h_node_count};
    // Its two forms of a term (series below t = 1/2, K itself above) on
    // kernels of their own (node_parallel.h, "Split terms"; docs/benchmarks.md,
    // "Node-parallel quadrature").
    {
        NodeParallelFunctions& f = b.quantity_by_id(HF_Q_H).node_parallel;
        f.term_first = "hfunction_h_node_term_series";
        f.term_second = "hfunction_h_node_term_direct";
        f.host_split = &hfunction_h_node_split;
    }
    b.quantity(
        QuantityInfo{"moment", HF_Q_MOMENT,
                     "alpha_n = int_0^1 mu^n H(mu) dmu (24-point Gauss-Legendre in sqrt(mu))", "1",
                     QuantityKind::Quadrature, none, psi, "eqs. 13-20 (d'Eon)", Method::Quadrature, 0});
    b.quantity(QuantityInfo{"H_inf", HF_Q_HINF, "H(inf) = 1/sqrt(K(0)) (inf when K(0) = 0)", "1",
                            QuantityKind::ClosedForm, none, psi, "eq. 32 (d'Eon)", Method::ClosedForm,
                            0});
    b.quantity(QuantityInfo{"K", HF_Q_K, "K(t) at t = mu (diagnostic; closed forms or series)", "1",
                            QuantityKind::ClosedForm, none, psi, "eqs. 17-20 (d'Eon)",
                            Method::ClosedForm, 0});
    b.check_cell(&check_hfunction_poly);

    // Float against double (registry.h, docs/precision.md).
    b.float_vs_double(HF_Q_H, 1.5e-07);
    b.float_vs_double(HF_Q_HINF, 4.9e-07);
    b.float_vs_double(HF_Q_MOMENT, 2.5e-07);

    b.bench({"H", true});
    return b.build();
}

// The remainder's order range must be non-empty (the kernel returns NaN
// otherwise, as a last resort).
std::string check_lambert_sphere_point(const QuantityInfo& q,
                                       const std::map<std::string, double>& params) {
    if (q.id != LS_Q_BRDF_MC || params.at("order") != -2) return "";
    const double max_order = params.at("max_order"), tail_order = params.at("tail_order");
    if (tail_order > max_order) return "";
    std::ostringstream s;
    s << "parameter 'tail_order' (" << tail_order << ") must exceed 'max_order' (" << max_order
      << ") for brdf_mc with order = -2 (the remainder covers orders max_order+1..tail_order)";
    return s.str();
}

// The derived slots of brdf_analytic / brdf_three_term
// (kernels/models/lambert_sphere.h, LS_DERIVED_K and LS_DERIVED_H): the exact
// constants l, m, A..F solved once per distinct c, and the exact H-functions
// once per distinct (H-function, rule, mu, c), instead of in every cell and
// both quadrature batches of the kernel.  The values are those
// ls_fill_derived writes (the same kernel functions, memoised), so the host
// path's tables are unchanged bit for bit.
CellDerivation derive_lambert_sphere(const QuantityInfo& q, const std::vector<int>& options) {
    int o[BT_MAX_OPTIONS] = {0};
    for (std::size_t k = 0; k < options.size() && k < BT_MAX_OPTIONS; ++k) o[k] = options[k];
    if (!ls_reads_derived(q.id)) return {};
    const bool constants = ls_reads_derived_constants(q.id, o) != 0;
    const int h_count = ls_h_slot_count(q.id);
    using Constants = std::array<double, 8>;
    auto bits = [](double x) {
        std::uint64_t b;
        std::memcpy(&b, &x, sizeof b);
        return b;
    };
    struct Memo {
        std::unordered_map<std::uint64_t, Constants> constants;              // by c
        std::map<std::tuple<int, std::uint64_t, std::uint64_t>, double> h;  // (kind, rule), mu, c
    };
    auto memo = std::make_shared<Memo>();
    return {LS_DERIVED_COUNT, [memo, constants, h_count, bits](double* p) {
                std::fill_n(p + LS_DERIVED_K, LS_DERIVED_COUNT, 0.0);
                const double c = p[LS_PARAM_C];
                if (constants) {
                    auto it = memo->constants.find(bits(c));
                    if (it == memo->constants.end()) {
                        ls_fill_constants(p);
                        Constants k;
                        std::copy_n(p + LS_DERIVED_K, 8, k.begin());
                        memo->constants.emplace(bits(c), k);
                    } else {
                        std::copy(it->second.begin(), it->second.end(), p + LS_DERIVED_K);
                    }
                }
                for (int rule = 0; rule < 2; ++rule)
                    for (int j = 0; j < h_count; ++j) {
                        const int kind = ls_h_slot_kind(j);
                        const double mu = ls_h_slot_mu(p, j);
                        const auto key = std::make_tuple(2 * kind + rule, bits(mu), bits(c));
                        auto it = memo->h.find(key);
                        if (it == memo->h.end())
                            it = memo->h.emplace(key, ls_h_exact(kind, mu, c, rule)).first;
                        p[LS_DERIVED_H + 6 * rule + j] = it->second;
                    }
            }};
}

ModelInfo lambert_sphere_model() {
    ModelBuilder b("lambert-sphere", 50);
    b.citation(kCitation);
    b.description(
        "Semi-infinite medium of sparse Lambertian spheres of albedo c (dusty / porous "
        "materials): the exact BRDF by random walks per scattering order, and d'Eon's "
        "analytic model with exact or fitted H-functions, its fast variant and albedo maps.");
    b.kernel("models/lambert_sphere.h", "lambert_sphere_sample", &lambert_sphere_sample);
    b.counts(LS_PARAM_COUNT, LS_OPT_COUNT, LS_Q_COUNT);
    b.parameter(
        LS_PARAM_C,
        parameter_info("c", "1", "particle (single-scattering) albedo; kd for c_fit", 0, 1, 1.0));
    b.parameter(
        LS_PARAM_ORDER,
        parameter_info(
            "order", "1",
            "random walks: 0 all orders 1..max_order, -1 orders >= 2 only, k >= 1 order k only "
            "(order k scales exactly as c^k); -2 = truncation remainder: albedo_mc/kd_mc the "
            "weight still inside the medium after max_order scatterings, brdf_mc the BRDF of "
            "orders max_order+1..tail_order of the same walks",
            -2, 100000, 0.0)
            .whole());
    b.parameter(
        LS_PARAM_MAX_ORDER,
        parameter_info("max_order", "1", "random walks: truncation order (c = 1 converges slowly)",
                       1, 100000, 1000.0)
                    .whole());
    b.parameter(LS_PARAM_MODE,
                parameter_info("mode", "1",
                               "-1: value at phi; 0, 1, 2: Fourier coefficient f^(m) of eq. 9 "
                               "(f = sum_m f^(m) cos(m phi))",
                               -1, 8, -1.0)
                    .whole());
    b.parameter(
        LS_PARAM_TAIL_ORDER,
        parameter_info("tail_order", "1",
                       "brdf_mc with order = -2: last order of the truncation remainder (orders "
                       "max_order+1..tail_order); must exceed max_order",
                       2, 10000000, 100000.0)
            .whole());
    b.option(LS_OPT_PHASE_MC,
             {"phase_mc",
              "random walks: exact Lambert-sphere phase function (eqs. 1, 5), or its 3-term "
              "Legendre truncation (eqs. 2, 8; signed weights, noisy for c near 1)",
              {"exact", "three-term"},
              "exact"});
    b.option(LS_OPT_COS_PHI,
             {"cos_phi",
              "analytic/fit: weight of the multiple-scattering cos(phi) mode eq. 22 - eq. 28: "
              "'corrected' (x2, what the Monte Carlo reference shows) or 'paper' (x1, as printed)",
              {"corrected", "paper"},
              "corrected"});
    b.option(
        LS_OPT_FM1,
        {"fm1",
         "brdf_fit: cos(phi) mode from eqs. 22, 28 with fitted H1, l, m, or the fast fit eq. 29",
         {"eq22", "eq29"},
         "eq22"});
    b.option(LS_OPT_H1_FIT,
             {"h1_fit",
              "brdf_fit: H1 fit eqs. 23-25 as printed (up to 11 % off the exact H1), normalised by "
              "Hc1(1) (9 %), or 'power' = H1(1)^(mu^e(mu)) with eq. 24's exponent e and eq. 25 "
              "(our reading, 0.24 %)",
              {"printed", "normalised", "power"},
              "printed"});
    b.option(LS_OPT_CONSTANTS,
             {"constants",
              "brdf_analytic, constant: the constants l, m (eq. 22) and A..F (eq. 30) 'exact' "
              "(Horak-Chandrasekhar psi-function system solved numerically, "
              "kernels/models/horak_chandrasekhar.h) or the paper's 'fit' (eqs. 26-27, 33-37)",
              {"exact", "fit"},
              "exact"});
    b.option(LS_OPT_CONSTANT, {"constant",
                               "quantity constant: which constant",
                               {"l", "m", "A", "B", "C", "D", "E", "F"},
                               "l"});
    const std::vector<std::string> dirs = {"theta_i", "phi_i", "theta_o", "phi_o"};
    const std::vector<std::string> walk_opts = {"phase_mc"};
    const std::vector<std::string> an_opts = {"cos_phi", "constants"};
    const std::vector<std::string> fit_opts = {"cos_phi", "fm1", "h1_fit"};
    b.quantity(
        QuantityInfo{"phase",
                     LS_Q_PHASE,
                     "phase function p(cos theta_o); theta_o is the scattering angle (0 = forward)",
                     "1/sr",
                     QuantityKind::ClosedForm,
                     {"theta_o"},
                     {},
                     "eq. 1",
                     Method::ClosedForm,
                     0});
    b.quantity(QuantityInfo{"brdf_mc", LS_Q_BRDF_MC,
                            "exact BRDF: random walks with the exact phase function and next-event "
                            "estimation, per scattering order (parameters order, max_order, mode)",
                            "1/sr", QuantityKind::Integral, dirs, walk_opts,
                            "eqs. 1, 5, 10 (order 1)", Method::MonteCarlo, 8});
    b.quantity(QuantityInfo{"albedo_mc",
                            LS_Q_ALBEDO_MC,
                            "directional albedo E(mu_i) by random walks, per scattering order",
                            "1",
                            QuantityKind::Integral,
                            {"theta_i"},
                            walk_opts,
                            "eqs. 1, 5",
                            Method::MonteCarlo,
                            8});
    b.quantity(
        QuantityInfo{"brdf_analytic", LS_Q_BRDF_ANALYTIC,
                     "d'Eon's model with exact H0, H1 (eq. 16) and exact (default) or fitted "
                     "constants l, m, A-F",
                     "1/sr", QuantityKind::Quadrature, dirs, an_opts,
                     "eqs. 9-12, 16, 18-19, 22, 26-28, 30, 33-38", Method::Quadrature, 0});
    b.quantity(QuantityInfo{"brdf_fit", LS_Q_BRDF_FIT,
                            "d'Eon's model entirely with fitted functions", "1/sr",
                            QuantityKind::ClosedForm, dirs, fit_opts,
                            "eqs. 9-12, 22-31, 33-38 (29 with fm1=eq29)", Method::ClosedForm, 0});
    b.quantity(QuantityInfo{"brdf_fast",
                            LS_Q_BRDF_FAST,
                            "fast variant",
                            "1/sr",
                            QuantityKind::ClosedForm,
                            dirs,
                            {},
                            "eqs. 40, 41",
                            Method::ClosedForm,
                            0});
    b.quantity(QuantityInfo{"brdf_single",
                            LS_Q_BRDF_SINGLE,
                            "exact single scattering",
                            "1/sr",
                            QuantityKind::ClosedForm,
                            dirs,
                            {},
                            "eq. 10",
                            Method::ClosedForm,
                            0});
    b.quantity(QuantityInfo{"kd_fit",
                            LS_Q_KD_FIT,
                            "spherical albedo kd from c (fit)",
                            "1",
                            QuantityKind::ClosedForm,
                            {},
                            {},
                            "eq. 40",
                            Method::ClosedForm,
                            0});
    b.quantity(QuantityInfo{"kd_mc",
                            LS_Q_KD_MC,
                            "spherical (bond) albedo 2 int E(mu) mu dmu by random walks",
                            "1",
                            QuantityKind::Integral,
                            {},
                            walk_opts,
                            "eqs. 1, 5",
                            Method::MonteCarlo,
                            8});
    b.quantity(
        QuantityInfo{"brdf_three_term",
                     LS_Q_BRDF_THREE_TERM,
                     "exact single scattering + the exact multiple scattering of the three-term "
                     "phase function (modes 0-2, exact H and constants): d'Eon's construction "
                     "without approximations beyond the phase truncation",
                     "1/sr",
                     QuantityKind::Quadrature,
                     dirs,
                     {},
                     "eqs. 8-12, 16, 22, 30 + Horak-Chandrasekhar mode 2",
                     Method::Quadrature,
                     0});
    b.quantity(
        QuantityInfo{"constant",
                     LS_Q_CONSTANT,
                     "one of the constants l, m, A-F of eqs. 22, 30 (option constant), exact or "
                     "fitted (option constants)",
                     "1",
                     QuantityKind::ClosedForm,
                     {},
                     {"constants", "constant"},
                     "eqs. 22, 26-27, 30, 33-37",
                     Method::ClosedForm,
                     0});
    b.quantity(QuantityInfo{"c_fit",
                            LS_Q_C_FIT,
                            "particle albedo c from kd (fit); kd is given as c",
                            "1",
                            QuantityKind::ClosedForm,
                            {},
                            {},
                            "eq. 39",
                            Method::ClosedForm,
                            0});
    b.check_point(&check_lambert_sphere_point);
    b.derive(&derive_lambert_sphere);

    // brdf_mc's walks run walk-parallel on OpenCL devices (Monte Carlo;
    // kernels/common/walk_parallel.h): measured faster per CPU-second than
    // the usual kernel (docs/benchmarks.md, "Walk-parallel launch").  No
    // forced inlining for this model: with it, preset tables came out wrong
    // and PoCL crashed in the in-kernel Horak-Chandrasekhar solve
    // (docs/contributing.md); the walk-parallel build forces it itself.
    b.quantity_by_id(LS_Q_BRDF_MC).walk_parallel = {"ls_brdf_mc_state", "ls_brdf_mc_setup",
                                                    "ls_brdf_mc_begin", "ls_brdf_mc_step",
                                                    "ls_brdf_mc_value"};

    // Float against double (registry.h, docs/precision.md).
    b.float_vs_double(LS_Q_ALBEDO_MC, 4.2e-05);
    b.float_vs_double(LS_Q_BRDF_ANALYTIC, 6.4e-06);
    b.float_vs_double(LS_Q_BRDF_FAST, 1.3e-06);
    b.float_vs_double(LS_Q_BRDF_FIT, 1.6e-06);
    b.float_vs_double(LS_Q_BRDF_MC, 0.0015, "Fourier modes near zero, formed by cancellation");
    b.float_vs_double(LS_Q_BRDF_SINGLE, 6.4e-06);
    b.float_vs_double(LS_Q_BRDF_THREE_TERM, 6.2e-06);
    b.float_vs_double(LS_Q_CONSTANT, 0.00012,
                      "the paper's fits in float; the exact constants are solved in double");
    b.float_vs_double(LS_Q_KD_FIT, 1.7e-05);
    b.float_vs_double(LS_Q_KD_MC, 1.6e-07);

    b.bench({"brdf_mc"});
    return b.build();
}

BRDFTAB_REGISTER_MODEL(hfunction_model);
BRDFTAB_REGISTER_MODEL(lambert_sphere_model);

}  // namespace

}  // namespace brdftab::detail

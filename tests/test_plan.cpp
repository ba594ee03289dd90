// test_plan.cpp — the planner's error model, fits and choice (host/plan/plan.h).
//
// Oracles from outside the code under test:
//   - linear interpolation of a smooth f with step dx has the leading error
//     dx^2/8 |f''| at the midpoint of each interval (the remainder of the
//     two-point Lagrange interpolant), so the fit must give p = 2 and
//     C = max|f''| / 8 (times the axis span squared);
//   - Catmull-Rom at an interval's midpoint has the weights (-1, 9, 9, -1)/16
//     of the four-point Lagrange cubic, error 3 dx^4 / 128 |f''''| (p = 4);
//     elsewhere its error for f = x^3 is s (2s - 1)(s - 1) dx^3 f''' / 6
//     (worked out by hand from the Catmull-Rom weights), p = 3;
//   - on a log axis ln(x) is linear in the warped coordinate: exact;
//   - the standard error of a Monte Carlo mean falls as N^-1/2;
//   - float16 rounding checked against the file writer's own conversion
//     (host/io/half_float.h), an independent implementation;
//   - Pareto fronts and choices worked out by hand.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "host/core/error.h"
#include "host/engine/engine.h"
#include "host/engine/evaluate.h"
#include "host/models/registry.h"
#include "host/io/half_float.h"
#include "host/plan/plan.h"
#include "host/spec/spec.h"

using namespace brdftab;

namespace {

// Max |interpolated - f| over `probes` (t values) of a 1-D table of f on `axis`
// with `count` nodes.
double max_interp_error(const Axis& axis, std::size_t count, double (*f)(double),
                        const std::vector<double>& probes, Interpolation interp) {
    const Axis a = make_axis(axis.name, axis.unit, axis.min, axis.max, count, axis.spacing);
    std::vector<double> nodes;
    for (double x : a.values) nodes.push_back(f(x));
    const std::vector<double> got = interpolate_line(a, nodes, probes, interp);
    double m = 0;
    for (std::size_t k = 0; k < probes.size(); ++k)
        m = std::max(m, std::fabs(got[k] - f(a.warp(probes[k]))));
    return m;
}

// Probes at fraction s of every interior interval (the first and last
// intervals use extrapolated ghost nodes for Catmull-Rom: left out).
std::vector<double> interior_probes(std::size_t count, std::vector<double> fractions) {
    std::vector<double> t;
    const double h = 1.0 / double(count - 1);
    for (std::size_t k = 1; k + 2 < count; ++k)
        for (double s : fractions) t.push_back((k + s) * h);
    return t;
}

double exp_fn(double x) { return std::exp(x); }
double log_fn(double x) { return std::log(x); }
double cube_fn(double x) { return x * x * x; }

Candidate hand_candidate(double seconds, double error, double bytes) {
    Candidate c;
    c.seconds = seconds;
    c.error_max = error;
    c.error_rms = error / 3;
    c.bytes = bytes;
    return c;
}

}  // namespace

TEST_CASE("fit_power_law recovers an exact power law and skips unusable points") {
    const PowerFit f = fit_power_law({0.1, 0.05, 0.025, 0.0}, {3 * 0.01, 3 * 0.0025, 3 * 0.000625, 0.0});
    REQUIRE(f.valid);
    CHECK(f.points == 3);
    CHECK(f.p == doctest::Approx(2.0).epsilon(1e-12));
    CHECK(f.c == doctest::Approx(3.0).epsilon(1e-12));
    CHECK(f.eval(0.2) == doctest::Approx(0.12).epsilon(1e-12));
    CHECK_FALSE(fit_power_law({0.1}, {0.5}).valid);
    CHECK_FALSE(fit_power_law({0.1, 0.05}, {0.0, 0.0}).valid);  // exact interpolation
    const PowerFit q = fit_power_law_fixed({100, 400}, {0.1, 0.05}, -0.5);
    CHECK(q.c == doctest::Approx(1.0).epsilon(1e-12));
}

TEST_CASE("linear interpolation: p = 2 and C = max|f''| / 8 on exp over [0, 1]") {
    const Axis axis = make_axis("x", "1", 0.0, 1.0, 5, Spacing::Linear);
    AxisFit fit;
    for (std::size_t n : {17u, 33u, 65u}) {
        LevelErrors e;
        e.count = n;
        e.h = 1.0 / double(n - 1);
        e.max_abs = e.max_rel = max_interp_error(axis, n, exp_fn, probe_positions(n), Interpolation::Linear);
        e.rms_abs = e.rms_rel = e.max_abs / 2;
        fit.levels.push_back(e);
    }
    fit_axis(fit);
    REQUIRE(fit.max_abs.valid);
    CHECK(fit.max_abs.p == doctest::Approx(2.0).epsilon(0.02));
    // The worst midpoint is that of the last interval, f'' = e^(1 - dx/2):
    // C -> e / 8 as dx -> 0, within 3 % at these steps.
    CHECK(fit.max_abs.c == doctest::Approx(std::exp(1.0) / 8).epsilon(0.03));
}

TEST_CASE("linear interpolation on a warped axis acts in the warped coordinate") {
    // ln(x) on a log axis is linear in t: the interpolation is exact, and the
    // fit reports no usable level rather than a made-up exponent.
    const Axis axis = make_axis("x", "1", 1.0, 100.0, 5, Spacing::Log);
    for (std::size_t n : {5u, 9u})
        CHECK(max_interp_error(axis, n, log_fn, probe_positions(n), Interpolation::Linear) < 1e-12);
    // On a linear axis over the same range it is not.
    const Axis lin = make_axis("x", "1", 1.0, 100.0, 5, Spacing::Linear);
    CHECK(max_interp_error(lin, 9, log_fn, probe_positions(9), Interpolation::Linear) > 1e-2);
}

TEST_CASE("Catmull-Rom: p = 4 at midpoints, p = 3 elsewhere in the interval") {
    const Axis axis = make_axis("x", "1", 0.0, 1.0, 5, Spacing::Linear);
    std::vector<double> h, mid, quarter;
    for (std::size_t n : {17u, 33u, 65u}) {
        h.push_back(1.0 / double(n - 1));
        mid.push_back(max_interp_error(axis, n, exp_fn, interior_probes(n, {0.5}), Interpolation::Cubic));
        quarter.push_back(max_interp_error(axis, n, exp_fn, interior_probes(n, {0.25, 0.5, 0.75}),
                                           Interpolation::Cubic));
    }
    const PowerFit fm = fit_power_law(h, mid), fq = fit_power_law(h, quarter);
    CHECK(fm.p == doctest::Approx(4.0).epsilon(0.03));
    // 3/128 max|f''''| over the interior midpoints, f'''' = e^x <= e.
    CHECK(fm.c == doctest::Approx(3 * std::exp(1.0) / 128).epsilon(0.1));
    CHECK(fq.p == doctest::Approx(3.0).epsilon(0.03));
    // At s = 1/4 the hand-derived error is |s (2s - 1)(s - 1)| / 6 f''' dx^3
    // = (3/32) / 6 f''' dx^3.
    CHECK(fq.c == doctest::Approx(3.0 / 32 / 6 * std::exp(1.0)).epsilon(0.1));

    // f = x^3 on [0, 1]: f''' = 6 everywhere, error exactly (3/32) dx^3 at
    // s = 1/4 of every interior interval.
    const std::size_t n = 9;
    const double dx = 1.0 / 8;
    CHECK(max_interp_error(axis, n, cube_fn, interior_probes(n, {0.25}), Interpolation::Cubic) ==
          doctest::Approx(3.0 / 32 * dx * dx * dx).epsilon(1e-9));
    CHECK(max_interp_error(axis, n, cube_fn, interior_probes(n, {0.5}), Interpolation::Cubic) < 1e-14);
}

TEST_CASE("Monte Carlo standard error falls as N^-1/2 (q = 0.5)") {
    // Synthetic integrands x^k, k = 1..8, on [0, 1], estimated with N
    // uniform samples; the largest standard error over the "cells" per N.
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<double> ns, max_se;
    for (int n : {1024, 4096, 16384, 65536}) {
        double worst = 0;
        for (int k = 1; k <= 8; ++k) {
            double s = 0, s2 = 0;
            for (int i = 0; i < n; ++i) {
                const double v = std::pow(u(rng), k);
                s += v, s2 += v * v;
            }
            const double mean = s / n, var = (s2 / n - mean * mean) * n / (n - 1);
            worst = std::max(worst, std::sqrt(var / n));
        }
        ns.push_back(n), max_se.push_back(worst);
    }
    const PowerFit f = fit_power_law(ns, max_se);
    CHECK(-f.p == doctest::Approx(0.5).epsilon(0.05));
    // k = 1: variance of x is 1/12: stderr = 1/sqrt(12 N); larger k have less.
    CHECK(fit_power_law_fixed(ns, max_se, -0.5).c == doctest::Approx(1 / std::sqrt(12.0)).epsilon(0.05));
}

TEST_CASE("storage rounding bounds the stored types' real rounding") {
    const StorageRounding h = storage_rounding(StoredType::Float16);
    CHECK(h.rel == std::ldexp(1.0, -11));
    CHECK(h.max_value == 65504.0);
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> e(-30, 15);
    double worst_ratio = 0;
    for (int i = 0; i < 20000; ++i) {
        const double v = std::ldexp(1.0 + std::generate_canonical<double, 53>(rng), int(e(rng)));
        const double err = std::fabs(half_to_double(half_bits(v)) - v);
        CHECK(err <= std::max(h.rel * v, h.abs));
        if (v > 1e-4) worst_ratio = std::max(worst_ratio, err / v);
    }
    CHECK(worst_ratio > 0.9 * h.rel);  // the bound is reached, not loose
    const StorageRounding f = storage_rounding(StoredType::Float32);
    const double v = 1.0 + std::ldexp(1.0, -24) * 0.999;
    CHECK(std::fabs(double(float(v)) - v) <= f.rel * v);
}

TEST_CASE("Pareto front and choice on hand-made candidates") {
    // (seconds, error, bytes)
    std::vector<Candidate> c = {
        hand_candidate(1, 1e-2, 100),  // 0: fastest, least accurate
        hand_candidate(2, 1e-3, 400),  // 1
        hand_candidate(2, 2e-3, 400),  // 2: dominated by 1
        hand_candidate(2, 1e-3, 200),  // 3: dominates 1 (fewer bytes)
        hand_candidate(8, 1e-5, 1600), // 4
        hand_candidate(9, 1e-4, 1600), // 5: dominated by 4
    };
    const std::vector<Candidate> front = pareto_front(c);
    REQUIRE(front.size() == 3);
    CHECK(front[0].seconds == 1);
    CHECK(front[1].bytes == 200);
    CHECK(front[2].error_max == 1e-5);

    PlanTarget t;
    t.accuracy = 1e-3;
    REQUIRE(choose_plan(c, t));
    CHECK(*choose_plan(c, t) == 3);  // candidates 1 and 3 tie on time: fewer bytes
    t.accuracy = 5e-5;
    CHECK(*choose_plan(c, t) == 4);
    t.accuracy = 1e-6;
    CHECK_FALSE(choose_plan(c, t));
    t.accuracy.reset();
    t.budget = 5;
    CHECK(*choose_plan(c, t) == 1);  // 1e-3 at 2 s (1 and 3 tie: the first)
    t.budget = 100;
    CHECK(*choose_plan(c, t) == 4);
    t.budget = 0.5;
    CHECK_FALSE(choose_plan(c, t));
}

TEST_CASE("targets: bad values are input errors") {
    PlanTarget t;
    CHECK_NOTHROW(check_target(t));
    t.accuracy = 0.0;
    CHECK_THROWS_WITH_AS(check_target(t), doctest::Contains("--accuracy must be a finite number > 0"),
                         InputError);
    t.accuracy = -1e-3;
    CHECK_THROWS_AS(check_target(t), InputError);
    t.accuracy = std::nan("");
    CHECK_THROWS_AS(check_target(t), InputError);
    t.accuracy = 1e-3;
    t.budget = 10.0;
    CHECK_THROWS_WITH_AS(check_target(t), doctest::Contains("exclude each other"), InputError);
    t.accuracy.reset();
    t.budget = 0.0;
    CHECK_THROWS_WITH_AS(check_target(t), doctest::Contains("--budget must be"), InputError);
}

TEST_CASE("balanced counts and predictions follow the fits") {
    TablePilot p;
    p.table = "t";
    p.kind = QuantityKind::ClosedForm;
    p.axes = {make_axis("theta_i", "deg", 0, 80, 9, Spacing::Linear),
              make_axis("theta_o", "deg", 0, 80, 9, Spacing::Linear)};
    p.max_value = 2;
    p.rel_floor = 2e-3;
    for (double c : {1.0, 4.0}) {
        AxisFit f;
        f.axis = "a";
        LevelErrors l;
        l.count = 9, l.h = 0.125, l.max_rel = l.max_abs = c * 0.125 * 0.125;
        f.levels = {l};
        f.max_rel = f.max_abs = PowerFit{c, 2.0, true, 3};
        f.rms_rel = f.rms_abs = PowerFit{c / 3, 2.0, true, 3};
        p.linear.push_back(f);
        p.cubic.push_back(f);
    }
    IntegrationFit cost;
    cost.seconds_per_cell = 1e-6;
    p.integration = {cost};
    PlanTarget t;
    // Each axis gets 1e-3 / 2: h_a = sqrt(5e-4 / C_a).
    const std::vector<std::size_t> n = balanced_counts(p, t, 1e-3);
    CHECK(n[0] == std::size_t(1 + std::ceil(1 / std::sqrt(5e-4 / 1.0))));
    CHECK(n[1] == std::size_t(1 + std::ceil(1 / std::sqrt(5e-4 / 4.0))));
    const TablePlan tp = predict_table(p, t, n, Method::ClosedForm, 0, StoredType::Float32);
    CHECK(tp.interpolation_max <= 1e-3);
    CHECK(tp.interpolation_max > 0.9e-3);
    CHECK(tp.storage_max == doctest::Approx(std::ldexp(1.0, -24)));
    CHECK(tp.error_max == doctest::Approx(tp.interpolation_max + tp.storage_max));
    CHECK(tp.seconds == doctest::Approx(double(n[0] * n[1]) * 1e-6 +
                                        write_seconds(double(n[0] * n[1]), StoredType::Float32, 6, false, false)));
    // float16 of values up to 2 with a floor of 2e-3: no value is subnormal
    // relative to the floor (2^-25 / 2e-3 < 2^-11): 2^-11.
    const TablePlan th = predict_table(p, t, n, Method::ClosedForm, 0, StoredType::Float16);
    CHECK(th.storage_max == std::ldexp(1.0, -11));
    // A floor of 1e-6 lets subnormals count: 2^-25 / 1e-6 = 0.0298.
    p.rel_floor = 1e-6;
    CHECK(predict_table(p, t, n, Method::ClosedForm, 0, StoredType::Float16).storage_max ==
          doctest::Approx(std::ldexp(1.0, -25) / 1e-6));
    p.rel_floor = 2e-3;
    p.max_value = 1e5;  // beyond float16's range
    CHECK(std::isinf(predict_table(p, t, n, Method::ClosedForm, 0, StoredType::Float16).error_max));
}

TEST_CASE("the planned spec parses and carries the plan, without the comments") {
    const std::string text = R"(# a comment that must not survive
model = "rough-dielectric"
[parameters]
distribution = "ggx"
eta = 1.5
[[axes]]
name = "mu_i"
range = [0.1, 1.0]
count = 5
[[axes]]
name = "alpha"
range = [0.01, 1.0]
count = 5
spacing = "quadratic"
[[tables]]
name = "albedo_r"
quantity = "albedo_r"
[integration]
method = "rqmc"
tolerance = 1e-3
samples = 1024
max_samples = 2048
[output]
type = "float32"
compression = 4
)";
    const Spec spec = parse_spec_string(text, "mini.toml");
    Candidate c;
    c.method = Method::MonteCarlo;
    c.samples = 4096;
    c.stored_type = StoredType::Float16;
    TablePlan tp;
    tp.counts = {12, 7};
    c.tables = {tp};
    const std::string out = planned_spec_text(spec, {0}, c, {"Planned for a test."});
    CHECK(out.rfind("# Planned for a test.\n", 0) == 0);
    CHECK(out.find("a comment") == std::string::npos);
    const Spec planned = parse_spec_string(out, "planned.toml");
    REQUIRE(planned.tables.size() == 1);
    CHECK(planned.tables[0].axes[0].count == 12);
    CHECK(planned.tables[0].axes[1].count == 7);
    CHECK(planned.tables[0].axes[1].spacing == Spacing::Quadratic);
    CHECK(planned.tables[0].axes[1].min == 0.01);
    CHECK(planned.integration.method == Method::MonteCarlo);
    CHECK(planned.integration.samples == 4096);
    CHECK(planned.integration.tolerance == 0);
    CHECK(planned.integration.max_samples >= 4096);
    CHECK(planned.output.stored_type == StoredType::Float16);
    CHECK(planned.output.compression == 4);  // other keys kept
    CHECK(planned.tables[0].fixed.at("eta") == 1.5);
}

TEST_CASE("anchored fits cap the exponent and pass through the finest level") {
    AxisFit fit;
    // A pre-asymptotic steep fall, 1e-2, 1e-3, 1e-4 at h = 1/4, 1/8, 1/16
    // (p = 3.3), read as a linear interpolation's (order 2).
    for (double h : {0.25, 0.125, 0.0625}) {
        LevelErrors l;
        l.h = h;
        l.max_abs = l.rms_abs = l.max_rel = l.rms_rel = 1e-2 * std::pow(10.0, -std::log2(0.25 / h));
        fit.levels.push_back(l);
    }
    fit_axis(fit, 2.0);
    CHECK(fit.max_abs.p == 2.0);
    CHECK(fit.max_abs.eval(0.0625) == doctest::Approx(1e-4));
    // Levels below three times their reference noise are left out.
    AxisFit noisy = fit;
    for (LevelErrors& l : noisy.levels) l.noise = 1e-3;
    fit_axis(noisy, 2.0);
    CHECK(noisy.max_abs.points == 1);
    CHECK_FALSE(noisy.max_abs.valid);
}

TEST_CASE("pilot on the host backend: a smooth closed form converges at the interpolation's order") {
    // The GGX BRDF in the plane of incidence is smooth on [0, 80] deg: the
    // fitted exponents must be the interpolations' orders (2; Catmull-Rom
    // pre-asymptotic, between 2 and its order 3).
    const Spec spec = parse_spec_file(std::string(BT_SOURCE_DIR) + "/tests/data/plan_rough_dielectric.toml");
    auto backend = make_backend("host", Precision::Double);
    const TablePilot p = run_pilot(spec, 0, *backend, PilotOptions{});
    REQUIRE(p.linear.size() == 2);
    for (std::size_t a = 0; a < 2; ++a) {
        CHECK(p.linear[a].levels.size() == 3);
        REQUIRE(p.linear[a].max_rel.valid);
        CHECK(p.linear[a].max_rel.p == doctest::Approx(2.0).epsilon(0.1));
        REQUIRE(p.cubic[a].max_rel.valid);
        CHECK(p.cubic[a].max_rel.p > 2.3);
        CHECK(p.cubic[a].max_rel.p <= 3.0);
    }
    REQUIRE(p.integration.size() == 1);
    CHECK(p.integration[0].seconds_per_cell > 0);
    PlanTarget t;
    t.accuracy = 1e-2;
    const std::vector<Candidate> front = pareto_front(make_candidates({p}, t));
    const auto choice = choose_plan(front, t);
    REQUIRE(choice);
    CHECK(front[*choice].error_max <= 1e-2);
    // Finer than the spec's 9 x 9 (whose measured linear error is ~4e-2).
    CHECK(front[*choice].tables[0].counts[0] > 9);
}

TEST_CASE("expected_max_error: the median of the largest of M normal errors") {
    // One cell: the median of |N(0, s^2)| is 0.6745 s.
    CHECK(expected_max_error({2.0}, 1) == doctest::Approx(2 * 0.6744897501960817).epsilon(1e-6));
    // 1000 cells with two stderr levels, against a simulation.
    const std::vector<double> sigma = {1.0, 0.1};
    std::mt19937_64 rng(11);
    std::normal_distribution<double> g(0, 1);
    std::vector<double> maxima;
    for (int trial = 0; trial < 2001; ++trial) {
        double m = 0;
        for (int c = 0; c < 1000; ++c) m = std::max(m, std::fabs(g(rng) * sigma[c % 2]));
        maxima.push_back(m);
    }
    std::nth_element(maxima.begin(), maxima.begin() + 1000, maxima.end());
    CHECK(expected_max_error(sigma, 1000) == doctest::Approx(maxima[1000]).epsilon(0.02));
    CHECK(expected_max_error({0.0, 0.0}, 10) == 0);
}

TEST_CASE("recombined tables: shared counts, and the bound at the worst p") {
    // Two terms, R(p) = p T1 + p^2 T2 over p in [0, 1] (Oren-Nayar's form).
    RecombinedGroup g;
    g.name = "brdf";
    g.terms = {0, 1};
    g.coeffs = {{0.0, 1.0}, {0.0, 0.0, 1.0}};
    g.lo = 0, g.hi = 1;
    CHECK(shared_counts(g, {{5, 30, 7}, {9, 4, 7}}) == std::vector<std::size_t>{9, 30, 7});

    std::vector<TablePilot> pilots(2);
    for (TablePilot& p : pilots) p.signed_min = 0.1, p.signed_max = 1, p.max_value = 1, p.rel_floor = 1e-3;
    TablePlan t1, t2;
    t1.counts = t2.counts = {9, 30, 7};
    t1.cells = t2.cells = 9 * 30 * 7;
    t1.error_max = 3e-3, t1.interpolation_max = 2e-3, t1.storage_max = 1e-3;
    t2.error_max = 5e-3, t2.interpolation_max = 5e-3;
    PlanTarget absolute;
    absolute.absolute = true;
    // Absolute: |dR| <= p E1 + p^2 E2, largest at p = 1.
    const TablePlan a = predict_recombined(g, pilots, {t1, t2}, absolute);
    CHECK(a.error_max == doctest::Approx(8e-3));
    CHECK(a.interpolation_max == doctest::Approx(7e-3));
    CHECK(a.counts == t1.counts);
    // Over p in [0, 0.5] the worst p is 0.5: 0.5 E1 + 0.25 E2.
    RecombinedGroup half = g;
    half.hi = 0.5;
    CHECK(predict_recombined(half, pilots, {t1, t2}, absolute).error_max ==
          doctest::Approx(0.5 * 3e-3 + 0.25 * 5e-3));
    // Relative, nonnegative terms and coefficients: the largest term error.
    PlanTarget relative;
    CHECK(predict_recombined(g, pilots, {t1, t2}, relative).error_max == doctest::Approx(5e-3));
    // A floor above every value (albedos, floor 1): relative = absolute / floor, summed.
    std::vector<TablePilot> floored = pilots;
    for (TablePilot& p : floored) p.rel_floor = 1;
    CHECK(predict_recombined(g, floored, {t1, t2}, relative).error_max == doctest::Approx(8e-3));
    // A term of mixed sign can cancel the other: no relative bound.
    pilots[1].signed_min = -0.2;
    CHECK(std::isinf(predict_recombined(g, pilots, {t1, t2}, relative).error_max));
    // A negative coefficient over the range: likewise.
    pilots[1].signed_min = 0.1;
    RecombinedGroup minus = g;
    minus.coeffs[1] = {0.0, 0.0, -1.0};
    CHECK(std::isinf(predict_recombined(minus, pilots, {t1, t2}, relative).error_max));
    CHECK(predict_recombined(minus, pilots, {t1, t2}, absolute).error_max == doctest::Approx(8e-3));
}

TEST_CASE("recombined groups: terms found among the piloted tables, range from the model") {
    const std::string text = R"(
model = "oren-nayar"
[parameters]
sigma = 20.0
theta_o = 30.0
phi_d = 0.0
[[axes]]
name = "theta_i"
range = [0.0, 80.0]
count = 5
[[tables]]
name = "d"
quantity = "brdf_direct"
[[tables]]
name = "i"
quantity = "brdf_interreflection"
[[recombined]]
name = "brdf"
parameter = "rho"
[[recombined.terms]]
table = "d"
coeffs = [0.0, 1.0]
[[recombined.terms]]
table = "i"
coeffs = [0.0, 0.0, 1.0]
)";
    const Spec spec = parse_spec_string(text, "rec.toml");
    const std::vector<RecombinedGroup> all = recombined_groups(spec, {0, 1});
    REQUIRE(all.size() == 1);
    CHECK(all[0].terms == std::vector<std::size_t>{0, 1});
    // No range in the spec: the model's range of rho, [0, 1].
    CHECK(all[0].lo == 0);
    CHECK(all[0].hi == 1);
    // Only one term piloted (plan --table d): no group.
    CHECK(recombined_groups(spec, {0}).empty());
}

TEST_CASE("quadrature pilot: the integration term is the rule's own error, not the two-rule difference") {
    // Rough-dielectric albedos with `nodes` given: the pilot measures the
    // n-node rule against a finer one (plan.cpp, finer_rule_nodes).  On a
    // 2 x 2 grid every pilot cell is one of four cells, so the measured max
    // must be the largest |Q_4 - Q_64| over those four (Q_64: a much finer
    // rule than the pilot's 24-node reference; Gauss-Legendre converges
    // exponentially for light from outside, so the two references agree to
    // far below Q_4's error), and the stored difference |Q_4 - Q_2|, the
    // coarse rule's error, is much larger.
    auto spec_text = [](const char* nodes_line) {  // "": nodes at its default
        return std::string(R"(model = "rough-dielectric"
[parameters]
distribution = "ggx"
eta = 1.5
)") + nodes_line + R"(
[[axes]]
name = "theta_i"
range = [30.0, 85.0]
count = 2
[[axes]]
name = "alpha"
range = [0.05, 0.5]
count = 2
[[tables]]
quantity = "albedo_t"
[integration]
method = "quadrature"
)";
    };
    auto backend = make_backend("host", Precision::Double);
    PilotOptions o;
    o.lines = 1;
    o.cells = 8;
    const TablePilot p = run_pilot(parse_spec_string(spec_text("nodes = 4"), "q4.toml"), 0, *backend, o);
    REQUIRE(p.integration.size() == 1);
    const IntegrationFit& f = p.integration[0];
    CHECK(f.method == Method::Quadrature);
    CHECK(f.reference_nodes == 24);

    const ModelInfo& model = find_model("rough-dielectric");
    const QuantityInfo& q = model.quantity("albedo_t");
    std::vector<std::map<std::string, double>> cells;
    for (double ti : {30.0, 85.0})
        for (double alpha : {0.05, 0.5})
            cells.push_back({{"theta_i", ti}, {"alpha", alpha}, {"eta", 1.5}, {"nodes", 4}});
    auto at_nodes = [&](double nodes) {
        for (auto& c : cells) c["nodes"] = nodes;
        IntegrationSettings s;
        s.method = Method::Quadrature;
        return estimate_at(*backend, model, q, resolve_options(model, {{"distribution", "ggx"}}, "test"),
                           build_kernel_points(model, q, cells, [](std::size_t) { return std::string("cell"); }), s);
    };
    const EstimateResult q4 = at_nodes(4), q64 = at_nodes(64);
    double truth = 0, stored = 0;
    for (std::size_t k = 0; k < cells.size(); ++k) {
        truth = std::max(truth, std::fabs(q4.value[k] - q64.value[k]));
        stored = std::max(stored, q4.stderr_[k]);
    }
    INFO("measured " << f.max_abs.front() << ", |Q4 - Q64| " << truth << ", stored difference " << stored);
    REQUIRE(truth > 1e-7);
    CHECK(f.max_abs.front() == doctest::Approx(truth).epsilon(1e-3));
    CHECK(stored > 10 * truth);

    // `nodes` left at its default: the same (the default is a given value).
    const TablePilot d = run_pilot(parse_spec_string(spec_text(""), "default.toml"), 0, *backend, o);
    REQUIRE(d.integration.size() == 1);
    CHECK(d.integration[0].reference_nodes == 24);  // 2 x the default 12
    // A quadrature without a rule size (the H-function's trapezoid): the
    // stored two-rule difference stays the error term, as in its certificate.
    const TablePilot h = run_pilot(parse_spec_string(R"(model = "hfunction"
[parameters]
c = 0.9
[[axes]]
name = "mu"
range = [0.1, 1.0]
count = 3
[[tables]]
quantity = "H"
)", "h.toml"), 0, *backend, o);
    REQUIRE(h.integration.size() == 1);
    CHECK(h.integration[0].method == Method::Quadrature);
    CHECK(h.integration[0].reference_nodes == 0);
}

// ------------------------------------------------------------ the spec as written (plan --as-written)

namespace {

// A pilot of an integral table with every cell at stderr `sigma` at 4096
// samples (rate N^-1/2), value `value`, exact interpolation.
TablePilot integral_pilot(const Spec& spec, double sigma, double value) {
    TablePilot p;
    p.table = spec.tables[0].name;
    p.quantity = spec.tables[0].quantity;
    p.kind = QuantityKind::Integral;
    p.axes = spec.tables[0].axes;
    p.max_value = p.min_value = p.signed_min = p.signed_max = value;
    p.rel_floor = 1e-3 * value;
    p.startup_seconds = 0.1, p.overhead_seconds = 0.01, p.process_seconds = 0.2;
    for (const Axis& a : p.axes) {
        AxisFit f;
        f.axis = a.name;
        LevelErrors l;  // every error 0: exact
        l.count = a.count, l.h = 1.0 / double(a.count - 1);
        f.levels = {l};
        p.linear.push_back(f), p.cubic.push_back(f);
    }
    IntegrationFit f;
    f.method = Method::Rqmc;
    f.samples = {4096};
    f.max_abs = f.rms_abs = {sigma};
    f.max_rel = f.rms_rel = {sigma / value};
    f.fit_max_abs = f.fit_rms_abs = PowerFit{sigma * 64, -0.5, true, 1};
    f.fit_max_rel = f.fit_rms_rel = PowerFit{sigma / value * 64, -0.5, true, 1};
    f.cell_abs.assign(8, sigma);
    f.cell_rel.assign(8, sigma / value);
    f.cell_value.assign(8, value);
    f.seconds_per_sample = 1e-8;
    p.integration = {f};
    return p;
}

// The median of the largest |error| of `cells` independent N(0, s^2) errors:
// erf(x / (s sqrt 2))^cells = 1/2, solved by bisection on std::erf.
double median_max_normal(double s, double cells) {
    double lo = 0, hi = 20 * s;
    for (int k = 0; k < 200; ++k) {
        const double mid = 0.5 * (lo + hi);
        (std::pow(std::erf(mid / (s * std::sqrt(2.0))), cells) < 0.5 ? lo : hi) = mid;
    }
    return hi;
}

const char* kAsWrittenSpec = R"(
model = "oren-nayar"
[[tables]]
name = "albedo_direct"
quantity = "albedo_direct"
[[tables.axes]]
name = "mu_i"
range = [0.1, 1.0]
count = 10
[[tables.axes]]
name = "sigma"
range = [0.0, 1.0]
count = 5
[integration]
method = "rqmc"
samples = 1024
[output]
type = "float16"
)";

}  // namespace

TEST_CASE("as written: the spec's counts, method, samples and type, and the time they cost") {
    const Spec spec = parse_spec_string(kAsWrittenSpec, "aw.toml");
    const TablePilot p = integral_pilot(spec, 4e-3, 0.5);
    PlanTarget t;
    t.absolute = true;
    std::string why;
    const auto c = predict_as_written(spec, {p}, t, {}, why);
    REQUIRE(c);
    CHECK(why.empty());
    CHECK(c->method == Method::Rqmc);
    CHECK(c->samples == 1024);
    CHECK(c->stored_type == StoredType::Float16);
    REQUIRE(c->tables.size() == 1);
    CHECK(c->tables[0].counts == std::vector<std::size_t>{10, 5});
    // 50 cells x 1024 samples x 1e-8 s, one launch, the start-up, once the process.
    // Plus the process' fixed cost and the write of value, stderr and samples.
    const double fixed = process_fixed_seconds() + write_seconds(50, StoredType::Float16, 6, true, true);
    CHECK(c->seconds == doctest::Approx(fixed + 0.2 + 0.1 + 0.01 + 50 * 1024 * 1e-8));
    // stderr at 1024 samples: 4e-3 x 2 (N^-1/2); the max over 50 cells.
    CHECK(c->tables[0].integration_max == doctest::Approx(median_max_normal(8e-3, 50)).epsilon(1e-3));
    // float16 of values up to 0.5: half an ulp, 2^-11 x 0.5.
    CHECK(c->tables[0].storage_max == doctest::Approx(std::ldexp(1.0, -12)));
    // Two tables of the same kernel program: the second does not load it again.
    Spec two = spec;
    two.tables.push_back(two.tables[0]);
    two.tables[1].name = "albedo_direct_2";
    TablePilot p1 = p, p2 = p;
    p1.kernel = p2.kernel = "oren-nayar\nalbedo_direct";
    p2.table = "albedo_direct_2";
    const auto c2 = predict_as_written(two, {p1, p2}, t, {}, why);
    REQUIRE(c2);
    CHECK(c2->seconds == doctest::Approx(fixed + 0.2 + 0.1 + 2 * 0.01 + 2 * 50 * 1024 * 1e-8 +
                                         write_seconds(50, StoredType::Float16, 6, true, true)));
    // A method the pilot did not measure: no prediction, and why.
    Spec mc = spec;
    mc.integration.method = Method::MonteCarlo;
    CHECK_FALSE(predict_as_written(mc, {p}, t, {}, why));
    CHECK(why.find("mc") != std::string::npos);
}

TEST_CASE("as written with a tolerance: the adaptive rounds of the engine, worked by hand") {
    Spec spec = parse_spec_string(kAsWrittenSpec, "aw.toml");
    spec.integration.tolerance = 1e-2;
    spec.integration.abs_floor = 1e-6;
    spec.integration.max_samples = 1u << 20;
    const TablePilot p = integral_pilot(spec, 4e-3, 0.5);
    PlanTarget t;
    std::string why;
    const auto c = predict_as_written(spec, {p}, t, {}, why);
    REQUIRE(c);
    // Goal max(1e-2 x 0.5, 1e-6) = 5e-3.  At 1024 samples stderr 8e-3: ratio
    // 1.6, so the engine asks for 1024 x 1.6^2 x 1.1 = 2884 samples (within
    // [2 x, 16 x] 1024), where stderr = 4e-3 sqrt(4096 / 2884) = 4.77e-3 <= goal.
    const double samples = std::ceil(1024 * 1.6 * 1.6 * 1.1);
    const double sigma = 4e-3 * std::sqrt(4096 / samples);
    const double fixed = process_fixed_seconds() + write_seconds(50, StoredType::Float16, 6, true, true);
    CHECK(c->seconds == doctest::Approx(fixed + 0.2 + 0.1 + 2 * 0.01 + 50 * samples * 1e-8));
    // Relative: divided by the value 0.5.
    CHECK(c->tables[0].integration_max == doctest::Approx(median_max_normal(sigma / 0.5, 50)).epsilon(1e-3));
    // A cap below what the tolerance needs: every cell stops at max_samples.
    spec.integration.max_samples = 2048;
    const auto capped = predict_as_written(spec, {p}, t, {}, why);
    REQUIRE(capped);
    CHECK(capped->seconds == doctest::Approx(fixed + 0.2 + 0.1 + 2 * 0.01 + 50 * 2048 * 1e-8));
    CHECK(capped->tables[0].integration_max ==
          doctest::Approx(median_max_normal(4e-3 * std::sqrt(2.0) / 0.5, 50)).epsilon(1e-3));
}

TEST_CASE("pilot: an explicit axis of a whole-number parameter is read at its nodes only") {
    // The H-function moments over n = 0, 1, 2: the model accepts no n between
    // nodes (before, the pilot's probes at n = 0.25 were refused).
    const std::string text = R"(
model = "hfunction"
[[tables]]
name = "moments"
quantity = "moment"
[[tables.axes]]
name = "n"
spacing = "explicit"
values = [0, 1, 2]
[[tables.axes]]
name = "c"
range = [0.0, 0.9]
count = 9
)";
    const Spec spec = parse_spec_string(text, "moments.toml");
    auto backend = make_backend("host", Precision::Double);
    const TablePilot p = run_pilot(spec, 0, *backend, PilotOptions{});
    REQUIRE(p.linear.size() == 2);
    CHECK_FALSE(p.linear[0].planned);
    REQUIRE(p.linear[0].levels.size() == 1);
    CHECK(p.linear[0].levels[0].max_abs == 0);
    CHECK(p.linear[0].levels[0].count == 3);
    CHECK(p.linear[1].levels.size() == 3);  // c: three pilot levels
    CHECK(p.linear[1].levels.back().max_abs > 0);
}

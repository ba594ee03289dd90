// test_node_placement.cpp — explicit nodes equidistributing the measured
// interpolation error (host/plan/node_placement.h, `plan --place-nodes`).
//
// Oracle: f(x) = exp(a x) on [0, 1].  Linear interpolation errs by h^2 f''/8
// on a cell of width h, so equidistributed nodes have density proportional
// to sqrt(f'') = a exp(a x / 2): x_k = (2/a) ln(1 + k/(N-1) (e^(a/2) - 1)),
// and they beat N uniform nodes by a^2 e^a / (4 (e^(a/2) - 1)^2) as N grows
// (9.97 for a = 6; 8.5 at N = 20 from the per-cell closed forms).  The errors of the placed and the uniform nodes are measured here
// by dense sampling of the closed form.
#include <doctest/doctest.h>

#include <cmath>
#include <vector>

#include "host/core/error.h"
#include "host/plan/node_placement.h"

using namespace brdftab;

namespace {

constexpr double kA = 6.0;
double f(double x) { return std::exp(kA * x); }

// Max |f - piecewise linear interpolant| over the nodes, sampled densely.
double measured_max_error(const std::vector<double>& nodes) {
    double worst = 0;
    for (std::size_t k = 0; k + 1 < nodes.size(); ++k)
        for (int j = 1; j < 200; ++j) {
            const double s = j / 200.0, x = nodes[k] + s * (nodes[k + 1] - nodes[k]);
            worst = std::max(worst, std::fabs((1 - s) * f(nodes[k]) + s * f(nodes[k + 1]) - f(x)));
        }
    return worst;
}

PlacementLine pilot_line(std::size_t n) {
    PlacementLine l;
    for (std::size_t k = 0; k < n; ++k) {
        l.node_x.push_back(double(k) / double(n - 1));
        l.node_f.push_back(f(l.node_x.back()));
    }
    for (std::size_t k = 0; k + 1 < n; ++k)
        for (double s : {0.25, 0.5, 0.75}) {
            l.probe_x.push_back((double(k) + s) / double(n - 1));
            l.probe_f.push_back(f(l.probe_x.back()));
        }
    return l;
}

}  // namespace

TEST_CASE("local errors of linear interpolation: h^2 f''/8 at the cell midpoints") {
    const PlacementLine l = pilot_line(33);
    const std::vector<double> e = local_linear_errors({l}, false, 0);
    REQUIRE(e.size() == 32);
    const double h = 1.0 / 32;
    for (std::size_t i = 0; i < e.size(); ++i) {
        const double mid = (double(i) + 0.5) * h;
        CHECK(e[i] == doctest::Approx(h * h * kA * kA * f(mid) / 8).epsilon(0.01));
    }
    // Relative: divided by max(|f|, floor).
    const std::vector<double> r = local_linear_errors({l}, true, 1e6);
    CHECK(r[0] == doctest::Approx(e[0] / 1e6));
}

TEST_CASE("placed nodes follow the closed-form optimum and beat uniform by the predicted factor") {
    const PlacementLine l = pilot_line(65);
    const std::size_t n = 20;
    const NodePlacement p = place_nodes(l.node_x, local_linear_errors({l}, false, 0), 2.0, n);
    REQUIRE(p.values.size() == n);
    CHECK(p.values.front() == 0.0);
    CHECK(p.values.back() == 1.0);
    const double e2 = std::exp(kA / 2) - 1;
    for (std::size_t k = 0; k < n; ++k) {
        const double want = 2 / kA * std::log(1 + double(k) / double(n - 1) * e2);
        CHECK(p.values[k] == doctest::Approx(want).epsilon(0.01));
    }
    // Predictions against the closed forms ...
    const double h = 1.0 / double(n - 1);
    // Each cell errs by (integral of sqrt(f''/8) dx)^2 = (2 (e^(a b/2) - e^(a a'/2)))^2 / 8
    // over [a', b] (h^2 f''/8 to leading order): the last uniform cell, and
    // every placed cell alike.
    const double last = 2 * (std::exp(kA / 2) - std::exp(kA * (1 - h) / 2));
    const double uniform_exact = last * last / 8;
    const double placed_exact = (2 * e2) * (2 * e2) / (8 * double(n - 1) * double(n - 1));
    CHECK(p.uniform_max == doctest::Approx(uniform_exact).epsilon(0.05));
    CHECK(p.predicted_max == doctest::Approx(placed_exact).epsilon(0.05));
    // As N grows the gain tends to a^2 e^a / (4 (e^(a/2) - 1)^2) = 9.97; at
    // N = 20 the closed forms give 8.5.
    CHECK(kA * kA * std::exp(kA) / (4 * e2 * e2) == doctest::Approx(9.97).epsilon(0.01));
    CHECK(p.uniform_max / p.predicted_max == doctest::Approx(uniform_exact / placed_exact).epsilon(0.05));
    // ... and against the errors measured on the nodes themselves.
    std::vector<double> uniform(n);
    for (std::size_t k = 0; k < n; ++k) uniform[k] = double(k) * h;
    const double mu = measured_max_error(uniform), mp = measured_max_error(p.values);
    CHECK(mp == doctest::Approx(p.predicted_max).epsilon(0.15));
    CHECK(mu / mp == doctest::Approx(p.uniform_max / p.predicted_max).epsilon(0.15));
    CHECK(mu / mp > 8);
}

TEST_CASE("placement corner cases") {
    const PlacementLine l = pilot_line(9);
    // No measurable error: uniform nodes.
    const NodePlacement flat = place_nodes(l.node_x, std::vector<double>(8, 0.0), 2.0, 5);
    CHECK(flat.values[2] == doctest::Approx(0.5));
    CHECK_THROWS_AS(place_nodes(l.node_x, std::vector<double>(7, 1.0), 2.0, 5), InputError);
    CHECK_THROWS_AS(place_nodes(l.node_x, std::vector<double>(8, 1.0), 2.0, 1), InputError);
    // A single bad interval gets the nodes, the others keep a floor density.
    std::vector<double> spike(8, 0.0);
    spike[3] = 1.0;
    const NodePlacement s = place_nodes(l.node_x, spike, 2.0, 12);
    for (std::size_t k = 1; k < s.values.size(); ++k) CHECK(s.values[k] > s.values[k - 1]);
    std::size_t inside = 0;
    for (double x : s.values) inside += (x > 3.0 / 8 && x < 4.0 / 8);
    CHECK(inside >= 8);
}

// test_grid.cpp — axis spacings, their inverses and the grid's index math.
//
// Oracles: the defining property of each spacing evaluated directly with
// <cmath> (equal steps in cos, constant ratio for log, t^2 law for quadratic),
// exact equality at the end points, and a brute-force nested-loop enumeration
// of the row-major order.
#include <doctest/doctest.h>

#include <cmath>
#include <string>
#include <vector>

#include "host/core/error.h"
#include "host/core/grid.h"
#include "test_support.h"

using namespace brdftab;

namespace {
using test::kDeg;

std::vector<Axis> sample_axes() {
    return {
        make_axis("theta_i", "deg", 0, 89, 17, Spacing::Linear),
        make_axis("theta_o", "deg", 0, 180, 33, Spacing::Cos),
        make_axis("theta_o", "deg", 10, 80, 9, Spacing::Cos),
        make_axis("alpha", "1", 0.01, 4, 12, Spacing::Log),
        make_axis("alpha", "1", 0.001, 1, 20, Spacing::Quadratic),
        make_axis("mu_i", "1", -1, 1, 2, Spacing::Linear),
        make_axis("eta", "1", 0, 0, 0, Spacing::Explicit, {1.0, 1.33, 1.5, 2.4, 3.0}),
    };
}
}  // namespace

TEST_CASE("spacing names round-trip and unknown names are rejected") {
    for (Spacing s : {Spacing::Linear, Spacing::Cos, Spacing::Log, Spacing::Quadratic,
                      Spacing::Explicit, Spacing::LogComplement, Spacing::Critical})
        CHECK(parse_spacing(spacing_name(s)) == s);
    CHECK(std::string(spacing_name(Spacing::LogComplement)) == "log-complement");
    CHECK(std::string(spacing_name(Spacing::Critical)) == "critical");
    CHECK_THROWS_AS(parse_spacing("Linear"), InputError);
    try {
        parse_spacing("chebyshev");
        FAIL("no exception");
    } catch (const InputError& e) {
        // The message must list what is allowed.
        CHECK(std::string(e.what()).find("quadratic") != std::string::npos);
    }
}

TEST_CASE("end nodes equal min and max exactly, nodes strictly increase") {
    for (const Axis& a : sample_axes()) {
        CAPTURE(a.name);
        CAPTURE(spacing_name(a.spacing));
        REQUIRE(a.values.size() == a.count);
        CHECK(a.values.front() == a.min);
        CHECK(a.values.back() == a.max);
        CHECK(a.warp(0.0) == a.min);
        CHECK(a.warp(1.0) == a.max);
        for (std::size_t k = 1; k < a.count; ++k) CHECK(a.values[k] > a.values[k - 1]);
        // warp itself is monotone on a fine sweep, not only at the nodes.
        double prev = a.warp(0.0);
        for (int j = 1; j <= 1000; ++j) {
            const double x = a.warp(j / 1000.0);
            CHECK(x >= prev);
            prev = x;
        }
    }
}

TEST_CASE("nodes sit at warp(k/(n-1)) and unwarp inverts warp") {
    for (const Axis& a : sample_axes()) {
        CAPTURE(a.name);
        CAPTURE(spacing_name(a.spacing));
        const double span = a.max - a.min;
        for (std::size_t k = 0; k < a.count; ++k) {
            const double t = double(k) / double(a.count - 1);
            CHECK(a.values[k] == doctest::Approx(a.warp(t)).epsilon(1e-14));
            CHECK(a.unwarp(a.values[k]) == doctest::Approx(t).epsilon(1e-12));
        }
        for (int j = 0; j <= 200; ++j) {
            const double t = j / 200.0;
            // warp(unwarp(x)) == x  for x in range.
            const double x = a.min + span * t;
            CHECK(a.warp(a.unwarp(x)) == doctest::Approx(x).epsilon(1e-11).scale(span));
            // and unwarp(warp(t)) == t.
            CHECK(a.unwarp(a.warp(t)) == doctest::Approx(t).epsilon(1e-11).scale(1));
        }
    }
}

TEST_CASE("linear spacing: equal steps") {
    Axis a = make_axis("theta_i", "deg", 0, 89, 17, Spacing::Linear);
    for (std::size_t k = 1; k < a.count; ++k)
        CHECK(a.values[k] - a.values[k - 1] == doctest::Approx(89.0 / 16.0).epsilon(1e-13));
    // Outside [min, max] the map extrapolates (the caller clamps).
    CHECK(a.unwarp(-89.0) == doctest::Approx(-1.0));
}

TEST_CASE("cos spacing: uniform in cos(theta)") {
    const Axis a = make_axis("theta_o", "deg", 0, 180, 33, Spacing::Cos);
    const double step = (std::cos(180 * kDeg) - std::cos(0.0)) / 32.0;  // = -2/32
    for (std::size_t k = 1; k < a.count; ++k)
        CHECK(std::cos(a.values[k] * kDeg) - std::cos(a.values[k - 1] * kDeg) ==
              doctest::Approx(step).epsilon(1e-12));
    // Symmetric about 90 degrees: the middle node is exactly the equator.
    CHECK(a.values[16] == doctest::Approx(90.0).epsilon(1e-13));

    const Axis b = make_axis("theta_o", "deg", 10, 80, 9, Spacing::Cos);
    const double c0 = std::cos(10 * kDeg), c1 = std::cos(80 * kDeg);
    for (std::size_t k = 0; k < b.count; ++k)
        CHECK(std::cos(b.values[k] * kDeg) == doctest::Approx(c0 + (c1 - c0) * k / 8.0).epsilon(1e-12));
}

TEST_CASE("log spacing: constant ratio between neighbours") {
    const Axis a = make_axis("alpha", "1", 0.01, 4, 12, Spacing::Log);
    const double ratio = std::pow(4.0 / 0.01, 1.0 / 11.0);
    for (std::size_t k = 1; k < a.count; ++k)
        CHECK(a.values[k] / a.values[k - 1] == doctest::Approx(ratio).epsilon(1e-12));
    // Non-positive x has no preimage: unwarp says "below the first node".
    CHECK(a.unwarp(0.0) < 0);
}

TEST_CASE("quadratic spacing: sqrt((x-min)/(max-min)) is uniform") {
    const Axis a = make_axis("alpha", "1", 0.001, 1, 20, Spacing::Quadratic);
    for (std::size_t k = 0; k < a.count; ++k)
        CHECK(std::sqrt((a.values[k] - 0.001) / 0.999) == doctest::Approx(k / 19.0).epsilon(1e-12));
    // Dense near min: the first step is the smallest.
    CHECK(a.values[1] - a.values[0] < a.values[19] - a.values[18]);
    // Inverse below min stays monotone (sign-preserving square).
    CHECK(a.unwarp(0.0) < 0);
}

TEST_CASE("explicit nodes are kept and interpolated piecewise linearly") {
    const std::vector<double> v = {1.0, 1.33, 1.5, 2.4, 3.0};
    const Axis a = make_axis("eta", "1", 123, 456, 99, Spacing::Explicit, v);
    CHECK(a.values == v);
    CHECK(a.count == 5);
    CHECK(a.min == 1.0);
    CHECK(a.max == 3.0);
    // Halfway between nodes 2 and 3 (t = 2.5/4) is the midpoint of 1.5 and 2.4.
    CHECK(a.warp(2.5 / 4) == doctest::Approx(1.95).epsilon(1e-14));
    CHECK(a.unwarp(1.95) == doctest::Approx(2.5 / 4).epsilon(1e-14));
    // A quarter into the first cell.
    CHECK(a.unwarp(1.0825) == doctest::Approx(0.25 / 4).epsilon(1e-13));
}

TEST_CASE("make_axis rejects bad input with InputError naming the axis") {
    auto throws_with = [](auto fn, const std::string& needle) {
        try {
            fn();
            FAIL("no exception");
        } catch (const InputError& e) {
            const std::string m = e.what();
            CAPTURE(m);
            CHECK(m.find(needle) != std::string::npos);
            CHECK(m.find("axis 'x'") != std::string::npos);
        }
    };
    throws_with([] { make_axis("x", "1", 0, 1, 1, Spacing::Linear); }, "count");
    throws_with([] { make_axis("x", "1", 0, 1, 0, Spacing::Linear); }, "count");
    throws_with([] { make_axis("x", "1", 1, 1, 4, Spacing::Linear); }, "less than");
    throws_with([] { make_axis("x", "1", 2, 1, 4, Spacing::Quadratic); }, "less than");
    throws_with([] { make_axis("x", "1", 0, 1, 4, Spacing::Log); }, "min > 0");
    throws_with([] { make_axis("x", "1", -1, 1, 4, Spacing::Log); }, "min > 0");
    throws_with([] { make_axis("x", "deg", -10, 90, 4, Spacing::Cos); }, "[0, 180]");
    throws_with([] { make_axis("x", "deg", 0, 190, 4, Spacing::Cos); }, "[0, 180]");
    throws_with([] { make_axis("x", "1", 0, NAN, 4, Spacing::Linear); }, "finite");
    throws_with([] { make_axis("x", "1", 0, 0, 0, Spacing::Explicit, {1.0}); }, "at least 2");
    throws_with([] { make_axis("x", "1", 0, 0, 0, Spacing::Explicit, {}); }, "at least 2");
    throws_with([] { make_axis("x", "1", 0, 0, 0, Spacing::Explicit, {1, 2, 2}); }, "increasing");
    throws_with([] { make_axis("x", "1", 0, 0, 0, Spacing::Explicit, {1, 3, 2}); }, "increasing");
    throws_with([] { make_axis("x", "1", 0, 1, 3, Spacing::Linear, {0, 0.5, 1}); }, "explicit");
    // Nodes that collapse in double precision.
    throws_with([] { make_axis("x", "1", 1.0, 1.0 + 1e-15, 100, Spacing::Linear); }, "coincide");
}

TEST_CASE("grid: row-major order, last axis fastest") {
    const Axis a = make_axis("a", "1", 0, 1, 3, Spacing::Linear);
    const Axis b = make_axis("b", "1", 10, 20, 2, Spacing::Linear);
    const Axis c = make_axis("c", "1", 0, 0, 0, Spacing::Explicit, {5, 6, 7, 8});
    const Grid g({a, b, c});
    REQUIRE(g.cell_count() == 24);
    REQUIRE(g.axes().size() == 3);
    std::size_t flat = 0;
    for (std::size_t i = 0; i < 3; ++i)
        for (std::size_t j = 0; j < 2; ++j)
            for (std::size_t k = 0; k < 4; ++k, ++flat) {
                const auto idx = g.index_of(flat);
                REQUIRE(idx.size() == 3);
                CHECK(idx[0] == i);
                CHECK(idx[1] == j);
                CHECK(idx[2] == k);
                const auto x = g.coordinates(flat);
                CHECK(x[0] == a.values[i]);
                CHECK(x[1] == b.values[j]);
                CHECK(x[2] == c.values[k]);
            }
    CHECK_THROWS_AS(g.index_of(24), Error);
}

TEST_CASE("grid: no axes is a single cell; axes without nodes are rejected") {
    const Grid g(std::vector<Axis>{});
    CHECK(g.cell_count() == 1);
    CHECK(g.index_of(0).empty());
    Axis bare;
    bare.name = "bare";
    bare.count = 3;
    CHECK_THROWS_AS(Grid({bare}), Error);
}

// ---------------------------------------------------------------------------
// log-complement and critical spacings (issue 13, item 4).

TEST_CASE("log-complement: geometric distance to the pivot, exact ends, exact inverse") {
    // Pivot above max: the distance 1 - x shrinks by a constant ratio per node.
    const Axis a = make_log_complement_axis("c", "1", 0.0, 0.999, 11, 1.0);
    CHECK(a.spacing == Spacing::LogComplement);
    CHECK(a.values.front() == 0.0);
    CHECK(a.values.back() == 0.999);
    const double ratio = std::pow(0.001, 0.1);  // ((1-0.999)/(1-0))^(1/10)
    for (std::size_t k = 1; k < a.count; ++k) {
        CHECK((1 - a.values[k]) / (1 - a.values[k - 1]) == doctest::Approx(ratio).epsilon(1e-12));
        CHECK(a.unwarp(a.values[k]) == doctest::Approx(double(k) / 10).epsilon(1e-13));
    }
    // Pivot below min: dense towards min, still increasing.
    const Axis b = make_log_complement_axis("x", "1", 1.0, 5.0, 9, 0.5);
    for (std::size_t k = 1; k < b.count; ++k) {
        CHECK(b.values[k] > b.values[k - 1]);
        CHECK((b.values[k] - 0.5) / (b.values[k - 1] - 0.5) ==
              doctest::Approx(std::pow(9.0, 1.0 / 8)).epsilon(1e-12));
    }
    for (double t : {-0.3, 0.0, 0.17, 0.5, 0.93, 1.0, 1.2})
        CHECK(a.unwarp(a.warp(t)) == doctest::Approx(t).epsilon(1e-12));
    // A pivot inside the range has no geometric distance: refused.
    CHECK_THROWS_AS(make_log_complement_axis("c", "1", 0.0, 0.9, 5, 0.5), InputError);
    CHECK_THROWS_AS(make_log_complement_axis("c", "1", 0.0, 0.9, 5, 0.9), InputError);
    CHECK_THROWS_AS(make_axis("c", "1", 0.0, 0.9, 5, Spacing::LogComplement), InputError);
    // Past the pivot there is no preimage: +inf (clamped to the last cell).
    CHECK(std::isinf(a.unwarp(1.5)));
}

namespace {
// The critical cosine from Snell's law, written independently of grid.cpp:
// light from inside a medium of relative index eta > 1 is totally reflected
// when sin(theta) > 1/eta.
double mu_c_inside(double eta) { return std::cos(std::asin(1.0 / eta)); }
}  // namespace

TEST_CASE("critical spacing: a node on the critical cosine for every eta, exact inverse") {
    const std::size_t n = 32;
    const Axis fixed = make_critical_axis("mu_i", -1.0, -0.02, n, 16, 2.0, 1.5);
    CHECK(fixed.spacing == Spacing::Critical);
    CHECK_FALSE(fixed.dependent());
    CHECK(fixed.values.front() == -1.0);
    CHECK(fixed.values.back() == -0.02);
    CHECK(fixed.values[16] == doctest::Approx(-mu_c_inside(1.5)).epsilon(1e-14));
    for (std::size_t k = 1; k < n; ++k) CHECK(fixed.values[k] > fixed.values[k - 1]);
    // Both sides graded: node distances to the kink grow as s^2.
    const double xc = fixed.values[16];
    for (std::size_t k = 0; k < 16; ++k) {
        const double s = double(16 - k) / 16;
        CHECK(xc - fixed.values[k] == doctest::Approx((xc + 1.0) * s * s).epsilon(1e-12));
    }
    for (std::size_t k = 17; k < n; ++k) {
        const double s = double(k - 16) / 15;
        CHECK(fixed.values[k] - xc == doctest::Approx((-0.02 - xc) * s * s).epsilon(1e-12));
    }

    // Dependent on an eta axis: values hold t_k; warp_at places the kink node.
    const Axis dep = make_critical_axis("mu_i", -1.0, -0.02, n, 10, 1.5, 0.0, "eta");
    CHECK(dep.dependent());
    CHECK(dep.values[5] == doctest::Approx(5.0 / 31));
    CHECK_THROWS_AS(dep.warp(0.5), Error);
    CHECK_THROWS_AS(dep.unwarp(-0.5), Error);
    for (double eta : {1.05, 1.2, 1.5, 2.0, 3.0}) {
        const double mc = mu_c_inside(eta);
        if (-mc < dep.min + kCriticalMinSide * (10.0 / 31) * 0.98 || -mc > dep.max - kCriticalMinSide * (21.0 / 31) * 0.98)
            continue;  // clamped, checked below
        CHECK(dep.warp_at(10.0 / 31, eta) == doctest::Approx(-mc).epsilon(1e-13));
        for (double t : {0.0, 0.01, 0.2, 10.0 / 31, 0.5, 0.77, 1.0})
            CHECK(dep.unwarp_at(dep.warp_at(t, eta), eta) == doctest::Approx(t).epsilon(1e-12));
        CHECK(dep.warp_at(0.0, eta) == -1.0);
        CHECK(dep.warp_at(1.0, eta) == -0.02);
    }
    // Light from outside with eta < 1 (a denser medium above): the kink is at
    // +sqrt(1 - eta^2).
    const Axis out = make_critical_axis("mu_i", 0.0, 1.0, 21, 10, 2.0, 0.5);
    CHECK(out.values[10] == doctest::Approx(std::sqrt(0.75)).epsilon(1e-14));
    CHECK(out.values[9] - out.values[8] > out.values[10] - out.values[9]);
    CHECK(out.values[11] - out.values[10] < out.values[12] - out.values[11]);
}

TEST_CASE("critical spacing: eta -> 1 is continuous, never collapses, and inverts") {
    const std::size_t n = 17;
    const Axis dep = make_critical_axis("mu_i", -1.0, -0.02, n, 8, 2.0, 0.0, "eta");
    // At eta = 1 there is no critical angle (mu_c = 0, outside the range): the
    // kink is clamped so the top side keeps kCriticalMinSide of its share.
    const double lo_clamp = -0.02 - kCriticalMinSide * 0.5 * 0.98;
    CHECK(dep.critical_position(3.0) == doctest::Approx(-mu_c_inside(3.0)));
    CHECK(dep.critical_position(1.002) == doctest::Approx(-mu_c_inside(1.002)));
    CHECK(dep.critical_position(1.0) == doctest::Approx(lo_clamp));
    CHECK(dep.critical_position(0.7) == doctest::Approx(lo_clamp));  // r > 1 as well
    double prev_kink = dep.critical_position(1.0);
    std::vector<double> prev_nodes;
    for (double eta = 1.0; eta <= 1.2; eta += 1e-4) {
        const double kink = dep.critical_position(eta);
        CHECK(std::isfinite(kink));
        CHECK(kink <= prev_kink + 1e-15);            // moves monotonically deeper
        CHECK(std::fabs(kink - prev_kink) < 0.01);   // and without jumps
        prev_kink = kink;
        std::vector<double> nodes(n);
        for (std::size_t k = 0; k < n; ++k) nodes[k] = dep.warp_at(double(k) / 16, eta);
        for (std::size_t k = 1; k < n; ++k) REQUIRE(nodes[k] > nodes[k - 1]);
        for (std::size_t k = 0; k < n; ++k)
            CHECK(dep.unwarp_at(nodes[k], eta) == doctest::Approx(double(k) / 16).epsilon(1e-12));
        if (!prev_nodes.empty())
            for (std::size_t k = 0; k < n; ++k) CHECK(std::fabs(nodes[k] - prev_nodes[k]) < 0.02);
        prev_nodes = nodes;
    }
    CHECK_NOTHROW(check_dependent_nodes(dep, {1.0, 1.0001, 1.5, 3.0, 10.0}));
    // Bad parameters.
    CHECK_THROWS_AS(make_critical_axis("mu_i", -1.0, 0.5, n, 8, 1, 1.5), InputError);
    CHECK_THROWS_AS(make_critical_axis("mu_i", -1.0, -0.02, 2, 1, 1, 1.5), InputError);
    CHECK_THROWS_AS(make_critical_axis("mu_i", -1.0, -0.02, n, 0, 1, 1.5), InputError);
    CHECK_THROWS_AS(make_critical_axis("mu_i", -1.0, -0.02, n, 16, 1, 1.5), InputError);
    CHECK_THROWS_AS(make_critical_axis("mu_i", -1.0, -0.02, n, 8, 5, 1.5), InputError);
    CHECK(critical_node_for(32, 0.5) == 16);
    CHECK(critical_node_for(32, 0.01) == 1);
    CHECK(critical_node_for(32, 0.99) == 30);
}

TEST_CASE("grid: a dependent axis is placed at each cell's value of its axis") {
    const Axis mu = make_critical_axis("mu_i", -1.0, -0.02, 9, 4, 2.0, 0.0, "eta");
    const Axis eta = make_axis("eta", "1", 1.0, 3.0, 5, Spacing::Log);
    const Grid g({mu, eta});
    CHECK(g.dependency(0) == 1);
    CHECK(g.dependency(1) == -1);
    for (std::size_t i = 0; i < 9; ++i)
        for (std::size_t j = 0; j < 5; ++j) {
            const std::vector<double> x = g.coordinates(i * 5 + j);
            CHECK(x[1] == eta.values[j]);
            CHECK(x[0] == mu.warp_at(double(i) / 8, eta.values[j]));
            if (i == 4 && eta.values[j] > 1.01)
                CHECK(x[0] == doctest::Approx(-mu_c_inside(eta.values[j])).epsilon(1e-13));
        }
    const std::vector<double> p = g.point_at({0.5, 0.5});
    CHECK(p[1] == doctest::Approx(std::sqrt(3.0)));
    CHECK(p[0] == doctest::Approx(-mu_c_inside(std::sqrt(3.0))).epsilon(1e-13));
    // The axis it names must exist.
    CHECK_THROWS_AS(Grid({mu}), InputError);
}

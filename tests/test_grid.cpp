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
                      Spacing::Explicit})
        CHECK(parse_spacing(spacing_name(s)) == s);
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

// test_lookup_fast.cpp — the lookup library's prepared fast path and its
// batch API (host/lookup/lookup.h, docs/lookup.md "Batch calls").
//
// Oracles: the exact multilinear interpolant computed naively here (the cell
// by a linear scan over the node list, the warped coordinate from the
// spacing formulas, the weighted sum over all 2^D corners); closed-form
// functions of the angles; std::upper_bound for the node index; Axis::unwarp
// for the prepared inverse warps; and the scalar calls for the batch calls
// (bit for bit).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <random>
#include <thread>
#include <vector>

#include "host/core/error.h"
#include "host/core/grid.h"
#include "host/lookup/lookup.h"
#include "host/lookup/lookup_internal.h"
#include "test_support.h"

using namespace brdftab;

namespace {

using test::kDeg;
using test::kPi;

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

TableData make_table(const std::string& name, std::vector<Axis> axes,
                     const std::function<double(const std::vector<double>&)>& f) {
    TableData t;
    t.name = name;
    t.model = "test";
    t.quantity = "brdf";
    t.units = "1/sr";
    t.axes = std::move(axes);
    std::size_t cells = 1;
    for (const auto& a : t.axes) cells *= a.count;
    t.value.resize(cells);
    std::vector<double> x(t.axes.size());
    for (std::size_t flat = 0; flat < cells; ++flat) {
        std::size_t r = flat;
        for (std::size_t d = t.axes.size(); d-- > 0;) {
            x[d] = t.axes[d].values[r % t.axes[d].count];
            r /= t.axes[d].count;
        }
        t.value[flat] = f(x);
    }
    return t;
}

// Pseudo-random node values (no structure for the interpolant to hide behind).
TableData random_table(std::vector<Axis> axes, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> U(-1, 2);
    return make_table("brdf", std::move(axes), [&](const std::vector<double>&) { return U(rng); });
}

// Warped coordinate from the spacing formulas (cos in degrees).
double t_of(const Axis& a, double x) {
    switch (a.spacing) {
        case Spacing::Cos:
            return (std::cos(x * kDeg) - std::cos(a.min * kDeg)) /
                   (std::cos(a.max * kDeg) - std::cos(a.min * kDeg));
        case Spacing::Log: return std::log(x / a.min) / std::log(a.max / a.min);
        case Spacing::Quadratic: return std::sqrt((x - a.min) / (a.max - a.min));
        case Spacing::Explicit: {
            std::size_t k = 0;
            while (k + 2 < a.count && x >= a.values[k + 1]) ++k;
            return (double(k) + (x - a.values[k]) / (a.values[k + 1] - a.values[k])) /
                   double(a.count - 1);
        }
        default: return (x - a.min) / (a.max - a.min);
    }
}

// The multilinear interpolant of `t` at x (inside every axis), naively.
double naive_multilinear(const TableData& t, const std::vector<double>& x) {
    const std::size_t dims = t.axes.size();
    std::vector<std::size_t> cell(dims);
    std::vector<double> frac(dims);
    for (std::size_t d = 0; d < dims; ++d) {
        const double u = t_of(t.axes[d], x[d]) * double(t.axes[d].count - 1);
        std::size_t k = 0;
        while (k + 2 < t.axes[d].count && u >= double(k + 1)) ++k;
        cell[d] = k;
        frac[d] = u - double(k);
    }
    double sum = 0;
    for (std::size_t corner = 0; corner < (std::size_t(1) << dims); ++corner) {
        double w = 1;
        std::size_t flat = 0;
        for (std::size_t d = 0; d < dims; ++d) {
            const bool up = (corner >> d) & 1;
            w *= up ? frac[d] : 1 - frac[d];
            flat = flat * t.axes[d].count + cell[d] + (up ? 1 : 0);
        }
        sum += w * t.value[flat];
    }
    return sum;
}

Vec3 dir(double theta_deg, double phi_deg) {
    const double t = theta_deg * kDeg, p = phi_deg * kDeg;
    return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

// Random unit directions over the sphere, a few of them on the pole.
std::vector<double> direction_rows(std::size_t n, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> U(0, 1);
    std::vector<double> rows(3 * n);
    for (std::size_t k = 0; k < n; ++k) {
        Vec3 w = dir(std::acos(2 * U(rng) - 1) / kDeg, 360 * U(rng));
        if (k % 37 == 0) w = {0, 0, 1};
        rows[3 * k] = w.x;
        rows[3 * k + 1] = w.y;
        rows[3 * k + 2] = w.z;
    }
    return rows;
}

Vec3 row(const std::vector<double>& rows, std::size_t k) {
    return {rows[3 * k], rows[3 * k + 1], rows[3 * k + 2]};
}

}  // namespace

TEST_CASE("the node index finds std::upper_bound's cell for any x") {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> U(0, 1);
    // Even, clustered and very uneven node lists.
    const std::vector<std::vector<double>> lists = {
        {0, 1}, {0, 1, 2, 3, 4, 5}, {-1, -0.999, -0.99, -0.5, 0.7, 1}, {0, 1e-6, 2e-6, 10, 1000}};
    for (const auto& nodes : lists) {
        lookup_detail::NodeIndex ix;
        ix.build(nodes);
        const std::size_t n = nodes.size();
        std::vector<double> xs(nodes);
        for (double v : nodes) {
            xs.push_back(std::nextafter(v, -1e300));
            xs.push_back(std::nextafter(v, 1e300));
        }
        const double lo = nodes.front(), hi = nodes.back();
        for (int k = 0; k < 5000; ++k) xs.push_back(lo - 0.1 * (hi - lo) + 1.2 * (hi - lo) * U(rng));
        xs.push_back(-1e300);
        xs.push_back(1e300);
        for (double x : xs) {
            std::size_t want = std::size_t(std::upper_bound(nodes.begin(), nodes.end(), x) -
                                           nodes.begin());
            want = want == 0 ? 0 : want - 1;
            want = std::min(want, n - 2);
            REQUIRE(ix.cell(x) == want);
        }
    }
}

TEST_CASE("prepared axes invert every warp as Axis::unwarp does, bit for bit") {
    const std::vector<Axis> axes = {
        make_axis("a", "1", -2, 3, 7, Spacing::Linear),
        make_axis("theta", "deg", 0, 90, 9, Spacing::Cos),
        make_axis("theta_t", "deg", 20, 170, 6, Spacing::Cos),
        make_axis("alpha", "1", 0.01, 1, 5, Spacing::Log),
        make_axis("b", "1", 0, 2, 6, Spacing::Quadratic),
        make_axis("e", "1", 0, 1, 6, Spacing::Explicit, {0, 0.01, 0.02, 0.3, 0.9, 1}),
        make_log_complement_axis("c", "1", 0, 0.999, 8, 1.0),
        make_log_complement_axis("d", "1", 0.5, 2, 5, 0.2),
        make_critical_axis("mu_i", -1, -0.02, 9, 4, 2, 1.5),
    };
    std::mt19937_64 rng(4);
    std::uniform_real_distribution<double> U(0, 1);
    for (const Axis& a : axes) {
        CAPTURE(a.name);
        lookup_detail::FastAxis f;
        f.build(a);
        std::vector<double> xs(a.values);
        for (int k = 0; k < 3000; ++k) xs.push_back(a.min + (a.max - a.min) * U(rng));
        for (double x : xs) {
            const double want = a.unwarp(x);
            const double got = lookup_internal::unwarp_fast(f, a, x);
            REQUIRE(same_bits(got, want));
        }
    }
}

TEST_CASE("linear eval is the exact multilinear interpolant, in 1 to 9 dimensions") {
    const std::vector<Axis> pool = {
        test::axis("theta_i", "deg", 0, 90, 7, Spacing::Cos),
        test::axis("alpha", "1", 0.01, 1, 5, Spacing::Log),
        test::axis("beta", "1", 0, 2, 4, Spacing::Quadratic),
        make_axis("e", "1", 0, 1, 5, Spacing::Explicit, {0, 0.05, 0.1, 0.6, 1}),
        test::axis("phi_d", "deg", 0, 180, 6, Spacing::Linear),
        test::axis("g", "1", -1, 1, 3, Spacing::Linear),
        test::axis("h", "1", 1, 4, 2, Spacing::Log),
        test::axis("k", "1", 0, 1, 3, Spacing::Quadratic),
        test::axis("m", "1", 0, 5, 2, Spacing::Linear),
    };
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> U(0, 1);
    for (std::size_t dims = 1; dims <= pool.size(); ++dims) {
        CAPTURE(dims);
        const TableData t = random_table({pool.begin(), pool.begin() + long(dims)}, unsigned(dims));
        const LookupTable lt(t);
        double max_err = 0;
        std::vector<double> x(dims);
        for (int n = 0; n < 1500; ++n) {
            for (std::size_t d = 0; d < dims; ++d) {
                const Axis& a = t.axes[d];
                // Every tenth point on a node of each axis (zero weights).
                x[d] = n % 10 == 0 ? a.values[std::size_t(U(rng) * double(a.count)) % a.count]
                                   : a.min + (a.max - a.min) * U(rng);
            }
            max_err = std::max(max_err, std::fabs(lt.eval(x) - naive_multilinear(t, x)));
        }
        CHECK(max_err < 1e-13);
    }
}

TEST_CASE("direction lookups: the azimuth difference and the pole convention") {
    // Linear in theta_i, theta_o and |phi_d| on linear axes: linear
    // interpolation reproduces it, so eval(wi, wo) is f of the true angles.
    auto f = [](double ti, double to, double pd) { return 1 + ti / 90 + 2 * to / 90 + pd / 60; };
    const LookupTable lt(make_table("brdf",
                                    {make_axis("theta_i", "deg", 0, 90, 10, Spacing::Linear),
                                     make_axis("theta_o", "deg", 0, 90, 7, Spacing::Linear),
                                     make_axis("phi_d", "deg", 0, 180, 13, Spacing::Linear)},
                                    [&](const std::vector<double>& x) { return f(x[0], x[1], x[2]); }));
    const BoundTable bt = lt.bind();
    std::mt19937_64 rng(6);
    std::uniform_real_distribution<double> U(0, 1);
    double max_err = 0;
    for (int n = 0; n < 5000; ++n) {
        // From 1 degree on: acos of a rounded cos(theta) loses precision near
        // the pole (1e-16 / sin(theta)), an error of the test's own vectors.
        const double ti = 1 + 88.9 * U(rng), to = 1 + 88.9 * U(rng), pi = 720 * U(rng) - 360,
                     po = 720 * U(rng) - 360;
        double pd = std::fabs(std::remainder(po - pi, 360.0));
        const double want = f(ti, to, pd);
        max_err = std::max(max_err, std::fabs(bt.eval(dir(ti, pi), dir(to, po)) - want));
        max_err = std::max(max_err, std::fabs(lt.eval_dirs(dir(ti, pi), dir(to, po)) - want));
    }
    CHECK(max_err < 1e-12);
    // A direction on the pole has azimuth 0: wi on the pole reads phi_d = phi_o,
    // wo on the pole phi_d = -phi_i (folded to |phi_i|).
    CHECK(bt.eval({0, 0, 1}, dir(40, 70)) == doctest::Approx(f(0, 40, 70)).epsilon(1e-13));
    CHECK(bt.eval(dir(30, -50), {0, 0, 2}) == doctest::Approx(f(30, 0, 50)).epsilon(1e-13));
    CHECK(bt.eval({0, 0, 1}, {0, 0, 1}) == doctest::Approx(f(0, 0, 0)).epsilon(1e-13));
    // Unnormalised vectors are normalised; zero and NaN vectors are refused.
    CHECK(bt.eval({0, 3, 4}, {2, 0, 2}) ==
          doctest::Approx(f(std::acos(0.8) / kDeg, 45, 90)).epsilon(1e-12));
    CHECK_THROWS_AS(bt.eval({0, 0, 0}, {0, 0, 1}), InputError);
    CHECK_THROWS_AS(bt.eval({0, 0, 1}, {NAN, 0, 1}), InputError);
}

TEST_CASE("the bound direction kernel on cos-spaced theta and linear mu axes") {
    // f linear in cos(theta_i), cos(theta_o) (mu) and phi_d: multilinear
    // interpolation on axes evenly spaced in mu reproduces it, so
    // BoundTable::eval(wi, wo) is f of the true direction cosines; the
    // Reject table takes the general path and must agree.
    auto f = [](double mi, double mo, double pd) { return 1 + 2 * mi + 3 * mo + pd / 90; };
    const LookupTable cos_axes(make_table(
        "brdf",
        {make_axis("theta_i", "deg", 0, 90, 9, Spacing::Cos),
         make_axis("theta_o", "deg", 0, 90, 12, Spacing::Cos),
         make_axis("phi_d", "deg", 0, 180, 7, Spacing::Linear)},
        [&](const std::vector<double>& x) {
            return f(std::cos(x[0] * kDeg), std::cos(x[1] * kDeg), x[2]);
        }));
    const LookupTable mu_axes(make_table(
        "brdf",
        {make_axis("mu_i", "1", 0, 1, 6, Spacing::Linear),
         make_axis("mu_o", "1", -1, 1, 11, Spacing::Linear),
         make_axis("phi_d", "deg", 0, 180, 5, Spacing::Linear)},
        [&](const std::vector<double>& x) { return f(x[0], x[1], x[2]); }));
    const BoundTable bc = cos_axes.bind(), bm = mu_axes.bind();
    const BoundTable bc_reject = cos_axes.bind({}, Interpolation::Linear, OutOfRange::Reject);
    std::mt19937_64 rng(12);
    std::uniform_real_distribution<double> U(0, 1);
    double worst_cos = 0, worst_mu = 0, worst_reject = 0;
    for (int n = 0; n < 5000; ++n) {
        const double ti = 90 * U(rng), to = 180 * U(rng), pi = 360 * U(rng), po = 360 * U(rng);
        const Vec3 wi = dir(ti, pi), wo = dir(to, po);
        const double pd = std::fabs(std::remainder(po - pi, 360.0));
        // Below the horizon the cos axes clamp theta_o to 90 degrees: mu_o = 0.
        const double mo_clamped = std::max(wo.z, 0.0);
        worst_cos = std::max(worst_cos, std::fabs(bc.eval(wi, wo) - f(wi.z, mo_clamped, pd)));
        worst_mu = std::max(worst_mu, std::fabs(bm.eval(wi, wo) - f(wi.z, wo.z, pd)));
        if (to < 90)
            worst_reject = std::max(worst_reject, std::fabs(bc_reject.eval(wi, wo) - bc.eval(wi, wo)));
        // Its pdf and sample agree bit for bit.
        const SampleResult s = bc.sample(wi, U(rng), U(rng));
        CHECK(same_bits(s.pdf, bc.pdf(wi, s.wo)));
        CHECK(same_bits(s.value, bc.eval(wi, s.wo)));
    }
    CAPTURE(worst_cos);
    CAPTURE(worst_mu);
    CAPTURE(worst_reject);
    CHECK(worst_cos < 1e-12);
    CHECK(worst_mu < 1e-12);
    CHECK(worst_reject < 1e-12);
    CHECK_THROWS_AS(bc_reject.eval(dir(30, 0), dir(120, 0)), InputError);
    // Each pdf integrates to 1 over the sphere (midpoint rule in (cos theta,
    // phi); the density is piecewise constant there).
    for (const BoundTable* b : {&bc, &bm}) {
        const Vec3 wi = dir(37, 20);
        const int rows = 200, cols = 400;
        double integral = 0;
        for (int r = 0; r < rows; ++r)
            for (int c = 0; c < cols; ++c) {
                const double m = -1 + 2 * (r + 0.5) / rows, p = 2 * kPi * (c + 0.5) / cols;
                const double st = std::sqrt(1 - m * m);
                integral += b->pdf(wi, {st * std::cos(p), st * std::sin(p), m}) * (2.0 / rows) *
                            (2 * kPi / cols);
            }
        CHECK(integral == doctest::Approx(1).epsilon(2e-3));
    }
}

TEST_CASE("batch calls equal the scalar calls bit for bit, also from several threads") {
    // Cos-spaced theta axes, a linear phi_d axis and a log parameter axis.
    const TableData t = random_table({test::axis("theta_i", "deg", 0, 90, 8, Spacing::Cos),
                                      test::axis("theta_o", "deg", 0, 90, 11, Spacing::Cos),
                                      test::axis("phi_d", "deg", 0, 180, 9, Spacing::Linear),
                                      test::axis("alpha", "1", 0.05, 1, 4, Spacing::Log)},
                                     7);
    // Non-negative values so that the table can be sampled.
    TableData tp = t;
    for (double& v : tp.value) v = std::fabs(v);
    const LookupTable lt(tp);
    const std::size_t n = 4000;
    const std::vector<double> wi = direction_rows(n, 8), wo = direction_rows(n, 9);
    std::vector<double> coords(4 * n), u(2 * n);
    std::mt19937_64 rng(10);
    std::uniform_real_distribution<double> U(0, 1);
    for (std::size_t k = 0; k < n; ++k) {
        coords[4 * k] = 100 * U(rng) - 5;  // some outside [0, 90]: clamped
        coords[4 * k + 1] = 90 * U(rng);
        coords[4 * k + 2] = 400 * U(rng) - 200;  // folded
        coords[4 * k + 3] = 0.05 + 0.95 * U(rng);
        u[2 * k] = U(rng);
        u[2 * k + 1] = U(rng);
    }
    const std::map<std::string, double> params = {{"alpha", 0.3}};
    for (Interpolation interp : {Interpolation::Linear, Interpolation::Cubic}) {
        CAPTURE(int(interp));
        const BoundTable bt = lt.bind(params, interp);
        REQUIRE(bt.can_sample());
        auto check_all = [&](std::vector<int>& bad) {
            std::vector<double> a(n), b(n), c(n), swo(3 * n), spdf(n), sval(n), sw(n);
            lt.eval_many(coords.data(), n, a.data(), interp);
            lt.eval_dirs_many(wi.data(), wo.data(), n, b.data(), params, interp);
            bt.eval_many(wi.data(), wo.data(), n, c.data());
            std::vector<double> p(n);
            bt.pdf_many(wi.data(), wo.data(), n, p.data());
            bt.sample_many(wi.data(), u.data(), n, swo.data(), spdf.data(), sval.data(), sw.data());
            for (std::size_t k = 0; k < n; ++k) {
                const std::vector<double> x(coords.begin() + long(4 * k),
                                            coords.begin() + long(4 * k + 4));
                if (!same_bits(a[k], lt.eval(x, interp))) ++bad[0];
                if (!same_bits(b[k], lt.eval_dirs(row(wi, k), row(wo, k), params, interp)))
                    ++bad[1];
                if (!same_bits(c[k], bt.eval(row(wi, k), row(wo, k)))) ++bad[2];
                if (!same_bits(p[k], bt.pdf(row(wi, k), row(wo, k)))) ++bad[3];
                const SampleResult s = bt.sample(row(wi, k), u[2 * k], u[2 * k + 1]);
                if (!same_bits(swo[3 * k], s.wo.x) || !same_bits(swo[3 * k + 1], s.wo.y) ||
                    !same_bits(swo[3 * k + 2], s.wo.z) || !same_bits(spdf[k], s.pdf) ||
                    !same_bits(sval[k], s.value) || !same_bits(sw[k], s.weight))
                    ++bad[4];
                // The sample's pdf and value are those of pdf() and eval() at its wo.
                if (!same_bits(s.pdf, bt.pdf(row(wi, k), s.wo)) ||
                    !same_bits(s.value, bt.eval(row(wi, k), s.wo)))
                    ++bad[5];
            }
        };
        std::vector<int> bad_main(6, 0), bad_a(6, 0), bad_b(6, 0);
        check_all(bad_main);
        std::thread ta([&] { check_all(bad_a); });
        std::thread tb([&] { check_all(bad_b); });
        ta.join();
        tb.join();
        for (int i = 0; i < 6; ++i) {
            CAPTURE(i);
            CHECK(bad_main[i] == 0);
            CHECK(bad_a[i] == 0);
            CHECK(bad_b[i] == 0);
        }
        // Null outputs of sample_many are skipped.
        std::vector<double> swo(3 * n);
        bt.sample_many(wi.data(), u.data(), n, swo.data(), nullptr);
        CHECK(same_bits(swo[3], bt.sample(row(wi, 1), u[2], u[3]).wo.x));
    }
}

TEST_CASE("batch calls keep the scalar checks and messages") {
    const LookupTable lt(random_table({test::axis("theta_i", "deg", 0, 90, 5, Spacing::Cos),
                                       test::axis("theta_o", "deg", 0, 90, 5, Spacing::Cos)},
                                      11));
    const std::vector<double> coords = {10, 20, 30, NAN};
    std::vector<double> out(2, -1);
    const std::string msg =
        test::input_error([&] { lt.eval_many(coords.data(), 2, out.data()); });
    CHECK(msg.find("theta_o") != std::string::npos);
    CHECK(msg.find("NaN") != std::string::npos);
    CHECK(out[0] == lt.eval({10.0, 20.0}));  // points before the bad one are written
    const std::vector<double> far = {100, 20};
    CHECK(test::input_error([&] {
              lt.eval_many(far.data(), 1, out.data(), Interpolation::Linear, OutOfRange::Reject);
          }).find("outside") != std::string::npos);
    const std::vector<double> wi = {0, 0, 1, 0, 0, 0}, wo = {0, 0, 1, 0, 0, 1};
    const BoundTable bt = lt.bind();
    CHECK_THROWS_AS(bt.eval_many(wi.data(), wo.data(), 2, out.data()), InputError);
    CHECK_THROWS_AS(lt.eval_dirs_many(wi.data(), wo.data(), 1, out.data(), {{"x", 1.0}}),
                    InputError);
    // theta_o over [0, 90] without phi_d: sampleable; a zero wi is refused.
    CHECK_THROWS_AS(bt.pdf_many(wi.data(), wo.data(), 2, out.data()), InputError);
}

TEST_CASE("a non-finite node value is not read where its weight is zero") {
    // Zero weights are skipped, not multiplied: a lookup on a node next to an
    // infinite value sees only finite nodes; inside the infinite node's cell
    // the value is infinite.  Linear eval and bound direction lookups alike.
    TableData t = make_table("brdf",
                             {test::axis("theta_i", "deg", 0, 90, 4, Spacing::Linear),
                              test::axis("theta_o", "deg", 0, 90, 4, Spacing::Linear)},
                             [](const std::vector<double>& x) { return 1 + x[0] + 2 * x[1]; });
    t.value[0] = INFINITY;  // theta_i = theta_o = 0
    const LookupTable lt(t);
    CHECK(lt.eval({30.0, 30.0}) == 1 + 30 + 60);
    CHECK(lt.eval({30.0, 60.0}) == 1 + 30 + 120);
    CHECK(std::isinf(lt.eval({10.0, 10.0})));
    // The batch form takes the same skipping kernel.
    const std::vector<double> rows = {30, 30, 30, 60, 10, 10, 0, 90, 90, 0};
    std::vector<double> out(5);
    lt.eval_many(rows.data(), 5, out.data());
    for (std::size_t k = 0; k < 5; ++k)
        CHECK(same_bits(out[k], lt.eval({rows[2 * k], rows[2 * k + 1]})));
    CHECK(out[1] == 1 + 30 + 120);
    const BoundTable bt = lt.bind();
    // (From vectors theta is a node only up to rounding: read away from node 0.)
    CHECK(bt.eval(dir(60, 0), dir(60, 90)) == doctest::Approx(181).epsilon(1e-12));
    CHECK(std::isinf(bt.eval(dir(10, 0), dir(10, 90))));
}

TEST_CASE("linear and cubic eval equal the reference weights and contraction bit for bit") {
    // The reference: Axis::unwarp, the per-axis weights of axis_weights_t and
    // the recursive contract() over the stored values.
    const TableData t = random_table({test::axis("theta_i", "deg", 0, 90, 7, Spacing::Cos),
                                      test::axis("alpha", "1", 0.01, 1, 5, Spacing::Log),
                                      make_axis("e", "1", 0, 1, 5, Spacing::Explicit,
                                                {0, 0.05, 0.1, 0.6, 1}),
                                      test::axis("phi_d", "deg", 0, 180, 6, Spacing::Linear)},
                                     13);
    const LookupTable lt(t);
    std::vector<std::size_t> strides(4, 1);
    for (std::size_t d = 3; d-- > 0;) strides[d] = strides[d + 1] * t.axes[d + 1].count;
    std::mt19937_64 rng(14);
    std::uniform_real_distribution<double> U(0, 1);
    int bad = 0;
    for (Interpolation interp : {Interpolation::Linear, Interpolation::Cubic})
        for (int n = 0; n < 3000; ++n) {
            std::vector<double> x(4);
            lookup_internal::AxisWeights ws[4];
            for (std::size_t d = 0; d < 4; ++d) {
                const Axis& a = t.axes[d];
                x[d] = n % 9 == 0 ? a.values[std::size_t(U(rng) * double(a.count)) % a.count]
                                  : a.min + (a.max - a.min) * U(rng);
                lookup_internal::axis_weights_t(a, a.unwarp(x[d]), interp, ws[d]);
            }
            const double want = lookup_internal::contract(ws, strides.data(), 4, t.value.data());
            if (!same_bits(lt.eval(x, interp), want)) ++bad;
        }
    CHECK(bad == 0);
}

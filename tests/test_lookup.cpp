// test_lookup.cpp — interpolation, direction lookup, recombination and
// importance sampling of host/lookup/lookup.h.
//
// Oracles: closed-form functions tabulated here (node positions computed by
// test::axis from the spacing formulas, not by Axis::warp), analytic integrals,
// independent quadrature of pdf(), and a chi-square test of sample() against
// cell probabilities computed from pdf() times exact cell areas.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "host/core/error.h"
#include "host/lookup/lookup.h"
#include "host/io/table_io.h"
#include "test_support.h"

using namespace brdftab;

namespace {

using test::axis;
using test::kDeg;
using test::kPi;

// Warped coordinate of x on axis a, from the spacing formulas (test oracle).
double tcoord(const Axis& a, double x) {
    switch (a.spacing) {
        case Spacing::Linear: return (x - a.min) / (a.max - a.min);
        case Spacing::Cos:
            return (std::cos(x * kDeg) - std::cos(a.min * kDeg)) /
                   (std::cos(a.max * kDeg) - std::cos(a.min * kDeg));
        case Spacing::Log: return std::log(x / a.min) / std::log(a.max / a.min);
        case Spacing::Quadratic: return std::sqrt((x - a.min) / (a.max - a.min));
        default: return 0;
    }
}

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

Vec3 dir(double theta_deg, double phi_deg) {
    const double t = theta_deg * kDeg, p = phi_deg * kDeg;
    return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

// Upper tail of chi-square with k dof (Wilson-Hilferty; fine for k > 30).
double chi2_pvalue(double x, double k) {
    const double z = (std::cbrt(x / k) - (1 - 2 / (9 * k))) / std::sqrt(2 / (9 * k));
    return 0.5 * std::erfc(z / std::sqrt(2.0));
}

// Multilinear in (cos theta_i, cos theta_o, |phi_d|): reproduced exactly by
// linear interpolation on cos-spaced theta axes and a linear phi_d axis.
double f_ml(double mi, double mo, double phid_deg) {
    return (0.2 + mi) * (0.05 + mo) * (1 + 2 * std::fabs(phid_deg) / 180);
}

TableData brdf_ml_table(std::size_t ni = 6, std::size_t no = 10, std::size_t np = 7) {
    return make_table("brdf",
                      {axis("theta_i", "deg", 0, 90, ni, Spacing::Cos),
                       axis("theta_o", "deg", 0, 90, no, Spacing::Cos),
                       axis("phi_d", "deg", 0, 180, np, Spacing::Linear)},
                      [](const std::vector<double>& x) {
                          return f_ml(std::cos(x[0] * kDeg), std::cos(x[1] * kDeg), x[2]);
                      });
}

}  // namespace

TEST_CASE("linear interpolation is exact for functions multilinear in the warped coordinates") {
    const Axis a0 = axis("theta_i", "deg", 0, 90, 7, Spacing::Cos);
    const Axis a1 = axis("alpha", "1", 0.01, 1, 5, Spacing::Log);
    const Axis a2 = axis("beta", "1", 0, 2, 4, Spacing::Quadratic);
    const Axis a3 = axis("phi_d", "deg", 0, 180, 13, Spacing::Linear);
    // Linear in t of each axis: cos(theta), log(alpha), sqrt(beta), phi.
    auto g = [&](double th, double al, double be, double ph) {
        return (1 + 2 * std::cos(th * kDeg)) * (3 + std::log(al)) * (0.5 + std::sqrt(be)) *
               (1 - ph / 400);
    };
    LookupTable lt(make_table("t", {a0, a1, a2, a3}, [&](const std::vector<double>& x) {
        return g(x[0], x[1], x[2], x[3]);
    }));
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> U(0, 1);
    double max_err = 0;
    for (int n = 0; n < 2000; ++n) {
        const double th = 90 * U(rng), al = 0.01 * std::pow(100.0, U(rng)), be = 2 * U(rng),
                     ph = 180 * U(rng);
        max_err = std::max(max_err, std::fabs(lt.eval({th, al, be, ph}) - g(th, al, be, ph)));
    }
    CHECK(max_err < 1e-11);
    // A function that is linear in theta (not cos theta) is NOT reproduced:
    // interpolation really happens in the warped coordinate.
    LookupTable lin(make_table("t", {a0}, [](const std::vector<double>& x) { return x[0]; }));
    CHECK(std::fabs(lin.eval({40.0}) - 40.0) > 0.1);
}

TEST_CASE("Catmull-Rom reproduces quadratics in t on every cell and beats linear on smooth data") {
    const Axis a0 = axis("theta_o", "deg", 0, 90, 6, Spacing::Cos);
    const Axis a1 = axis("alpha", "1", 0.05, 1, 5, Spacing::Log);
    auto q = [&](double th, double al) {
        const double t0 = tcoord(a0, th), t1 = tcoord(a1, al);
        return (1 + 3 * t0 - 2 * t0 * t0) * (2 - t1 + 4 * t1 * t1);
    };
    LookupTable lt(make_table("t", {a0, a1}, [&](const std::vector<double>& x) {
        return q(x[0], x[1]);
    }));
    std::mt19937_64 rng(2);
    std::uniform_real_distribution<double> U(0, 1);
    double max_err = 0;
    for (int n = 0; n < 2000; ++n) {
        const double th = 90 * U(rng), al = 0.05 * std::pow(20.0, U(rng));
        max_err = std::max(max_err,
                           std::fabs(lt.eval({th, al}, Interpolation::Cubic) - q(th, al)));
    }
    CHECK(max_err < 1e-11);

    // Smooth non-polynomial function: cubic error well below linear.
    const Axis b0 = axis("x", "1", 0, 2, 12, Spacing::Linear);
    const Axis b1 = axis("y", "1", 0, 1, 9, Spacing::Linear);
    auto s = [](double x, double y) { return std::exp(std::sin(2 * x) * y) + std::cos(3 * y); };
    LookupTable sm(make_table("s", {b0, b1}, [&](const std::vector<double>& x) {
        return s(x[0], x[1]);
    }));
    double el = 0, ec = 0;
    for (int n = 0; n < 2000; ++n) {
        const double x = 2 * U(rng), y = U(rng);
        el = std::max(el, std::fabs(sm.eval({x, y}, Interpolation::Linear) - s(x, y)));
        ec = std::max(ec, std::fabs(sm.eval({x, y}, Interpolation::Cubic) - s(x, y)));
    }
    MESSAGE("smooth 12x9: max error linear ", el, " cubic ", ec);
    CHECK(ec < el / 4);

    // phi_d over [0, 180] uses mirrored ghosts: an even function such as
    // cos(phi) keeps zero slope at both ends, so end cells are as accurate
    // as interior ones.
    const Axis p = axis("phi_d", "deg", 0, 180, 10, Spacing::Linear);
    LookupTable ph(make_table("p", {p}, [](const std::vector<double>& x) {
        return std::cos(x[0] * kDeg);
    }));
    double e_end = 0, e_mid = 0;
    for (int n = 0; n <= 200; ++n) {
        const double x = 180.0 * n / 200;
        const double e = std::fabs(ph.eval({x}, Interpolation::Cubic) - std::cos(x * kDeg));
        (x < 20 || x > 160 ? e_end : e_mid) = std::max(x < 20 || x > 160 ? e_end : e_mid, e);
    }
    MESSAGE("cos(phi) cubic: end-cell error ", e_end, ", interior ", e_mid);
    CHECK(e_end < 2 * e_mid);
}

TEST_CASE("out-of-range coordinates: clamp, reject, NaN, wrong count, named coordinates") {
    const Axis a0 = axis("theta_i", "deg", 0, 80, 5, Spacing::Cos);
    const Axis a1 = axis("alpha", "1", 0.1, 0.5, 3, Spacing::Linear);
    auto g = [](double th, double al) { return std::cos(th * kDeg) + 10 * al; };
    LookupTable lt(make_table("t", {a0, a1}, [&](const std::vector<double>& x) {
        return g(x[0], x[1]);
    }));
    CHECK(lt.eval({85.0, 0.7}) == doctest::Approx(g(80, 0.5)).epsilon(1e-12));
    CHECK(lt.eval({-5.0, 0.0}) == doctest::Approx(g(0, 0.1)).epsilon(1e-12));
    CHECK_THROWS_AS(lt.eval({85.0, 0.3}, Interpolation::Linear, OutOfRange::Reject), InputError);
    try {
        lt.eval({40.0, 0.7}, Interpolation::Cubic, OutOfRange::Reject);
        FAIL("no throw");
    } catch (const InputError& e) {
        const std::string m = e.what();
        CHECK(m.find("alpha") != std::string::npos);
        CHECK(m.find("0.7") != std::string::npos);
        CHECK(m.find("[0.1, 0.5]") != std::string::npos);
    }
    CHECK_NOTHROW(lt.eval({80.0, 0.5}, Interpolation::Linear, OutOfRange::Reject));
    CHECK_THROWS_AS(lt.eval({std::nan(""), 0.3}), InputError);
    CHECK_THROWS_AS(lt.eval({40.0}), InputError);
    CHECK(lt.eval(std::map<std::string, double>{{"alpha", 0.3}, {"theta_i", 33.0}}) ==
          doctest::Approx(lt.eval({33.0, 0.3})).epsilon(1e-15));
    CHECK_THROWS_AS(lt.eval(std::map<std::string, double>{{"alpha", 0.3}}), InputError);
    CHECK_THROWS_AS(
        lt.eval(std::map<std::string, double>{{"alpha", 0.3}, {"theta_i", 3.0}, {"beta", 1.0}}),
        InputError);
    // Malformed tables are rejected.
    TableData bad = make_table("bad", {a0, a1}, [](const std::vector<double>&) { return 0.0; });
    bad.value.pop_back();
    CHECK_THROWS_AS(LookupTable{bad}, InputError);
}

TEST_CASE("eval_dirs: angles from vectors, phi_d folding and wrapping, mu axes, parameters") {
    LookupTable lt(brdf_ml_table());
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> U(0, 1);
    for (int n = 0; n < 500; ++n) {
        const double ti = 90 * U(rng), to = 90 * U(rng), pi = 360 * U(rng), po = 360 * U(rng);
        const Vec3 wi = dir(ti, pi), wo = dir(to, po);
        // Independent phi_d: angle between the projections (always in [0, 180]).
        const double c = (wi.x * wo.x + wi.y * wo.y) /
                         std::sqrt((wi.x * wi.x + wi.y * wi.y) * (wo.x * wo.x + wo.y * wo.y));
        const double pd = std::acos(std::max(-1.0, std::min(1.0, c))) / kDeg;
        REQUIRE(lt.eval_dirs(wi, wo) ==
                doctest::Approx(f_ml(wi.z, wo.z, pd)).epsilon(1e-10));
    }
    // phi_d = 30, -30 and 330 are the same configuration.
    const Vec3 wi = dir(35, 40);
    const double v30 = lt.eval_dirs(wi, dir(60, 70));
    CHECK(lt.eval_dirs(wi, dir(60, 10)) == doctest::Approx(v30).epsilon(1e-12));
    CHECK(lt.eval_dirs(wi, dir(60, 370)) == doctest::Approx(v30).epsilon(1e-12));
    CHECK(v30 == doctest::Approx(f_ml(std::cos(35 * kDeg), std::cos(60 * kDeg), 30)).epsilon(1e-12));

    // mu axes and a phi_d axis over [-180, 180] (wrapped, not folded): an
    // odd-in-phi function distinguishes +phi_d from -phi_d.
    auto h = [](double mi, double mo, double pd) { return 1 + mi * mo + pd / 360; };
    LookupTable mu(make_table("m",
                              {axis("mu_i", "1", 0, 1, 4, Spacing::Linear),
                               axis("mu_o", "1", -1, 1, 5, Spacing::Linear),
                               axis("phi_d", "deg", -180, 180, 9, Spacing::Linear)},
                              [&](const std::vector<double>& x) { return h(x[0], x[1], x[2]); }));
    CHECK(mu.eval_dirs(dir(50, 10), dir(120, 40)) ==
          doctest::Approx(h(std::cos(50 * kDeg), std::cos(120 * kDeg), 30)).epsilon(1e-12));
    CHECK(mu.eval_dirs(dir(50, 10), dir(120, -20)) ==
          doctest::Approx(h(std::cos(50 * kDeg), std::cos(120 * kDeg), -30)).epsilon(1e-12));
    CHECK(mu.eval_dirs(dir(50, 10), dir(120, 210)) ==
          doctest::Approx(h(std::cos(50 * kDeg), std::cos(120 * kDeg), -160)).epsilon(1e-12));

    // A parameter axis: eval_dirs and bind agree with the closed form.
    auto k = [](double al, double mi, double mo, double pd) {
        return al * al + mi * mo * (1 + pd / 180) * al;  // linear interp exact only at alpha nodes
    };
    LookupTable par(make_table("p",
                               {axis("alpha", "1", 0.1, 0.9, 5, Spacing::Linear),
                                axis("theta_i", "deg", 0, 90, 5, Spacing::Cos),
                                axis("theta_o", "deg", 0, 90, 5, Spacing::Cos),
                                axis("phi_d", "deg", 0, 180, 5, Spacing::Linear)},
                               [&](const std::vector<double>& x) {
                                   return k(x[0], std::cos(x[1] * kDeg), std::cos(x[2] * kDeg),
                                            x[3]);
                               }));
    const Vec3 a = dir(20, 0), b = dir(70, 100);
    const double pd = 100;
    CHECK(par.eval_dirs(a, b, {{"alpha", 0.3}}) ==
          doctest::Approx(k(0.3, a.z, b.z, pd)).epsilon(1e-12));
    // Between alpha nodes 0.3 and 0.5: linear interpolation of alpha^2 + c*alpha.
    const double lin = 0.5 * (k(0.3, a.z, b.z, pd) + k(0.5, a.z, b.z, pd));
    CHECK(par.eval_dirs(a, b, {{"alpha", 0.4}}) == doctest::Approx(lin).epsilon(1e-12));
    const BoundTable bt = par.bind({{"alpha", 0.4}});
    CHECK(bt.eval(a, b) == doctest::Approx(lin).epsilon(1e-12));
    CHECK_THROWS_AS(par.eval_dirs(a, b), InputError);
    CHECK_THROWS_AS(par.eval_dirs(a, b, {{"alpha", 0.4}, {"sigma", 1.0}}), InputError);
    CHECK_THROWS_AS(par.bind({{"alpha", 1.4}}, Interpolation::Linear, OutOfRange::Reject),
                    InputError);
    // Tables without both polar axes have no direction-level lookup.
    LookupTable plain(make_table("q", {axis("alpha", "1", 0, 1, 3, Spacing::Linear)},
                                 [](const std::vector<double>& x) { return x[0]; }));
    CHECK_THROWS_AS(plain.eval_dirs(a, b), InputError);
}

TEST_CASE("reciprocal_half tables are completed by f(i,o) = f(o,i)") {
    auto sym = [](double mi, double mo, double pd) {
        return 0.3 + mi * mo + 0.2 * (mi + mo) + 0.1 * pd / 180;
    };
    TableData t = make_table("half",
                             {axis("theta_i", "deg", 0, 90, 6, Spacing::Cos),
                              axis("theta_o", "deg", 0, 90, 6, Spacing::Cos),
                              axis("phi_d", "deg", 0, 180, 4, Spacing::Linear)},
                             [&](const std::vector<double>& x) {
                                 if (x[0] > x[1]) return std::nan("");  // not stored
                                 return sym(std::cos(x[0] * kDeg), std::cos(x[1] * kDeg), x[2]);
                             });
    t.parameters["reciprocal_half"] = true;
    LookupTable lt(t);
    std::mt19937_64 rng(4);
    std::uniform_real_distribution<double> U(0, 1);
    for (int n = 0; n < 300; ++n) {
        const Vec3 wi = dir(90 * U(rng), 0), wo = dir(90 * U(rng), 180 * U(rng));
        const double pd = std::atan2(wo.y, wo.x) / kDeg;
        REQUIRE(lt.eval_dirs(wi, wo) == doctest::Approx(sym(wi.z, wo.z, pd)).epsilon(1e-10));
    }
    TableData bad = t;
    bad.axes[1] = axis("theta_o", "deg", 0, 90, 6, Spacing::Linear);
    CHECK_THROWS_AS(LookupTable{bad}, InputError);
}

TEST_CASE("recombination: value = N(p)/D(p) * sum_k C_k(p) table_k") {
    // Orders of a series in an albedo-like parameter c, plus a Kd/(pi n^2 (1 - r Kd))
    // style prefactor with n = 1.5, r = 0.6 fixed.
    const std::vector<Axis> ax = {axis("theta_i", "deg", 0, 90, 5, Spacing::Cos),
                                  axis("theta_o", "deg", 0, 90, 5, Spacing::Cos)};
    auto o1 = [](double mi, double mo) { return 1 + mi * mo; };
    auto o2 = [](double mi, double mo) { return mi + mo; };
    auto o3 = [](double mi, double mo) { return 0.5 * mi + 0 * mo; };
    auto mk = [&](const std::string& n, std::function<double(double, double)> f) {
        return make_table(n, ax, [f](const std::vector<double>& x) {
            return f(std::cos(x[0] * kDeg), std::cos(x[1] * kDeg));
        });
    };
    std::vector<TableData> tabs = {mk("order1", o1), mk("order2", o2), mk("order3", o3)};
    const double n = 1.5, r = 0.6;
    TableData head = mk("brdf", o1);  // head carries the recipe; its own values are unused
    head.parameters["recombine"] = {
        {"parameter", "c"},
        {"range", {0.0, 1.0}},
        {"terms",
         {{{"table", "order1"}, {"coeffs", {0.0, 1.0}}},
          {{"table", "order2"}, {"coeffs", {0.0, 0.0, 1.0}}},
          {{"table", "order3"}, {"coeffs", {0.0, 0.0, 0.0, 1.0}}}}},
        {"prefactor", {{"num", {1.0 / (kPi * n * n)}}, {"den", {1.0, -r}}}}};
    tabs.push_back(head);
    LookupTable lt = LookupTable::from_tables(tabs, "brdf");
    CHECK(lt.has_recombination());
    CHECK(lt.coordinate_names() == std::vector<std::string>{"theta_i", "theta_o", "c"});
    auto truth = [&](double mi, double mo, double c) {
        return (c * o1(mi, mo) + c * c * o2(mi, mo) + c * c * c * o3(mi, mo)) /
               (kPi * n * n * (1 - r * c));
    };
    for (double c : {0.0, 0.25, 0.8, 1.0}) {
        const Vec3 wi = dir(30, 0), wo = dir(65, 120);
        CHECK(lt.eval({30.0, 65.0, c}) ==
              doctest::Approx(truth(std::cos(30 * kDeg), std::cos(65 * kDeg), c)).epsilon(1e-12));
        CHECK(lt.eval_dirs(wi, wo, {{"c", c}}) ==
              doctest::Approx(truth(wi.z, wo.z, c)).epsilon(1e-12));
        CHECK(lt.bind({{"c", c}}).eval(wi, wo) ==
              doctest::Approx(truth(wi.z, wo.z, c)).epsilon(1e-12));
    }
    CHECK_THROWS_AS(lt.eval({30.0, 65.0, 1.5}, Interpolation::Linear, OutOfRange::Reject),
                    InputError);
    CHECK(lt.eval({30.0, 65.0, 1.5}) == doctest::Approx(lt.eval({30.0, 65.0, 1.0})));
    CHECK_THROWS_AS(lt.eval_dirs(dir(1, 0), dir(2, 0)), InputError);  // c missing
    std::vector<TableData> missing = {head, tabs[0]};
    CHECK_THROWS_AS(LookupTable::from_tables(missing, "brdf"), InputError);
}

TEST_CASE("sampling a Lambertian table: pdf is the cell average of cos/pi") {
    const Axis ao = axis("theta_o", "deg", 0, 90, 10, Spacing::Cos);
    LookupTable lt(make_table("lambert",
                              {axis("theta_i", "deg", 0, 90, 5, Spacing::Cos), ao,
                               axis("phi_d", "deg", 0, 180, 7, Spacing::Linear)},
                              [](const std::vector<double>&) { return 1 / kPi; }));
    const BoundTable bt = lt.bind();
    REQUIRE(bt.can_sample());
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> U(0, 1);
    double max_dev = 0;
    for (int n = 0; n < 2000; ++n) {
        const Vec3 wi = dir(90 * U(rng), 360 * U(rng));
        const auto s = bt.sample(wi, U(rng), U(rng));
        const double mu = s.wo.z;
        // Cell of mu on the cos-spaced axis: mu nodes are 1 - k/9.
        const double k = std::min(8.0, std::floor((1 - mu) * 9));
        const double mean_mu = 1 - (k + 0.5) / 9;
        REQUIRE(s.pdf == doctest::Approx(mean_mu / kPi).epsilon(1e-10));
        REQUIRE(s.weight == doctest::Approx(mu / mean_mu).epsilon(1e-10));
        REQUIRE(s.value == doctest::Approx(1 / kPi).epsilon(1e-12));
        max_dev = std::max(max_dev, std::fabs(s.pdf - mu / kPi));
    }
    CHECK(max_dev <= 0.5 / 9 / kPi + 1e-12);
    CHECK(bt.pdf(dir(10, 0), dir(100, 0)) == 0);  // below the table's theta_o range
}

TEST_CASE("sampling: normalisation, chi-square against pdf(), weights and an unbiased albedo") {
    LookupTable lt(brdf_ml_table(6, 10, 7));
    const BoundTable bt = lt.bind();
    REQUIRE(bt.can_sample());
    const Vec3 wi = dir(47, 25);  // between theta_i nodes: a two-node mixture

    // (1) Integral of pdf over the sphere by a fine midpoint rule in (mu, phi).
    {
        const int nm = 600, nphi = 720;
        double sum = 0;
        for (int a = 0; a < nm; ++a)
            for (int b = 0; b < nphi; ++b) {
                const double mu = -1 + 2 * (a + 0.5) / nm, phi = 2 * kPi * (b + 0.5) / nphi;
                const double st = std::sqrt(1 - mu * mu);
                sum += bt.pdf(wi, {st * std::cos(phi), st * std::sin(phi), mu});
            }
        const double integral = sum * (2.0 / nm) * (2 * kPi / nphi);
        MESSAGE("integral of pdf over the sphere: ", integral);
        CHECK(integral == doctest::Approx(1).epsilon(3e-3));
    }

    // (2) Histogram of 200k samples over sub-cells of the table cells:
    // theta_o cell x phi_d cell x sign(phi_d) x 2 x 2 sub-bins.  The pdf is
    // constant on each cell, so a bin's probability is pdf(centre) times its
    // exact solid angle (d mu d phi).
    const int no = 10, np = 7, sub = 2;
    auto mu_node = [&](int k) { return 1 - double(k) / (no - 1); };
    auto ph_node = [&](int l) { return kPi * l / (np - 1); };
    const int nbins = (no - 1) * (np - 1) * 2 * sub * sub;
    std::vector<double> expected(nbins, 0), count(nbins, 0);
    for (int k = 0; k < no - 1; ++k)
        for (int l = 0; l < np - 1; ++l)
            for (int s = 0; s < 2; ++s)
                for (int a = 0; a < sub; ++a)
                    for (int b = 0; b < sub; ++b) {
                        const double m0 = mu_node(k + 1), m1 = mu_node(k);
                        const double p0 = ph_node(l), p1 = ph_node(l + 1);
                        const double mc = m0 + (a + 0.5) / sub * (m1 - m0);
                        const double pc = (p0 + (b + 0.5) / sub * (p1 - p0)) * (s ? -1 : 1);
                        const double st = std::sqrt(1 - mc * mc), phi = std::atan2(wi.y, wi.x) + pc;
                        const double area = (m1 - m0) / sub * (p1 - p0) / sub;
                        expected[(((k * (np - 1) + l) * 2 + s) * sub + a) * sub + b] =
                            bt.pdf(wi, {st * std::cos(phi), st * std::sin(phi), mc}) * area;
                    }
    double total_p = 0;
    for (double e : expected) total_p += e;
    CHECK(total_p == doctest::Approx(1).epsilon(1e-10));

    std::mt19937_64 rng(6);
    std::uniform_real_distribution<double> U(0, 1);
    const int N = 200000;
    double wsum = 0, wsum2 = 0, max_rel = 0;
    for (int n = 0; n < N; ++n) {
        const SampleResult r = bt.sample(wi, U(rng), U(rng));
        const double mu = r.wo.z;
        double pd = std::atan2(r.wo.y, r.wo.x) - std::atan2(wi.y, wi.x);
        pd = std::remainder(pd, 2 * kPi);
        const int s = pd < 0 ? 1 : 0;
        const double apd = std::fabs(pd);
        const double fk = (1 - mu) * (no - 1), fl = apd / kPi * (np - 1);
        const int k = std::min(no - 2, int(fk)), l = std::min(np - 2, int(fl));
        const int a = std::min(sub - 1, int((1 - (fk - k)) * sub));  // sub-bin in increasing mu
        const int b = std::min(sub - 1, int((fl - l) * sub));
        count[(((k * (np - 1) + l) * 2 + s) * sub + a) * sub + b] += 1;
        // weight * pdf = f * cos, with f known in closed form (exact for this table).
        const double f = f_ml(wi.z, mu, apd / kDeg);
        max_rel = std::max(max_rel, std::fabs(r.weight * r.pdf - f * std::fabs(mu)) /
                                        (f * std::fabs(mu) + 1e-300));
        max_rel = std::max(max_rel, std::fabs(r.value - f) / f);
        wsum += r.weight;
        wsum2 += r.weight * r.weight;
    }
    CHECK(max_rel < 1e-9);
    double chi2 = 0;
    int dof = -1;
    for (int i = 0; i < nbins; ++i) {
        const double e = expected[i] * N;
        REQUIRE(e > 5);
        chi2 += (count[i] - e) * (count[i] - e) / e;
        ++dof;
    }
    const double pval = chi2_pvalue(chi2, dof);
    MESSAGE("chi2 = ", chi2, " with ", dof, " dof, p = ", pval);
    CHECK(pval > 1e-4);

    // (3) Unbiasedness: mean weight = albedo, closed form
    // (0.2 + mi) * (0.05/2 + 1/3) * integral over phi of (1 + 2|phi|/pi) = 4 pi.
    const double mean = wsum / N, sd = std::sqrt((wsum2 / N - mean * mean) / N);
    const double albedo = (0.2 + wi.z) * (0.025 + 1.0 / 3) * 4 * kPi;
    MESSAGE("albedo estimate ", mean, " +- ", sd, " (exact ", albedo, ")");
    CHECK(std::fabs(mean - albedo) < 4 * sd);
}

TEST_CASE("sampling a transmission table over theta_o in [0, 180] without a phi_d axis") {
    // 8 cos-spaced nodes over [0, 180]: no node at 90, one cell straddles the horizon.
    auto f = [](double mo) { return 0.5 + 0.25 * mo; };
    LookupTable lt(make_table("bsdf",
                              {axis("theta_i", "deg", 0, 90, 3, Spacing::Cos),
                               axis("theta_o", "deg", 0, 180, 8, Spacing::Cos)},
                              [&](const std::vector<double>& x) { return f(std::cos(x[1] * kDeg)); }));
    const BoundTable bt = lt.bind();
    REQUIRE(bt.can_sample());
    const Vec3 wi = dir(30, 0);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> U(0, 1);
    const int N = 100000;
    double sum = 0, sum2 = 0;
    int below = 0;
    for (int n = 0; n < N; ++n) {
        const auto r = bt.sample(wi, U(rng), U(rng));
        REQUIRE(r.weight * r.pdf == doctest::Approx(f(r.wo.z) * std::fabs(r.wo.z)).epsilon(1e-9));
        below += r.wo.z < 0;
        sum += r.weight;
        sum2 += r.weight * r.weight;
    }
    // integral of (0.5 + 0.25 mu)|mu| over the sphere = 2 pi * 0.5 = pi.
    const double mean = sum / N, sd = std::sqrt((sum2 / N - mean * mean) / N);
    MESSAGE("transmission albedo ", mean, " +- ", sd, ", fraction below horizon ", double(below) / N);
    CHECK(std::fabs(mean - kPi) < 4 * sd);
    // Fraction below the horizon: integral of f|mu| over mu < 0 / total = (0.5 - 0.25*2/3)/1.
    CHECK(double(below) / N == doctest::Approx((0.25 - 0.25 / 3) * 2 * kPi / kPi).epsilon(0.02));
}

TEST_CASE("tables that cannot be sampled say why") {
    LookupTable lt(make_table("partial",
                              {axis("theta_i", "deg", 0, 90, 3, Spacing::Cos),
                               axis("theta_o", "deg", 0, 60, 4, Spacing::Cos),
                               axis("phi_d", "deg", 0, 180, 3, Spacing::Linear)},
                              [](const std::vector<double>&) { return 1.0; }));
    const BoundTable bt = lt.bind();
    CHECK_FALSE(bt.can_sample());
    CHECK(bt.sampling_error().find("theta_o") != std::string::npos);
    CHECK_THROWS_AS(bt.sample(dir(10, 0), 0.5, 0.5), Error);
    CHECK(bt.eval(dir(10, 0), dir(30, 0)) == doctest::Approx(1.0));
}

TEST_CASE("file round trip through write_tables / LookupTable::open") {
    const std::string path = std::string(BT_BINARY_DIR) + "/test_lookup_roundtrip.h5";
    TableData t = brdf_ml_table(5, 6, 4);
    t.stored_type = StoredType::Float64;
    t.compression = 0;
    t.keep_stderr = false;
    TableData o1 = t, o2 = t;
    o1.name = "order1";
    o2.name = "order2";
    TableData head = t;
    head.name = "combined";
    head.parameters["recombine"] = {
        {"parameter", "c"},
        {"terms",
         {{{"table", "order1"}, {"coeffs", {0.0, 1.0}}},
          {{"table", "order2"}, {"coeffs", {0.0, 0.0, 2.0}}}}}};
    write_tables(path, {t, o1, o2, head});
    LookupTable lt = LookupTable::open(path, "brdf");
    CHECK(lt.model() == "test");
    CHECK(lt.units() == "1/sr");
    REQUIRE(lt.axes().size() == 3);
    CHECK(lt.axes()[0].spacing == Spacing::Cos);
    const Vec3 wi = dir(33, 10), wo = dir(71, 150);
    const double f = f_ml(wi.z, wo.z, 140);
    CHECK(lt.eval_dirs(wi, wo) == doctest::Approx(f).epsilon(1e-10));
    LookupTable c = LookupTable::open(path, "combined");
    CHECK(c.eval_dirs(wi, wo, {{"c", 0.5}}) == doctest::Approx((0.5 + 0.5) * f).epsilon(1e-10));
    CHECK_THROWS_AS(LookupTable::open(path, "nope"), InputError);
    std::remove(path.c_str());
}

TEST_CASE("hostile shapes: an overflowing cell count and min/max off the node list") {
    // 4 axes of 65 536 nodes: 2^64 cells, which wrapped to 0 and crashed
    // every lookup (#15).  Refused before any value is touched.
    TableData t;
    t.name = "huge";
    for (const char* n : {"a", "b", "c", "d"}) t.axes.push_back(axis(n, "1", 0.0, 1.0, 65536));
    bool refused = false;
    try {
        LookupTable lt(t);
    } catch (const InputError& e) {
        refused = std::string(e.what()).find("65536 x 65536 x 65536 x 65536") != std::string::npos;
    }
    CHECK(refused);

    // min/max that disagree with the end nodes would shift every lookup
    // (interpolation warps between them): refused, naming the axis.
    TableData s;
    s.name = "small";
    s.axes = {axis("x", "1", 0.0, 1.0, 3)};
    s.value = {0.0, 1.0, 2.0};
    CHECK(LookupTable(s).eval({0.5}) == doctest::Approx(1.0));
    s.axes[0].max = 2.0;
    std::string msg;
    try {
        LookupTable lt(s);
    } catch (const InputError& e) {
        msg = e.what();
    }
    CHECK(msg.find("axis 'x'") != std::string::npos);
    CHECK(msg.find("min/max") != std::string::npos);
}

// test_lookup_trig.cpp — the fast trigonometry of direction lookups
// (host/lookup/fast_trig.h) against the C library's functions.
//
// Oracles: std::atan2, std::acos, std::sin and std::cos (glibc: within an
// ulp of the true values), over dense sweeps, random arguments of every
// magnitude and sign, and the special points: +-0, +-1, denormals, the
// reduction boundaries (tan(pi/8), |y| = |x|, multiples of pi/4) and grazing
// directions.  The bounds are those docs/lookup.md states.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "host/lookup/fast_trig.h"

namespace ft = brdftab::fast_trig;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kAtanBound = 2.5e-15;  // rad, atan2 and acos
constexpr double kSinCosBound = 5e-16;

double atan2_err(double y, double x) { return std::fabs(ft::atan2(y, x) - std::atan2(y, x)); }

}  // namespace

TEST_CASE("fast atan2: dense sweep of the circle at several radii") {
    double worst = 0;
    const int n = 400000;
    for (double r : {1.0, 1e-3, 7.5e5, 1e-300, 1e300}) {
        for (int k = 0; k <= n; ++k) {
            const double a = -kPi + 2 * kPi * k / n;
            worst = std::max(worst, atan2_err(r * std::sin(a), r * std::cos(a)));
        }
    }
    CAPTURE(worst);
    CHECK(worst <= kAtanBound);
}

TEST_CASE("fast atan2: random arguments of every magnitude and sign, denormals included") {
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> e(-320, 300), U(0, 1);
    double worst = 0;
    for (int k = 0; k < 1000000; ++k) {
        const double y = (U(rng) < 0.5 ? -1 : 1) * std::pow(10.0, e(rng));
        const double x = (U(rng) < 0.5 ? -1 : 1) * std::pow(10.0, e(rng));
        worst = std::max(worst, atan2_err(y, x));
    }
    // Ratios near the reduction boundaries: tan(pi/8) and 1, from both sides.
    const double t8 = std::tan(kPi / 8);
    for (int k = -2000; k <= 2000; ++k)
        for (double b : {t8, 1.0}) {
            const double y = b + k * std::numeric_limits<double>::epsilon();
            for (double sx : {1.0, -1.0})
                for (double sy : {1.0, -1.0}) {
                    worst = std::max(worst, atan2_err(sy * y, sx * 1.0));
                    worst = std::max(worst, atan2_err(sx * 1.0, sy * y));
                }
        }
    CAPTURE(worst);
    CHECK(worst <= kAtanBound);
}

TEST_CASE("fast atan2: zeros, denormals and exact angles as std::atan2") {
    const double dmin = std::numeric_limits<double>::denorm_min();
    const double vals[] = {0.0, -0.0, dmin, -dmin, 1e-310, -1e-310, 1.0, -1.0, 3.0, -2.5e-7};
    for (double y : vals)
        for (double x : vals) {
            CAPTURE(y);
            CAPTURE(x);
            const double f = ft::atan2(y, x), s = std::atan2(y, x);
            CHECK(std::fabs(f - s) <= kAtanBound);
            CHECK(std::signbit(f) == std::signbit(s));  // +-0 and +-pi as the C library
            if (s == 0 || std::fabs(s) == std::atan2(0.0, -1.0)) CHECK(f == s);
        }
    CHECK(std::isnan(ft::atan2(NAN, 1.0)));
    CHECK(std::isnan(ft::atan2(1.0, NAN)));
    CHECK(std::isnan(ft::atan2(0.0, NAN)));
}

TEST_CASE("fast acos: dense sweep of [-1, 1], its ends and grazing cosines") {
    double worst = 0;
    const int n = 2000000;
    for (int k = 0; k <= n; ++k) {
        const double c = -1 + 2.0 * k / n;
        worst = std::max(worst, std::fabs(ft::acos(c) - std::acos(c)));
    }
    // Next to +-1 and 0, one ulp at a time, and the cosines of grazing angles.
    const double eps = std::numeric_limits<double>::epsilon();
    for (int k = 0; k < 100000; ++k) {
        for (double c : {1 - k * eps / 2, -1 + k * eps / 2, k * 1e-300, -k * 1e-300, k * eps})
            worst = std::max(worst, std::fabs(ft::acos(c) - std::acos(c)));
        const double g = std::cos(kPi / 2 - k * 1e-9);
        worst = std::max(worst, std::fabs(ft::acos(g) - std::acos(g)));
    }
    CAPTURE(worst);
    CHECK(worst <= kAtanBound);
    CHECK(ft::acos(1.0) == 0.0);
    CHECK(ft::acos(-1.0) == std::acos(-1.0));
    CHECK(ft::acos(1.5) == 0.0);  // clamped
    CHECK(ft::acos(-7.0) == std::acos(-1.0));
}

TEST_CASE("fast atan2 of a direction's (sqrt(x^2 + y^2), z): the polar angle up to grazing") {
    std::mt19937_64 rng(2);
    std::uniform_real_distribution<double> U(0, 1);
    double worst = 0, worst_atan2 = 0;
    for (int k = 0; k < 200000; ++k) {
        // theta in [0, pi], dense near the pole and near the horizon.
        const double th = k < 100000 ? kPi * U(rng) : kPi / 2 + (U(rng) - 0.5) * 1e-6;
        const double ph = 2 * kPi * U(rng);
        const double x = std::sin(th) * std::cos(ph), y = std::sin(th) * std::sin(ph),
                     z = std::cos(th);
        const double l = std::sqrt(x * x + y * y + z * z);
        const double want = std::acos(std::min(1.0, std::max(-1.0, z / l)));
        const double f = ft::atan2(std::sqrt(x * x + y * y), z);
        worst_atan2 = std::max(worst_atan2, std::fabs(f - std::atan2(std::sqrt(x * x + y * y), z)));
        // acos of a rounded cosine is itself off by up to 1.2e-16 / sin(theta).
        const double slack = 3e-16 / std::sin(std::max(th, 1e-300));
        worst = std::max(worst, std::fabs(f - want) - slack);
    }
    CAPTURE(worst);
    CAPTURE(worst_atan2);
    CHECK(worst <= kAtanBound);
    CHECK(worst_atan2 <= kAtanBound);
}

TEST_CASE("fast sincos: dense sweep, quadrant boundaries and large arguments") {
    double worst = 0;
    auto check = [&](double x) {
        double s, c;
        ft::sincos(x, s, c);
        worst = std::max(worst, std::max(std::fabs(s - std::sin(x)), std::fabs(c - std::cos(x))));
    };
    const int n = 2000000;
    for (int k = 0; k <= n; ++k) check(-4 * kPi + 8 * kPi * k / n);
    const double eps = std::numeric_limits<double>::epsilon();
    for (int q = -16; q <= 16; ++q)
        for (int k = -1000; k <= 1000; ++k) check(q * kPi / 4 * (1 + k * eps));
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> U(-1e6, 1e6);
    for (int k = 0; k < 1000000; ++k) check(U(rng));
    for (double x : {0.0, -0.0, 1e-310, -1e-310, 1e-8, 1e6, -1e6}) check(x);
    CAPTURE(worst);
    CHECK(worst <= kSinCosBound);
    double s, c;
    ft::sincos(-0.0, s, c);
    CHECK((s == 0 && c == 1));
}

// test_support.h — constants, oracles and helpers shared by the tests.
// Written independently of the kernels and of the host code they test, so
// tests that use them stay oracles.
#pragma once

#include <cfloat>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "host/core/error.h"
#include "host/core/grid.h"

namespace brdftab::test {

// The message of the InputError that `f` throws; "" when it throws none.
template <class F>
std::string input_error(F&& f) {
    try {
        f();
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

// pi and one degree in radians, typed here rather than taken from the
// kernels' constants.
constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180;

// Unpolarised Fresnel reflectance of a smooth dielectric interface, the mean
// of the squared s- and p-polarised amplitude coefficients (Hecht, Optics,
// sec. 4.6): rs = (ci - eta ct)/(ci + eta ct), rp = (eta ci - ct)/(eta ci + ct),
// ct from Snell's law; 1 under total internal reflection.  eta is the ratio
// of the refractive index across the interface to the one on the incident
// side; |ci| is used, so the side of the normal does not matter.
inline double fresnel_sp(double ci, double eta) {
    ci = std::fabs(ci);
    const double st2 = (1 - ci * ci) / (eta * eta);
    if (st2 >= 1) return 1;
    const double ct = std::sqrt(1 - st2);
    const double rs = (ci - eta * ct) / (ci + eta * ct);
    const double rp = (eta * ci - ct) / (eta * ci + ct);
    return 0.5 * (rs * rs + rp * rp);
}

// Welford running mean and standard error of the mean.
struct RunningStat {
    double mean = 0, m2 = 0;
    long n = 0;
    void add(double x) {
        ++n;
        const double d = x - mean;
        mean += d / n;
        m2 += d * (x - mean);
    }
    double se() const { return n > 1 ? std::sqrt(m2 / (n - 1) / n) : 0; }
};

// An axis with its nodes filled by hand from the spacing definitions (not by
// make_axis, which the grid tests test), for tests that build tables in
// memory.  Node k of n sits at t = k/(n-1): lo + t (hi - lo) (linear), the
// angle whose cosine is the same blend of cos lo and cos hi (cos, degrees),
// lo (hi/lo)^t (log), lo + t^2 (hi - lo) (quadratic); the end nodes are lo
// and hi exactly.  One node: lo.
inline Axis axis(const std::string& name, const std::string& unit, double lo, double hi,
                 std::size_t n, Spacing spacing = Spacing::Linear) {
    Axis a;
    a.name = name;
    a.unit = unit;
    a.min = lo;
    a.max = hi;
    a.count = n;
    a.spacing = spacing;
    if (n == 1) {
        a.values = {lo};
        return a;
    }
    for (std::size_t k = 0; k < n; ++k) {
        const double t = double(k) / double(n - 1);
        double x = 0;
        switch (spacing) {
            case Spacing::Linear: x = lo + t * (hi - lo); break;
            case Spacing::Cos: {
                const double c0 = std::cos(lo * kDeg), c1 = std::cos(hi * kDeg);
                x = std::acos(c0 + t * (c1 - c0)) / kDeg;
                break;
            }
            case Spacing::Log: x = lo * std::pow(hi / lo, t); break;
            case Spacing::Quadratic: x = lo + t * t * (hi - lo); break;
            case Spacing::Explicit:
                throw std::invalid_argument("axis: explicit nodes are not computed");
            case Spacing::LogComplement:
            case Spacing::Critical:
                throw std::invalid_argument("axis: build log-complement and critical axes with "
                                            "make_log_complement_axis / make_critical_axis");
        }
        a.values.push_back(x);
    }
    a.values.front() = lo;
    a.values.back() = hi;
    return a;
}

// The text of a shared spec fixture, tests/data/<name>.
inline std::string fixture_text(const std::string& name) {
    const std::filesystem::path p = std::filesystem::path(BT_SOURCE_DIR) / "tests" / "data" / name;
    std::ifstream in(p);
    if (!in) throw std::runtime_error("cannot read test fixture " + p.string());
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

// An empty scratch directory under the build tree: <build>/tmp-<test>/<sub>.
inline std::filesystem::path scratch_dir(const std::string& binary_dir, const std::string& test,
                                         const std::string& sub) {
    const std::filesystem::path d = std::filesystem::path(binary_dir) / ("tmp-" + test) / sub;
    std::filesystem::remove_all(d);
    std::filesystem::create_directories(d);
    return d;
}

// Gauss-Legendre nodes and weights on [-1, 1], nodes in decreasing order:
// Newton's method on the three-term recurrence of P_n, in long double.
inline void gauss_legendre(int n, std::vector<double>& x, std::vector<double>& w) {
    const long double pi = 3.14159265358979323846264338327950288L;
    x.resize(n);
    w.resize(n);
    for (int k = 0; k < n; ++k) {
        long double z = std::cos(pi * (k + 0.75L) / (n + 0.5L)), dp = 0;
        for (int it = 0; it < 200; ++it) {
            long double p0 = 1, p1 = z;
            for (int j = 2; j <= n; ++j) {
                const long double p2 = ((2 * j - 1) * z * p1 - (j - 1) * p0) / j;
                p0 = p1;
                p1 = p2;
            }
            dp = n * (z * p1 - p0) / (z * z - 1);
            const long double dz = p1 / dp;
            z -= dz;
            if (std::fabs(static_cast<double>(dz)) < 1e-19) break;
        }
        x[k] = static_cast<double>(z);
        w[k] = static_cast<double>(2 / ((1 - z * z) * dp * dp));
    }
}

// Error of a double result y in units in the last place of the exact value
// v (given as long double): |y - v| / ulp(v), with the spacing of doubles at
// |v| (the subnormal spacing below DBL_MIN).  NaN against NaN and equal
// infinities count 0; any other NaN or infinity counts 1e30.
inline long double ulp_at(long double v) {
    const double d = std::fabs(static_cast<double>(v));
    if (d < DBL_MIN) return std::ldexp(1.0L, -1074);
    int e;
    std::frexp(d, &e);  // d = m 2^e, m in [0.5, 1)
    return std::ldexp(1.0L, e - 53);
}

inline double ulp_error(double y, long double v) {
    const double vd = static_cast<double>(v);
    if (std::isnan(y) || std::isnan(vd)) return std::isnan(y) && std::isnan(vd) ? 0 : 1e30;
    if (std::isinf(vd) || std::isinf(y)) return vd == y ? 0 : 1e30;
    return static_cast<double>(std::fabs(static_cast<long double>(y) - v) / ulp_at(v));
}

// Points PoCL's kernel cache at BUILD_DIR/pocl-cache unless POCL_CACHE_DIR is
// already set, so that a test binary run by hand does not write to the
// user's own cache.  Returns true, for a namespace-scope initialiser that
// runs before the first test.
inline bool default_pocl_cache(const std::string& build_dir) {
    if (!std::getenv("POCL_CACHE_DIR")) {
        const std::string dir = build_dir + "/pocl-cache";
        std::filesystem::create_directories(dir);
        ::setenv("POCL_CACHE_DIR", dir.c_str(), 1);
    }
    return true;
}

}  // namespace brdftab::test

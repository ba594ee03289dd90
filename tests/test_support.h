// test_support.h — numerical helpers shared by the model tests.  Written
// independently of the kernels, so tests that use them stay oracles.
#pragma once

#include <cmath>
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "host/core/grid.h"

namespace brdftab::test {

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

// A linear axis with its nodes filled by hand (not by make_axis, which the
// grid tests test), for tests that build tables in memory.
inline Axis linear_axis(const std::string& name, const std::string& unit, double lo, double hi,
                        std::size_t n) {
    Axis a;
    a.name = name;
    a.unit = unit;
    a.min = lo;
    a.max = hi;
    a.count = n;
    a.spacing = Spacing::Linear;
    for (std::size_t k = 0; k < n; ++k)
        a.values.push_back(n == 1 ? lo : lo + (hi - lo) * double(k) / double(n - 1));
    return a;
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

}  // namespace brdftab::test

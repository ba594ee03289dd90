// test_support.h — numerical helpers shared by the model tests.  Written
// independently of the kernels, so tests that use them stay oracles.
#pragma once

#include <cmath>
#include <vector>

namespace brdftab::test {

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

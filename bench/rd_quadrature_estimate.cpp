// rd_quadrature_estimate — how honest and how tight are error estimates of
// the rough-dielectric albedo quadrature (rd_albedo_quadrature,
// docs/models/rough-dielectric.md "Quadrature")?
//
// The kernel header compiled as C++.  Over a broad grid (GGX/separable and
// Beckmann/height-correlated, light from outside and from inside, alpha from
// 0.001 to 1, eta from 1.0001 to 3) it evaluates the rule with several node
// counts and takes the 64-node rule as the truth.  For each candidate
// estimate E of the n-node rule's error it prints, over the cells whose true
// error exceeds 1e-9 (below that the 64-node rule's own error and rounding
// count): how many cells have a true error above E ("below"), the largest
// true error / E ("worst"), and the median E / true error ("median over").
// The candidates are what a second rule in one work item can give: the
// distance to one coarser rule (the engine stores |batch 0 - batch 1|), and
// two convergence models that would need the n-node rule in batch 1 as well.
// Single-threaded, about 5 minutes on the project machine.  Run by hand:
//   cmake --build build --target rd_quadrature_estimate && build/bench/rd_quadrature_estimate
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "kernels/models/rough_dielectric.h"

namespace {

const int kNodes[] = {2, 3, 4, 5, 6, 7, 8, 10, 12, 14, 16, 64};
constexpr int kCount = sizeof(kNodes) / sizeof(kNodes[0]);

struct Cell {
    double mu;
    double q[kCount];  // the rule at kNodes[k]
    double at(int n) const {
        for (int k = 0; k < kCount; ++k)
            if (kNodes[k] == n) return q[k];
        return NAN;
    }
};

void report(const char* name, int n, const std::vector<Cell>& cells,
            const std::function<double(const Cell&)>& estimate, int side) {
    std::vector<double> over;
    int below = 0;
    double worst = 0;
    for (const Cell& c : cells) {
        if (side > 0 && c.mu < 0) continue;
        if (side < 0 && c.mu > 0) continue;
        const double err = std::fabs(c.at(n) - c.at(64));
        if (!(err > 1e-9)) continue;
        const double e = estimate(c);
        if (err > e) ++below;
        worst = std::max(worst, err / std::max(e, 1e-300));
        over.push_back(e / err);
    }
    if (over.empty()) return;
    std::sort(over.begin(), over.end());
    std::printf("n=%2d %-34s %-7s cells %5zu  below %4d (%5.2f %%)  worst %9.3g  median over %9.3g\n", n,
                name, side > 0 ? "outside" : side < 0 ? "inside" : "all", over.size(), below,
                100.0 * below / over.size(), worst, over[over.size() / 2]);
}

}  // namespace

int main() {
    const double mus[] = {0.02, 0.05, 0.1, 0.2, 0.35, 0.5, 0.7, 0.85, 0.95, 1.0,
                          -0.02, -0.1, -0.3, -0.5, -0.7, -0.9, -1.0};
    const double alphas[] = {0.001, 0.003, 0.01, 0.03, 0.1, 0.2, 0.35, 0.5, 0.7, 1.0};
    const double etas[] = {1.0001, 1.02, 1.1, 1.33, 1.5, 2.0, 3.0};
    const int forms[2][2] = {{BT_MF_GGX, BT_SHADOW_SEPARABLE}, {BT_MF_BECKMANN, BT_SHADOW_HEIGHT_CORRELATED}};
    std::vector<Cell> cells;
    for (const auto& f : forms)
        for (double mu : mus)
            for (double alpha : alphas)
                for (double eta : etas) {
                    bt_microfacet mf = bt_microfacet_make(f[0], 0, f[1], alpha, alpha);
                    bt_vec3 i;
                    bt_direction(std::acos(mu), 0, RD_MIN_COS, BT_DIR_SIGNED_COS, &i);
                    double e = eta;
                    if (i.z < 0) {  // the kernel's mirror for light from inside
                        i.z = -i.z;
                        e = 1 / eta;
                    }
                    Cell r{mu, {}}, t{mu, {}};
                    for (int k = 0; k < kCount; ++k) rd_albedo_quadrature(&mf, i, e, kNodes[k], &r.q[k], &t.q[k]);
                    cells.push_back(r);
                    cells.push_back(t);
                }
    std::printf("%zu cells (albedo_r and albedo_t); truth: the 64-node rule\n", cells.size());
    for (int n : {6, 8, 12, 16}) {
        const int half = RD_QUAD_COARSE(n), quarter = RD_QUAD_COARSE(half);
        auto diff = [](int a, int b) {
            return [a, b](const Cell& c) { return std::fabs(c.at(a) - c.at(b)); };
        };
        for (int side : {0, 1, -1}) report("|Q_n - Q_(n/2)| (stored)", n, cells, diff(n, half), side);
        report("|Q_n - Q_(n/2 - 1)|", n, cells, diff(n, half - 1), 0);
        report("|Q_n - Q_(n - 2)|", n, cells, diff(n, n - 2), 0);
        // Geometric convergence across halvings: err(n) ~ d^2 / d', d = |Q_n
        // - Q_(n/2)|, d' = |Q_(n/2) - Q_(n/4)| (where d' > d, else d).
        report("d^2/d' (halvings)", n, cells, [&](const Cell& c) {
            const double d = std::fabs(c.at(n) - c.at(half)), d2 = std::fabs(c.at(half) - c.at(quarter));
            return d2 > d ? d * d / d2 : d;
        }, 0);
        // Algebraic convergence fitted to |Q_n - Q_(n/2)| and |Q_n - Q_(n-2)|:
        // err(n) ~ 2 d 2^-p, p from the two differences (as a rate in n).
        report("2 d 2^-p (p from n-2 and n/2)", n, cells, [&](const Cell& c) {
            const double d = std::fabs(c.at(n) - c.at(half)), d2 = std::fabs(c.at(n) - c.at(n - 2));
            const double p = d2 > 0 ? std::max(0.0, std::log(d / d2) / std::log((n - 2.0) / half)) : 0.0;
            return std::min(d, 2 * d * std::pow(2.0, -p));
        }, 0);
    }
    return 0;
}

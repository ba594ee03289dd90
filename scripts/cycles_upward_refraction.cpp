// cycles_upward_refraction.cpp — the check behind docs/renderer-luts.md
// ("Light from inside below the critical cosine"): the directional albedo of
// GGX glass (height-correlated G) by Monte Carlo over visible normals, once
// as the rough-dielectric model defines it (a refracted ray counts only when
// it leaves below the interface) and once with refractions that leave upward,
// on the light's side, counted too with their shadowing weight G/G1.  The
// second reproduces the ggx_glass_inv_E values Cycles ships.
//
// Build and run from the repository root:
//   c++ -O2 -std=c++17 -I. scripts/cycles_upward_refraction.cpp -o upward
//   ./upward R MU Z      (Cycles' node coordinates: roughness, cosine, IOR variable)
// IOR = (1 + Z^2)/(1 - Z^2); light from inside, i.e. relative index 1/IOR.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "kernels/models/rough_dielectric.h"

namespace {

// GGX Smith Lambda for a direction with cosine cz.
double ggx_lambda(double alpha, double cz) {
    const double c2 = cz * cz, tan2 = (1 - c2) / c2;
    return 0.5 * (-1 + std::sqrt(1 + alpha * alpha * tan2));
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 4) {
        std::fprintf(stderr, "usage: %s R MU Z\n", argv[0]);
        return 2;
    }
    const double r = std::atof(argv[1]), mu = std::atof(argv[2]), z = std::atof(argv[3]);
    const double alpha = r * r, ior = (1 + z * z) / (1 - z * z), eta = 1 / ior;
    const bt_vec3 i = bt_v3(std::sqrt(1 - mu * mu), 0, mu);
    const double lambda_i = ggx_lambda(alpha, mu);
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> uniform(0, 1);
    const int n = 4000000;
    double model = 0, upward_counted = 0;
    for (int k = 0; k < n; ++k) {
        const bt_vec3 m = bt_ggx_sample_visible(i, alpha, alpha, uniform(rng), uniform(rng));
        const double c = bt_v3_dot(i, m);
        if (c <= 0) continue;
        const double f = bt_fresnel_dielectric(c, eta);
        const bt_vec3 o_r = bt_reflect(i, m);
        if (o_r.z > 0) {
            const double w = f * (1 + lambda_i) / (1 + lambda_i + ggx_lambda(alpha, o_r.z));
            model += w;
            upward_counted += w;
        }
        bt_vec3 o_t;
        if (f < 1 && bt_refract(i, m, eta, &o_t)) {
            const double w =
                (1 - f) * (1 + lambda_i) / (1 + lambda_i + ggx_lambda(alpha, std::fabs(o_t.z)));
            if (o_t.z < 0) model += w;
            upward_counted += w;
        }
    }
    std::printf("r %g mu %g z %g (IOR %.6g, light inside): model %.5f, upward refractions counted "
                "%.5f (4e6 samples, stderr <= 2.5e-4)\n",
                r, mu, z, ior, model / n, upward_counted / n);
    return 0;
}

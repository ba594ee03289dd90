/*
 * toy_lambert.h — a test-only model that proves docs/adding-a-model.md: a
 * Lambertian reflector with albedo `albedo`.  Not installed, not embedded in
 * brdftab; tests/CMakeLists.txt builds it into test_toy_model and brdftab_toy.
 *
 * (Reference: J. H. Lambert, Photometria, 1760: radiance independent of the
 * viewing direction, f = albedo / pi.)
 *
 * Quantities:
 *   brdf    f = albedo / pi when both directions are above the surface, else 0
 *   albedo  int f cos(theta_o) dw_o over the upper hemisphere (= albedo), as a
 *           Monte Carlo integral, to exercise the estimator path: with
 *           sampling = uniform, cos(theta_o) = u is uniform on the hemisphere
 *           (pdf 1/(2 pi)) and the weight is f u 2 pi = 2 albedo u; with
 *           sampling = cosine, the pdf is cos/pi and the weight is albedo.
 */
#ifndef BRDFTAB_TOY_LAMBERT_H
#define BRDFTAB_TOY_LAMBERT_H

#include "../common/compat.h"
#include "../common/sampler.h"

#define TL_Q_BRDF 0
#define TL_Q_ALBEDO 1

/* The model contract: slots of the point p[] and of the options o[] and the
 * number of quantities.  tests/toy_model/toy_lambert.cpp registers them. */
#define TL_PARAM_ALBEDO 4
#define TL_PARAM_COUNT 1
#define TL_OPT_SAMPLING 0
#define TL_OPT_COUNT 1
#define TL_Q_COUNT 2

#define TL_SAMPLING_UNIFORM 0
#define TL_SAMPLING_COSINE 1

BT_INLINE REAL toy_lambert_sample(const REAL* p, const int* o, int quantity, const bt_sampler* s)
{
    const REAL albedo = p[TL_PARAM_ALBEDO];
    if (p[0] > BT_HALF_PI) return R(0.0); /* light from below: nothing reflected */
    if (quantity == TL_Q_BRDF) return p[2] > BT_HALF_PI ? R(0.0) : albedo * BT_INV_PI;
    if (quantity == TL_Q_ALBEDO) {
        if (o[TL_OPT_SAMPLING] == TL_SAMPLING_COSINE) return albedo;
        return R(2.0) * albedo * bt_uniform(s, 0u);
    }
    return R(0.0);
}

#endif /* BRDFTAB_TOY_LAMBERT_H */

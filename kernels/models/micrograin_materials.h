/*
 * micrograin_materials.h — what happens where light meets a grain or the
 * base plane in the micrograin model (Lucas et al. 2024, see micrograin.h
 * and docs/models/micrograin.md): the grain Fresnel factor (dielectric or
 * conductor grains, eqs. 21-22) and the base BRDF f^B, with the option values
 * that choose them, and ln(1 - tau0), which sets the grain density (eq. 9).
 * Shared by the analytic model (micrograin.h) and the
 * explicit ray-traced reference (micrograin_explicit.h).
 *
 * The functions read the point in the layout documented in micrograin.h:
 * p[9] eta, p[10] k (grains), p[11] base_albedo, p[12] base_alpha,
 * p[13] base_eta, p[14] base_k.
 */
#ifndef BRDFTAB_MICROGRAIN_MATERIALS_H
#define BRDFTAB_MICROGRAIN_MATERIALS_H

#include "../common/compat.h"
#include "../common/bt_math.h"
#include "../common/fresnel.h"
#include "../common/microfacet.h"
#include "../common/vec3.h"

/* The model contract: slots of the point p[] and of the options o[]
 * (quantity ids: MG_Q_* in micrograin.h).  host/models/micrograin.cpp registers the
 * model by these names; p[0..3] are the directions (estimator.h). */
#define MG_PARAM_TAU0 4
#define MG_PARAM_BETA_X 5
#define MG_PARAM_BETA_Y 6
#define MG_PARAM_H 7
#define MG_PARAM_KD 8
#define MG_PARAM_ETA 9
#define MG_PARAM_K 10
#define MG_PARAM_BASE_ALBEDO 11
#define MG_PARAM_BASE_ALPHA 12
#define MG_PARAM_BASE_ETA 13
#define MG_PARAM_BASE_K 14
#define MG_PARAM_COUNT 11
#define MG_OPT_GRAIN 0
#define MG_OPT_BASE 1
#define MG_OPT_CORRELATION 2
#define MG_OPT_WEIGHTING 3
#define MG_OPT_COUNT 4

#if !BT_DEVICE
using std::log1p;
#endif

/* Option o[0]: grain material. */
#define MG_GRAIN_DIFFUSE 0
#define MG_GRAIN_DIELECTRIC 1
#define MG_GRAIN_CONDUCTOR 2
/* Option o[1]: base plane. */
#define MG_BASE_ABSORBING 0
#define MG_BASE_LAMBERTIAN 1
#define MG_BASE_CONDUCTOR 2
#define MG_BASE_DIELECTRIC 3

BT_INLINE REAL mg_log1m(REAL tau0) { return bt_log1p(-tau0); } /* ln(1 - tau0) */

/* -------------------------------------------------------------- Fresnel */

/* Unpolarised reflectance of a conductor of complex index eta + i k (k >= 0;
 * k = 0 is the dielectric case).  Textbook form with
 * a^2 + b^2 = sqrt((eta^2 - k^2 - s^2)^2 + 4 eta^2 k^2):
 *   Rs = (a2b2 + c^2 - 2 a c) / (a2b2 + c^2 + 2 a c)
 *   Rp = Rs (a2b2 c^2 + s^4 - 2 a c s^2) / (a2b2 c^2 + s^4 + 2 a c s^2). */
BT_INLINE REAL mg_fresnel_conductor(REAL cos_i, REAL eta, REAL k)
{
    REAL c = bt_clamp(fabs(cos_i), R(0.0), R(1.0));
    REAL c2 = c * c, s2 = R(1.0) - c2;
    REAL t0 = eta * eta - k * k - s2;
    REAL a2b2 = sqrt(t0 * t0 + R(4.0) * eta * eta * k * k);
    REAL a = bt_safe_sqrt(R(0.5) * (a2b2 + t0));
    REAL t1 = a2b2 + c2, t2 = R(2.0) * a * c;
    REAL rs = (t1 - t2) / fmax(t1 + t2, R(1e-30));
    REAL t3 = a2b2 * c2 + s2 * s2, t4 = t2 * s2;
    REAL rp = rs * (t3 - t4) / fmax(t3 + t4, R(1e-30));
    return bt_clamp(R(0.5) * (rs + rp), R(0.0), R(1.0));
}

BT_INLINE REAL mg_grain_fresnel(REAL cos_i, const REAL* p, int grain)
{
    if (grain == MG_GRAIN_DIELECTRIC) return bt_fresnel_dielectric(cos_i, p[MG_PARAM_ETA]);
    if (grain == MG_GRAIN_CONDUCTOR) return mg_fresnel_conductor(cos_i, p[MG_PARAM_ETA], p[MG_PARAM_K]);
    return R(0.0);
}

/* Base (bulk) BRDF f^B. */
BT_INLINE REAL mg_f_base(bt_vec3 i, bt_vec3 o, const REAL* p, const int* opt)
{
    if (opt[MG_OPT_BASE] == MG_BASE_LAMBERTIAN) return p[MG_PARAM_BASE_ALBEDO] * BT_INV_PI;
    if (opt[MG_OPT_BASE] == MG_BASE_CONDUCTOR || opt[MG_OPT_BASE] == MG_BASE_DIELECTRIC) {
        /* Microfacet reflection (Walter 2007 eq. 20) of a GGX surface; only
         * the Fresnel term tells a conductor from a dielectric. */
        bt_microfacet mf =
            bt_microfacet_make(BT_MF_GGX, BT_G1_EXACT, BT_SHADOW_HEIGHT_CORRELATED, p[MG_PARAM_BASE_ALPHA], p[MG_PARAM_BASE_ALPHA]);
        bt_vec3 m = bt_v3_normalize(bt_v3_add(i, o));
        REAL cos_im = bt_v3_dot(i, m);
        REAL F = opt[MG_OPT_BASE] == MG_BASE_CONDUCTOR ? mg_fresnel_conductor(cos_im, p[MG_PARAM_BASE_ETA], p[MG_PARAM_BASE_K])
                                             : bt_fresnel_dielectric(cos_im, p[MG_PARAM_BASE_ETA]);
        return F * bt_mf_d(&mf, m) * bt_mf_g(&mf, i, o, m) / (R(4.0) * i.z * o.z);
    }
    return R(0.0);
}

#endif /* BRDFTAB_MICROGRAIN_MATERIALS_H */

/*
 * interfaced_lambertian.h — rough interfaced Lambertian microfacets: every
 * microfacet is a flat dielectric interface (relative index ni = n1/n0) over
 * a Lambertian substrate of reflectance Kd.
 *
 * D. Meneveaux, B. Bringier, E. Tauzia, M. Ribardiere, L. Simonot,
 * "Rendering Rough Opaque Materials with Interfaced Lambertian Microfacets",
 * IEEE Transactions on Visualization and Computer Graphics 24(3), 2018
 * (preprint "Isotropic and Anisotropic Interfaced Lambertian Microfacets",
 * 2015; equation numbers below are the preprint's; the equations as
 * implemented, with every correction: docs/models/interfaced-lambertian.md).
 *
 * Point p[] (kernels/common/estimator.h layout):
 *   p[0] theta_i, p[1] phi_i, p[2] theta_o, p[3] phi_o   radians; theta > pi/2
 *        (below the surface) gives 0: the material is opaque.
 *   p[4]  sigma    Gaussian-of-normals width (radians; gaussian-ts only, eq. 13)
 *   p[5]  alpha    Beckmann/GGX width (isotropic), eqs. 15, 20
 *   p[6]  alpha_x  anisotropic width along +x; 0 = use alpha
 *   p[7]  alpha_y  anisotropic width along +y; 0 = use alpha
 *   p[8]  ni       relative index n1/n0 (>= 1)
 *   p[9]  kd       substrate reflectance (brdf, albedo_body, Rb, vcavity)
 *   p[10] order    vcavity only: 0 = all bounce orders up to IL_MAX_BOUNCES (128),
 *                  k >= 1 = only paths with exactly k facet interactions
 * Options o[]:
 *   o[0] distribution  0 gaussian-ts, 1 beckmann-ts, 2 beckmann-smith,
 *                      3 ggx-smith (Table 2)
 *   o[1] sampling      0 visible normals (Beckmann/GGX), 1 the distribution
 *                      D(m)|m.n| (eqs. 29-31).  Gaussian always samples
 *                      D(m)|m.n| (by rejection, see il_sample_gaussian).
 *   o[2] interreflection  vcavity only: 0 full (each facet hit reflects
 *                      specularly with probability F or enters the body),
 *                      1 body (specular reflections inside the cavity are
 *                      dropped; only body events continue the path)
 * Quantities: see the IL_Q_* list.
 *
 * Departures from the paper (all flagged where they occur):
 *  - eq. 3 as printed divides by 4|i.h||o.h|; eqs. 2 and 5 give
 *    4|i.n||o.n| (Walter 2007 eq. 20), which is what we use.
 *  - eq. 20 (GGX) as printed swaps sigma_x/sigma_y relative to eq. 15; we use
 *    the standard anisotropic GGX with eq. 15's axes (microfacet.h).
 *  - The Gaussian distribution (eq. 13) is isotropic only.
 *  - vcavity: the paper bins exits on a hemispherical sensor (eq. 23); we
 *    connect every body event to the exact direction o with its analytic
 *    visibility in the V-cavity (a point estimator of eq. 22).
 */
#ifndef BRDFTAB_INTERFACED_LAMBERTIAN_H
#define BRDFTAB_INTERFACED_LAMBERTIAN_H

#include "interfaced_lambertian_surface.h"
#include "interfaced_lambertian_vcavity.h"

#define IL_Q_BODY 0
#define IL_Q_BRDF 1
#define IL_Q_SPECULAR 2
#define IL_Q_RE 3
#define IL_Q_RI 4
#define IL_Q_RE_INTEGRAL 5
#define IL_Q_RI_INTEGRAL 6
#define IL_Q_RS 7
#define IL_Q_RB 8
#define IL_Q_ALBEDO_BODY 9
#define IL_Q_ALBEDO_SPECULAR 10
#define IL_Q_VCAVITY 11
#define IL_Q_COUNT 12
/* Parameter and option slots: interfaced_lambertian_surface.h. */

/* Floor on cos(theta) of i and o (bt_direction): grazing directions give the
 * finite grazing limit instead of 0/0.  The GAFs vanish like cos theta and
 * cancel the 1/(|i.n||o.n|) of eqs. 3 and 12, so the floor only has to keep
 * the quotient defined; 1e-9 puts the floored direction within 1e-9 rad of
 * the horizon, and 1/(|i.n||o.n|) <= 1e18 stays finite even in float. */
#define IL_MIN_COS R(1e-9)
/* Random dimensions: 0-1 microfacet normal, 2 start point in the cavity,
 * 3.. V-cavity bounces (4 per bounce, < 520), 700.. V-cavity roulette,
 * 2-3 the outgoing direction of albedo_body; the Gaussian rejection sampler
 * uses IL_DIM_REJECT.. (all dims >= 8 are Philox). */

/* ------------------------------------------------------ body integral (eq. 12) */

/* One sample of
 *   B(i, o) = int T(i,m) T(o,m) D(m) G(i,o,m) |i.m||o.m| / (|i.n||o.n|) dw_m,
 * the integral of eq. 12 without its prefactor.
 *  visible: m ~ D_v from v, the one of i, o with the larger cosine (w is the
 *    other); pdf G1s(v) (v.m) D / v.z, weight T T G / G1s(v) |w.m| / w.z.
 *    Bounded: G <= G1(w) ~ w.z (Smith) or 2 w.z m.z / (w.m) (TS).
 *  distribution: m ~ D|m.n|, weight T T G |i.m||o.m| / (|i.n||o.n| m.z). */
BT_INLINE REAL il_body_sample(il_surface* s, int sampling, bt_vec3 i, bt_vec3 o, REAL ni,
                              const bt_sampler* smp)
{
    bt_vec3 m;
    if (il_uses_visible(s, sampling)) {
        int swap = o.z > i.z;
        bt_vec3 v = swap ? o : i, w = swap ? i : o;
        m = bt_mf_sample_visible(&s->mf, v, bt_uniform(smp, 0u), bt_uniform(smp, 1u));
        if (BT_MF_UNFINISHED(m)) return (REAL)NAN; /* the engine redoes this sample */
        REAL vm = bt_v3_dot(v, m), wm = bt_v3_dot(w, m);
        if (!(vm > R(0.0)) || !(wm > R(0.0)) || !(m.z > R(0.0))) return R(0.0);
        REAL gs = bt_mf_g1_smith_nochi(&s->mf, v);
        if (!(gs > R(0.0))) return R(0.0);
        REAL g = il_g(s, i, o, m);
        return il_t(vm, ni) * il_t(wm, ni) * g / gs * wm / w.z;
    }
    m = il_sample_distribution(s, smp);
    REAL im = bt_v3_dot(i, m), om = bt_v3_dot(o, m);
    if (!(im > R(0.0)) || !(om > R(0.0)) || !(m.z > R(0.0))) return R(0.0);
    REAL g = il_g(s, i, o, m);
    return il_t(im, ni) * il_t(om, ni) * g * im * om / (i.z * o.z * m.z);
}

/* ------------------------------------------------------ specular term (eq. 3) */

/* f_s = F(i,h) D(h) G(i,o,h) / (4 |i.n||o.n|), h = normalize(i + o); eq. 3
 * as printed has 4|i.h||o.h| in the denominator (see header). */
BT_INLINE REAL il_specular(il_surface* s, bt_vec3 i, bt_vec3 o, REAL ni)
{
    bt_vec3 h = bt_v3_normalize(bt_v3_add(i, o));
    REAL F = bt_fresnel_dielectric(bt_v3_dot(i, h), ni); /* eq. 7 */
    REAL D = il_d(s, h);
    if (!(D > R(0.0))) return R(0.0);
    return F * D * il_g(s, i, o, h) / (R(4.0) * i.z * o.z);
}

/* ------------------------------------------------------ directional albedos */

/* Microfacet normal for the albedo estimators (dims 0-1) and the part of the
 * weight that depends on how it was drawn: 1/G1s(i) for visible normals
 * (pdf G1s(i) (i.m) D / |i.n|), (i.m)/(|i.n| m.z) for m ~ D|m.n|. */
BT_INLINE bt_vec3 il_albedo_normal(il_surface* s, int sampling, bt_vec3 i, const bt_sampler* smp,
                                   REAL* base)
{
    bt_vec3 m;
    if (il_uses_visible(s, sampling)) {
        m = bt_mf_sample_visible(&s->mf, i, bt_uniform(smp, 0u), bt_uniform(smp, 1u));
        REAL gs = bt_mf_g1_smith_nochi(&s->mf, i);
        *base = gs > R(0.0) ? R(1.0) / gs : R(0.0);
    } else {
        m = il_sample_distribution(s, smp);
        *base = m.z > R(0.0) ? bt_v3_dot(i, m) / (i.z * m.z) : R(0.0);
    }
    return m;
}

/* Body: E_b(i) = P int int T_i T_o D G (i.m)(o.m)/|i.n| dw_m dw_o, with P the
 * prefactor of eq. 12; m as in il_body_sample (from i), o ~ (o.m)/pi
 * (cosine about m, dims 2-3), weight P pi T_i T_o G / G1s(i) (visible) or
 * P pi T_i T_o G (i.m) / (|i.n| m.z) (distribution). */
BT_INLINE REAL il_albedo_body_sample(il_surface* s, int sampling, bt_vec3 i, REAL ni, REAL kd,
                                     const bt_sampler* smp)
{
    REAL base;
    bt_vec3 m = il_albedo_normal(s, sampling, i, smp, &base);
    REAL im = bt_v3_dot(i, m);
    if (!(im > R(0.0)) || !(m.z > R(0.0)) || !(base > R(0.0))) return R(0.0);
    /* cosine-weighted o about m */
    REAL r = sqrt(bt_uniform(smp, 2u)), ph = BT_TWO_PI * bt_uniform(smp, 3u);
    bt_vec3 t1 = fabs(m.z) < R(0.999) ? bt_v3_normalize(bt_v3_cross(bt_v3(R(0.0), R(0.0), R(1.0)), m))
                                      : bt_v3(R(1.0), R(0.0), R(0.0));
    bt_vec3 t2 = bt_v3_cross(m, t1);
    REAL ct = bt_safe_sqrt(R(1.0) - r * r);
    bt_vec3 o = bt_v3_add(bt_v3_add(bt_v3_scale(t1, r * bt_cos(ph)), bt_v3_scale(t2, r * bt_sin(ph))),
                          bt_v3_scale(m, ct));
    if (!(o.z > R(0.0))) return R(0.0);
    REAL g = il_g(s, i, o, m);
    return il_body_prefactor(kd, ni) * BT_PI * il_t(im, ni) * il_t(ct, ni) * g * base;
}

/* Specular: E_s(i) = int F(i,m) D G(i, o(m), m) (i.m)/|i.n| dw_m with
 * o = reflect(i, m) (dw_o = 4 (o.m) dw_m); weight F G / G1s(i) (visible) or
 * F G (i.m)/(|i.n| m.z) (distribution). */
BT_INLINE REAL il_albedo_specular_sample(il_surface* s, int sampling, bt_vec3 i, REAL ni,
                                         const bt_sampler* smp)
{
    REAL base;
    bt_vec3 m = il_albedo_normal(s, sampling, i, smp, &base);
    REAL im = bt_v3_dot(i, m);
    if (!(im > R(0.0)) || !(m.z > R(0.0)) || !(base > R(0.0))) return R(0.0);
    bt_vec3 o = bt_reflect(i, m);
    if (!(o.z > R(0.0))) return R(0.0);
    return bt_fresnel_dielectric(im, ni) * il_g(s, i, o, m) * base;
}

/* ------------------------------------------------------ sample function */

BT_INLINE REAL interfaced_lambertian_sample(const REAL* p, const int* o, int quantity,
                                            const bt_sampler* smp)
{
    REAL ni = p[IL_PARAM_NI], kd = p[IL_PARAM_KD];
    if (quantity == IL_Q_RE || quantity == IL_Q_RS) return il_re(ni);
    if (quantity == IL_Q_RI) return il_ri(ni);
    if (quantity == IL_Q_RE_INTEGRAL) return il_re_quadrature(ni, smp->batch == 0u ? 32 : 16);
    if (quantity == IL_Q_RI_INTEGRAL) return il_ri_quadrature(ni, smp->batch == 0u ? 32 : 16);
    if (quantity == IL_Q_RB) {
        /* R_b = (1 - r_e)^2 Kd / (ni^2 (1 - Kd r_i)) (§4.1) */
        REAL re = il_re(ni);
        return bt_sqr(R(1.0) - re) * kd / (ni * ni * (R(1.0) - kd * il_ri(ni)));
    }
    il_surface s = il_make_surface(p, o);
    bt_vec3 vi, vo;
    if (!bt_direction(p[0], p[1], IL_MIN_COS, BT_DIR_CLAMP_COS, &vi)) return R(0.0);
    if (quantity == IL_Q_ALBEDO_BODY) return il_albedo_body_sample(&s, o[IL_OPT_SAMPLING], vi, ni, kd, smp);
    if (quantity == IL_Q_ALBEDO_SPECULAR) return il_albedo_specular_sample(&s, o[IL_OPT_SAMPLING], vi, ni, smp);
    if (!bt_direction(p[2], p[3], IL_MIN_COS, BT_DIR_CLAMP_COS, &vo)) return R(0.0);
    if (quantity == IL_Q_BODY) return il_body_sample(&s, o[IL_OPT_SAMPLING], vi, vo, ni, smp);
    if (quantity == IL_Q_SPECULAR) return il_specular(&s, vi, vo, ni);
    if (quantity == IL_Q_BRDF)
        return il_body_prefactor(kd, ni) * il_body_sample(&s, o[IL_OPT_SAMPLING], vi, vo, ni, smp) +
               il_specular(&s, vi, vo, ni); /* eq. 11 */
    if (quantity == IL_Q_VCAVITY)
        return il_vcavity_sample(&s, o[IL_OPT_SAMPLING], o[IL_OPT_INTERREFLECTION], vi, vo, ni, kd, (int)floor(p[IL_PARAM_ORDER] + R(0.5)), smp);
    return R(0.0);
}

/* The staged sample-parallel launch of vcavity (estimator.h,
 * staged_samples.cl; registered in
 * host/models/interfaced_lambertian.cpp): the first stage is the facet
 * (IL_VCAVITY_STAGE values), the rest the walk, with the checks of
 * interfaced_lambertian_sample in its order, so that rest(stage) is its
 * value bit for bit.  Other quantities: the rest is the sample function. */
BT_INLINE void interfaced_lambertian_stage(const REAL* p, const int* o, int quantity,
                                           const bt_sampler* smp, REAL* st)
{
    /* No branch: the facet is drawn for every quantity and for directions
     * below the horizon too (bt_direction gives a unit vector either way),
     * where the rest never reads it.  Early returns (stores under branches,
     * "control flow cannot be substituted for a select") and zeros selected
     * in their place (packed by SLP) both kept PoCL's work-item loop
     * scalar. */
    (void)quantity;
    il_surface s = il_make_surface(p, o);
    bt_vec3 vi, vo;
    bt_direction(p[0], p[1], IL_MIN_COS, BT_DIR_CLAMP_COS, &vi);
    bt_direction(p[2], p[3], IL_MIN_COS, BT_DIR_CLAMP_COS, &vo);
    il_vcavity_facet(&s, o[IL_OPT_SAMPLING], vi, vo, smp, st);
}

BT_INLINE REAL interfaced_lambertian_rest(const REAL* p, const int* o, int quantity,
                                          const bt_sampler* smp, const REAL* st)
{
    if (quantity != IL_Q_VCAVITY) return interfaced_lambertian_sample(p, o, quantity, smp);
    bt_vec3 vi, vo;
    if (!bt_direction(p[0], p[1], IL_MIN_COS, BT_DIR_CLAMP_COS, &vi)) return R(0.0);
    if (!bt_direction(p[2], p[3], IL_MIN_COS, BT_DIR_CLAMP_COS, &vo)) return R(0.0);
    return il_vcavity_walk(o[IL_OPT_INTERREFLECTION], vi, vo, p[IL_PARAM_NI], p[IL_PARAM_KD],
                           (int)floor(p[IL_PARAM_ORDER] + R(0.5)), smp, st);
}

#endif /* BRDFTAB_INTERFACED_LAMBERTIAN_H */

/*
 * rough_dielectric.h — rough dielectric interface (reflection + refraction).
 *
 * B. Walter, S. R. Marschner, H. Li, K. E. Torrance, "Microfacet Models for
 * Refraction through Rough Surfaces", Eurographics Symposium on Rendering
 * (EGSR) 2007, pp. 195-206.  doi:10.2312/EGWR/EGSR07/195-206
 * Equation numbers are the paper's; the equations as implemented are in
 * docs/models/rough-dielectric.md.
 *
 * Point p[] (kernels/common/estimator.h layout):
 *   p[0] theta_i, p[1] phi_i, p[2] theta_o, p[3] phi_o   radians; theta in
 *        [0, pi] from the macro normal +z, theta > pi/2 = below the surface
 *   p[4] alpha  (> 0) roughness width (Beckmann/GGX alpha; Phong exponent
 *        alpha_p = 2/alpha^2 - 2, see microfacet.h)
 *   p[5] eta    (> 0, may be < 1) index inside (below) / index outside (above)
 * Options o[]:
 *   o[0] distribution   0 beckmann, 1 ggx, 2 phong
 *   o[1] g1             0 exact Smith, 1 Walter rational fit (eq. 27)
 *                       (phong always uses the fit: microfacet.h)
 *   o[2] shadowing      0 separable G1 G1, 1 height-correlated
 *   o[3] lobe           albedo_avg only: 0 both, 1 reflection, 2 transmission
 *   o[4] side           albedo_avg only: 0 light from outside, 1 from inside
 *   o[5] sampling       albedos only: 0 visible normals (default), 1 Walter
 *                       (m ~ D|m.n|, eqs. 28/32/35).  Phong has no visible-
 *                       normal sampler and always uses Walter's.
 * Quantities:
 *   0 brdf        f_r (1/sr); 0 when i and o are on opposite sides
 *   1 btdf        f_t (1/sr); 0 when i and o are on the same side
 *   2 bsdf        f_r or f_t according to the sides of i and o
 *   3 albedo_r    directional reflectance  int f_r |o.n| do  for light from i
 *   4 albedo_t    directional transmittance int f_t |o.n| do
 *   5 albedo_avg  2 int_0^1 E(mu) mu dmu for the chosen lobe(s) and side
 * Random dimensions: 0, 1 sample m (visible normals or D(m)|m.n|);
 * 2 picks mu = sqrt(u) (avg).
 *
 * Sides.  The formulas are written for light arriving from outside (i.z > 0,
 * eta_i = 1, eta_o = eta on transmission).  When i is below the surface
 * both directions are mirrored (z -> -z) and the relative index becomes
 * 1/eta: f_t depends only on the ratio of the indices (eq. 21 is homogeneous
 * of degree 0 in (eta_i, eta_o)), and mirroring maps the problem onto the
 * outside one.  The side of a direction is taken from theta (theta > pi/2 is
 * below) rather than from the sign of cos(theta), so theta = pi/2 in float,
 * whose cosine rounds to -4e-8, is still "above".  |cos theta| is floored at
 * RD_MIN_COS so grazing directions give the finite grazing limit instead of
 * 0/0 (G1 ~ cos theta cancels the 1/|i.n| of eqs. 20-21).
 *
 * Degenerate cases (all return finite values):
 *   eta = 1: F = 0 and f_t is a Dirac delta at o = -i, not a function; the
 *     btdf returns 0 for every (i, o) (the transmission half-vector of
 *     eq. 16 does not exist at o = -i and no other o is reachable).  The
 *     albedos are well defined and the estimator returns them.
 *   total internal reflection: 1 - F = 0 at the facet, so f_t = 0 and the
 *     refracted sample carries 0 weight.
 *
 * Known model limitation (measured, not a coding error): Phong uses Walter's
 * Beckmann-fit G1 (eq. 31 with eq. 27), not the Smith G1 of the Phong D, so
 * Smith's identity and hence R + T <= 1 fail for rough Phong near grazing
 * (F = 1 reflection albedo up to 1.06 at alpha 0.5, 1.32 at alpha 1).
 * Beckmann and GGX with exact G1 conserve energy.
 */
#ifndef BRDFTAB_ROUGH_DIELECTRIC_H
#define BRDFTAB_ROUGH_DIELECTRIC_H

#include "../common/compat.h"
#include "../common/fresnel.h"
#include "../common/microfacet.h"
#include "../common/sampler.h"
#include "../common/vec3.h"

#define RD_Q_BRDF 0
#define RD_Q_BTDF 1
#define RD_Q_BSDF 2
#define RD_Q_ALBEDO_R 3
#define RD_Q_ALBEDO_T 4
#define RD_Q_ALBEDO_AVG 5
#define RD_Q_COUNT 6

/* The model contract: slots of the point p[] and of the options o[]
 * (quantity ids: RD_Q_* in rough_dielectric.h).  host/models/rough_dielectric.cpp registers the
 * model by these names; p[0..3] are the directions (estimator.h). */
#define RD_PARAM_ALPHA 4
#define RD_PARAM_ETA 5
#define RD_PARAM_COUNT 2
#define RD_OPT_DISTRIBUTION 0
#define RD_OPT_G1 1
#define RD_OPT_SHADOWING 2
#define RD_OPT_LOBE 3
#define RD_OPT_SIDE 4
#define RD_OPT_SAMPLING 5
#define RD_OPT_COUNT 6

#define RD_LOBE_BOTH 0
#define RD_LOBE_REFLECTION 1
#define RD_LOBE_TRANSMISSION 2

#define RD_SAMPLING_VISIBLE 0
#define RD_SAMPLING_WALTER 1

/* Floor on |cos theta| of i and o (bt_direction, see header comment): the
 * grazing limit is finite (G1 ~ cos theta cancels the 1/|i.n| of eqs. 20-21),
 * so the floor only has to keep the quotient defined; 1e-9 is within 1e-9
 * rad of the horizon. */
#define RD_MIN_COS R(1e-9)

BT_INLINE bt_microfacet rd_microfacet(const REAL* p, const int* o)
{
    return bt_microfacet_make(o[RD_OPT_DISTRIBUTION], o[RD_OPT_G1], o[RD_OPT_SHADOWING], p[RD_PARAM_ALPHA], p[RD_PARAM_ALPHA]);
}

/* ---------------------------------------------------- canonical frame
 * Below: i.z > 0 (light from outside), eta = eta_o / eta_i of the side o is
 * on when o.z < 0, i.e. eta_i = 1, eta_o = eta. */

/* f_r, eq. 20: F(i,h_r) D(h_r) G(i,o,h_r) / (4 |i.n| |o.n|),
 * h_r = normalize(i + o) (eq. 13; sign(i.n) = +1 here). */
BT_INLINE REAL rd_fr_canonical(const bt_microfacet* mf, bt_vec3 i, bt_vec3 o, REAL eta)
{
    if (!(i.z > R(0.0)) || !(o.z > R(0.0))) return R(0.0);
    bt_vec3 h = bt_v3_normalize(bt_v3_add(i, o)); /* |i+o| >= 2 RD_MIN_COS */
    REAL F = bt_fresnel_dielectric(bt_v3_dot(i, h), eta);   /* eq. 22 */
    REAL D = bt_mf_d(mf, h);
    REAL G = bt_mf_g(mf, i, o, h);
    return F * D * G / (R(4.0) * i.z * o.z);
}

/* f_t, eq. 21:
 *   |i.h||o.h| / (|i.n||o.n|) * eta_o^2 (1 - F(i,h)) D(h) G(i,o,h)
 *     / (eta_i (i.h) + eta_o (o.h))^2
 * with h_t = -normalize(eta_i i + eta_o o) (eq. 16), turned to the +z side
 * (the microfacet normal is the one facing the macro normal; Walter's h_t
 * already does so when eta_o > eta_i and the sign flip covers eta_o < eta_i).
 * The facet must face i and turn its back to o (chi+ of both G1, and the
 * refraction geometry); otherwise no facet refracts i into o and f_t = 0.
 * The squared denominator equals |eta_i i + eta_o o|^2 (the eq. 17 Jacobian). */
BT_INLINE REAL rd_ft_canonical(const bt_microfacet* mf, bt_vec3 i, bt_vec3 o, REAL eta)
{
    if (!(i.z > R(0.0)) || !(o.z < R(0.0))) return R(0.0);
    bt_vec3 ht = bt_v3_add(i, bt_v3_scale(o, eta)); /* eta_i = 1, eta_o = eta */
    REAL len2 = bt_v3_dot(ht, ht);
    /* len2 = 0 only for eta = 1 and o = -i: the Dirac case, see header. */
    if (!(len2 > R(1e-24))) return R(0.0);
    bt_vec3 h = bt_v3_scale(ht, -R(1.0) / sqrt(len2)); /* eq. 16 */
    if (h.z < R(0.0)) h = bt_v3_neg(h);
    REAL ih = bt_v3_dot(i, h), oh = bt_v3_dot(o, h);
    if (!(ih > R(0.0)) || !(oh < R(0.0))) return R(0.0);
    REAL denom = ih + eta * oh; /* eta_i (i.h) + eta_o (o.h) */
    REAL d2 = denom * denom;
    if (!(d2 > R(0.0))) return R(0.0);
    REAL F = bt_fresnel_dielectric(ih, eta); /* eq. 22 */
    REAL D = bt_mf_d(mf, h);
    REAL G = bt_mf_g(mf, i, o, h);
    return ih * (-oh) / (i.z * (-o.z)) * eta * eta * (R(1.0) - F) * D * G / d2;
}

/* ---------------------------------------------------- public evaluators
 * i, o: unit directions pointing away from the surface, any side;
 * eta: inside/outside index (p[5]).  The "below" flag of i decides the
 * mirroring; i.z must not be 0 (callers use bt_direction). */
BT_INLINE REAL rough_dielectric_fr_dir(const bt_microfacet* mf, bt_vec3 i, bt_vec3 o, REAL eta)
{
    if (i.z < R(0.0)) {
        i.z = -i.z;
        o.z = -o.z;
        eta = R(1.0) / eta;
    }
    return rd_fr_canonical(mf, i, o, eta);
}

BT_INLINE REAL rough_dielectric_ft_dir(const bt_microfacet* mf, bt_vec3 i, bt_vec3 o, REAL eta)
{
    if (i.z < R(0.0)) {
        i.z = -i.z;
        o.z = -o.z;
        eta = R(1.0) / eta;
    }
    return rd_ft_canonical(mf, i, o, eta);
}

/* Point/option forms (the registry's layout). */
BT_INLINE REAL rough_dielectric_fr(const REAL* p, const int* o)
{
    bt_vec3 vi, vo;
    int above_i = bt_direction(p[0], p[1], RD_MIN_COS, BT_DIR_SIGNED_COS, &vi);
    int above_o = bt_direction(p[2], p[3], RD_MIN_COS, BT_DIR_SIGNED_COS, &vo);
    if (above_i != above_o) return R(0.0);
    bt_microfacet mf = rd_microfacet(p, o);
    return rough_dielectric_fr_dir(&mf, vi, vo, p[RD_PARAM_ETA]);
}

BT_INLINE REAL rough_dielectric_ft(const REAL* p, const int* o)
{
    bt_vec3 vi, vo;
    int above_i = bt_direction(p[0], p[1], RD_MIN_COS, BT_DIR_SIGNED_COS, &vi);
    int above_o = bt_direction(p[2], p[3], RD_MIN_COS, BT_DIR_SIGNED_COS, &vo);
    if (above_i == above_o) return R(0.0);
    bt_microfacet mf = rd_microfacet(p, o);
    return rough_dielectric_ft_dir(&mf, vi, vo, p[RD_PARAM_ETA]);
}

BT_INLINE REAL rough_dielectric_fs(const REAL* p, const int* o)
{
    int bi = p[0] > BT_HALF_PI, bo = p[2] > BT_HALF_PI;
    return bi == bo ? rough_dielectric_fr(p, o) : rough_dielectric_ft(p, o);
}

/* ---------------------------------------------------- albedo estimator
 * One sample of the directional albedo for light from canonical direction i
 * (i.z > 0) and relative index eta.  Returns the reflected part in *wr and
 * the transmitted part in *wt (the same m for both).  unit_fresnel != 0
 * replaces F by 1 (and hence 1 - F by 0): the pure geometric reflection
 * albedo, for tests against closed forms.
 *
 * Both estimators start from the albedo as an integral over m.  Reflection:
 * o = reflect(i, m) (eq. 39), dw_o = 4 |o.m| dw_m (eq. 14), and with f_r of
 * eq. 20
 *   A_r = int f_r |o.n| dw_o = int F(i,m) D(m) G(i,o,m) |i.m| / |i.n| dw_m.
 * Transmission: o = refract(i, m) (eq. 40), dw_o = (i.m + eta o.m)^2 /
 * (eta^2 |o.m|) dw_m (eq. 17 with eta_i = 1), and eq. 21 collapses to the
 * same form with 1 - F:
 *   A_t = int (1 - F(i,m)) D(m) G(i,o,m) |i.m| / |i.n| dw_m.
 *
 * RD_SAMPLING_WALTER: m ~ D(m)|m.n| (eqs. 28/32/35), weight (eq. 41)
 *   w = F |i.m| G(i,o,m) / (|i.n| |m.n|).
 *   Unbounded: |i.m|/|m.n| grows without limit for m near grazing, where
 *   the sampler rarely goes, so the weights are heavy-tailed and error
 *   estimates from few samples run low.
 * RD_SAMPLING_VISIBLE: m ~ D_v(m) = G1s(i,m) (i.m)+ D(m) / (i.n)
 *   (microfacet.h; G1s is the exact Smith G1 that normalises D_v), so
 *   w = F G(i,o,m) / G1s(i,m)
 *     = F (G1(i)/G1s(i)) G(i,o,m)/G1(i,m)      (G1: the model's own G1)
 *   with G/G1(i) = G1(o) (separable) or G1o/(G1i + G1o - G1i G1o)
 *   (height-correlated), both in [0, 1].  With the exact G1 (the default)
 *   G1 = G1s, so every weight, and wr + wt for one m, is at most 1; with
 *   Walter's fit (eq. 27) the ratio G1/G1s stays within its 0.35 % accuracy.
 *   Needs D_v sampling: Beckmann and GGX.  Phong always takes the Walter
 *   path. */
BT_INLINE void rd_albedo_weights(const bt_microfacet* mf, bt_vec3 i, REAL eta, int sampling,
                                 REAL u0, REAL u1, int unit_fresnel, REAL* wr, REAL* wt)
{
    *wr = R(0.0);
    *wt = R(0.0);
    int visible = sampling == RD_SAMPLING_VISIBLE && bt_mf_has_visible(mf);
    bt_vec3 m;
    REAL pdf = R(1.0);
    if (visible)
        m = bt_mf_sample_visible(mf, i, u0, u1);
    else
        m = bt_mf_sample(mf, u0, u1, &pdf);
    REAL im = bt_v3_dot(i, m);
    if (!(im > R(0.0)) || !(m.z > R(0.0)) || !(pdf > R(0.0))) return; /* chi+ of G1(i,m) */
    REAL F = unit_fresnel ? R(1.0) : bt_fresnel_dielectric(im, eta); /* eq. 22 */
    bt_vec3 o_r = bt_reflect(i, m);                                  /* eq. 39 */
    bt_vec3 o_t;
    int has_t = F < R(1.0) && bt_refract(i, m, eta, &o_t) && o_t.z < R(0.0); /* eq. 40 */
    int has_r = o_r.z > R(0.0) && F > R(0.0);
    if (visible) {
        REAL gi = bt_mf_g1_nochi(mf, i);
        REAL gs = bt_mf_g1_smith_nochi(mf, i);
        /* gs > 0 whenever i.z > 0; gi == gs exactly for the exact G1. */
        REAL ratio = gi == gs ? R(1.0) : (gs > R(0.0) ? gi / gs : R(0.0));
        if (has_r) *wr = F * ratio * bt_mf_g_over_g1(mf, gi, o_r, m);
        if (has_t) *wt = (R(1.0) - F) * ratio * bt_mf_g_over_g1(mf, gi, o_t, m);
    } else {
        REAL base = im / (i.z * m.z); /* eq. 41 */
        if (has_r) *wr = F * base * bt_mf_g(mf, i, o_r, m);
        if (has_t) *wt = (R(1.0) - F) * base * bt_mf_g(mf, i, o_t, m);
    }
}

/* Canonicalise light direction by side, then one weight for the chosen lobe. */
BT_INLINE REAL rd_albedo_sample_dir(const bt_microfacet* mf, bt_vec3 i, REAL eta, int lobe,
                                    int sampling, REAL u0, REAL u1)
{
    if (i.z < R(0.0)) {
        i.z = -i.z;
        eta = R(1.0) / eta;
    }
    REAL wr, wt;
    rd_albedo_weights(mf, i, eta, sampling, u0, u1, 0, &wr, &wt);
    if (lobe == RD_LOBE_REFLECTION) return wr;
    if (lobe == RD_LOBE_TRANSMISSION) return wt;
    return wr + wt;
}

/* The model's sample function (estimator.h signature). */
BT_INLINE REAL rough_dielectric_sample(const REAL* p, const int* o, int quantity,
                                       const bt_sampler* s)
{
    if (quantity == RD_Q_BRDF) return rough_dielectric_fr(p, o);
    if (quantity == RD_Q_BTDF) return rough_dielectric_ft(p, o);
    if (quantity == RD_Q_BSDF) return rough_dielectric_fs(p, o);

    bt_microfacet mf = rd_microfacet(p, o);
    REAL u0 = bt_uniform(s, 0u), u1 = bt_uniform(s, 1u);
    if (quantity == RD_Q_ALBEDO_R || quantity == RD_Q_ALBEDO_T) {
        bt_vec3 i;
        bt_direction(p[0], p[1], RD_MIN_COS, BT_DIR_SIGNED_COS, &i);
        return rd_albedo_sample_dir(&mf, i, p[RD_PARAM_ETA],
                                    quantity == RD_Q_ALBEDO_R ? RD_LOBE_REFLECTION
                                                              : RD_LOBE_TRANSMISSION,
                                    o[RD_OPT_SAMPLING], u0, u1);
    }
    if (quantity == RD_Q_ALBEDO_AVG) {
        /* 2 int E(mu) mu dmu = E[E(sqrt(u))] with u uniform (pdf of mu: 2 mu). */
        REAL mu = fmax(sqrt(bt_uniform(s, 2u)), RD_MIN_COS);
        REAL st = bt_safe_sqrt(R(1.0) - mu * mu);
        bt_vec3 i = bt_v3(st, R(0.0), o[RD_OPT_SIDE] == 1 ? -mu : mu);
        return rd_albedo_sample_dir(&mf, i, p[RD_PARAM_ETA], o[RD_OPT_LOBE], o[RD_OPT_SAMPLING], u0, u1);
    }
    return R(0.0);
}

#endif /* BRDFTAB_ROUGH_DIELECTRIC_H */

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
 *   p[6] nodes  albedos under method quadrature: Gauss-Legendre nodes per
 *        sub-interval and direction (rd_albedo_quadrature)
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
 *   o[6] fresnel        0 dielectric (eq. 22, the default), 1 none (F = 1:
 *                       everything is reflected, nothing transmitted; eta is
 *                       not read), 2 schlick (Schlick's approximation with
 *                       F0 = ((eta - 1)/(eta + 1))^2, see rd_fresnel)
 *   o[7] mu_rule        albedo_avg under quadrature: 0 single (one Gauss-
 *                       Legendre rule per side of the critical cosine), 1
 *                       graded (panels geometric towards grazing, normal
 *                       incidence and the kinks of E(mu);
 *                       rd_albedo_avg_quadrature_graded)
 *   o[8] tir_rule       albedos under quadrature: 0 split (the TIR level is a
 *                       graded split of each row), 1 sqrt (also the sqrt map
 *                       on the panels just short of it, the theta~ splits of
 *                       rd_quad_add_crossings and, for albedo_avg with the
 *                       single mu rule, mu splits at 2 mu_c and eta)
 *   o[9] coarse_rule    quadrature: the error estimate's coarse rule, 0 half
 *                       the nodes, 1 three-quarters (rd_quad_nodes)
 * Quantities:
 *   0 brdf        f_r (1/sr); 0 when i and o are on opposite sides
 *   1 btdf        f_t (1/sr); 0 when i and o are on the same side
 *   2 bsdf        f_r or f_t according to the sides of i and o
 *   3 albedo_r    directional reflectance  int f_r |o.n| do  for light from i
 *   4 albedo_t    directional transmittance int f_t |o.n| do
 *   5 albedo_avg  2 int_0^1 E(mu) mu dmu for the chosen lobe(s) and side
 *   6 split_a     int f_r |o.n| (1 - (1 - o.m)^5) do with F = 1: the F0 factor
 *                 of the split-sum environment BRDF (Karis 2013)
 *   7 split_b     int f_r |o.n| (1 - o.m)^5 do with F = 1: its constant term,
 *                 so that under Schlick int f_r cos = F0 split_a + split_b
 *                 (neither reads eta or the fresnel option)
 *   8 albedo      directional albedo of both lobes, albedo_r + albedo_t (the
 *                 glass albedo of energy compensation)
 *   9 sheen_albedo directional albedo of the Charlie sheen lobe with
 *                 Neubelt's visibility at roughness alpha (Filament's cloth
 *                 DFG channel, charlie_sheen.h); reads neither eta nor the
 *                 microfacet options
 * Random dimensions: 0, 1 sample m (visible normals or D(m)|m.n|);
 * 2 picks mu = sqrt(u) (avg).  Method quadrature (the albedos' default):
 * deterministic tensor Gauss-Legendre, batch 0 with p[6] nodes, batch 1 with
 * half as many (the error estimate); see rd_albedo_quadrature.
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
#include "../common/gauss_legendre.h"
#include "../common/microfacet.h"
#include "../common/sampler.h"
#include "../common/vec3.h"

#define RD_Q_BRDF 0
#define RD_Q_BTDF 1
#define RD_Q_BSDF 2
#define RD_Q_ALBEDO_R 3
#define RD_Q_ALBEDO_T 4
#define RD_Q_ALBEDO_AVG 5
#define RD_Q_SPLIT_A 6
#define RD_Q_SPLIT_B 7
#define RD_Q_ALBEDO 8
#define RD_Q_SHEEN_ALBEDO 9
#define RD_Q_COUNT 10

/* The model contract: slots of the point p[] and of the options o[]
 * (quantity ids: RD_Q_* in rough_dielectric.h).  host/models/rough_dielectric.cpp registers the
 * model by these names; p[0..3] are the directions (estimator.h). */
#define RD_PARAM_ALPHA 4
#define RD_PARAM_ETA 5
#define RD_PARAM_NODES 6
#define RD_PARAM_COUNT 3
#define RD_OPT_DISTRIBUTION 0
#define RD_OPT_G1 1
#define RD_OPT_SHADOWING 2
#define RD_OPT_LOBE 3
#define RD_OPT_SIDE 4
#define RD_OPT_SAMPLING 5
#define RD_OPT_FRESNEL 6
#define RD_OPT_MU_RULE 7
#define RD_OPT_TIR_RULE 8
#define RD_OPT_COARSE_RULE 9
#define RD_OPT_COUNT 10

#define RD_MU_RULE_SINGLE 0
#define RD_MU_RULE_GRADED 1

#define RD_TIR_RULE_SPLIT 0
#define RD_TIR_RULE_SQRT 1

#define RD_COARSE_RULE_HALF 0
#define RD_COARSE_RULE_THREE_QUARTERS 1

#define RD_LOBE_BOTH 0
#define RD_LOBE_REFLECTION 1
#define RD_LOBE_TRANSMISSION 2

#define RD_SAMPLING_VISIBLE 0
#define RD_SAMPLING_WALTER 1

/* Facet reflectance modes: the first three are the choices of the fresnel
 * option; the split-sum factors are internal (quantities split_a/split_b),
 * reflection-only weights of F = 1 albedo integrals. */
#define RD_FRESNEL_DIELECTRIC 0
#define RD_FRESNEL_NONE 1
#define RD_FRESNEL_SCHLICK 2
#define RD_FRESNEL_SPLIT_A 3
#define RD_FRESNEL_SPLIT_B 4

/* Floor on |cos theta| of i and o (bt_direction, see header comment): the
 * grazing limit is finite (G1 ~ cos theta cancels the 1/|i.n| of eqs. 20-21),
 * so the floor only has to keep the quotient defined; 1e-9 is within 1e-9
 * rad of the horizon. */
#define RD_MIN_COS R(1e-9)

/* Facet reflectance F for |i.m| = cos_i and canonical relative index eta
 * (the far side's index over the light's side's).
 *   dielectric  eq. 22 (fresnel.h)
 *   none        1
 *   schlick     F0 + (1 - F0)(1 - c)^5, F0 = ((eta - 1)/(eta + 1))^2
 *               (Schlick 1994, eq. 15).  c is the cosine on the denser side:
 *               cos_i when eta >= 1, else the refracted cosine
 *               sqrt(1 - (1 - cos_i^2)/eta^2), and F = 1 under total internal
 *               reflection, so that F is symmetric in the two sides as eq. 22 is.
 *   split_a     1 - (1 - cos_i)^5   (F0 weight of Schlick's F)
 *   split_b     (1 - cos_i)^5       (its constant term) */
BT_INLINE REAL rd_fresnel(int mode, REAL cos_i, REAL eta)
{
    if (mode == RD_FRESNEL_DIELECTRIC) return bt_fresnel_dielectric(cos_i, eta); /* eq. 22 */
    if (mode == RD_FRESNEL_NONE) return R(1.0);
    REAL c = fmin(fabs(cos_i), R(1.0));
    if (mode == RD_FRESNEL_SCHLICK && eta < R(1.0)) {
        REAL s2 = (R(1.0) - c * c) / (eta * eta);
        if (!(s2 < R(1.0))) return R(1.0); /* total internal reflection */
        c = sqrt(R(1.0) - s2);
    }
    REAL k = R(1.0) - c, k2 = k * k;
    REAL k5 = k2 * k2 * k; /* (1 - c)^5 */
    if (mode == RD_FRESNEL_SPLIT_A) return R(1.0) - k5;
    if (mode == RD_FRESNEL_SPLIT_B) return k5;
    REAL f0 = bt_fresnel_normal(eta);
    return f0 + (R(1.0) - f0) * k5; /* Schlick 1994, eq. 15 */
}

/* Modes whose facets transmit 1 - F (the others reflect only). */
BT_INLINE int rd_fresnel_transmits(int mode)
{
    return mode == RD_FRESNEL_DIELECTRIC || mode == RD_FRESNEL_SCHLICK;
}

/* Modes that read eta (the others ignore the index entirely). */
BT_INLINE int rd_fresnel_reads_eta(int mode)
{
    return mode == RD_FRESNEL_DIELECTRIC || mode == RD_FRESNEL_SCHLICK;
}

BT_INLINE bt_microfacet rd_microfacet(const REAL* p, const int* o)
{
    return bt_microfacet_make(o[RD_OPT_DISTRIBUTION], o[RD_OPT_G1], o[RD_OPT_SHADOWING], p[RD_PARAM_ALPHA], p[RD_PARAM_ALPHA]);
}

/* ---------------------------------------------------- canonical frame
 * Below: i.z > 0 (light from outside), eta = eta_o / eta_i of the side o is
 * on when o.z < 0, i.e. eta_i = 1, eta_o = eta. */

/* f_r, eq. 20: F(i,h_r) D(h_r) G(i,o,h_r) / (4 |i.n| |o.n|),
 * h_r = normalize(i + o) (eq. 13; sign(i.n) = +1 here). */
BT_INLINE REAL rd_fr_canonical(const bt_microfacet* mf, bt_vec3 i, bt_vec3 o, REAL eta, int fresnel)
{
    if (!(i.z > R(0.0)) || !(o.z > R(0.0))) return R(0.0);
    bt_vec3 h = bt_v3_normalize(bt_v3_add(i, o)); /* |i+o| >= 2 RD_MIN_COS */
    REAL F = rd_fresnel(fresnel, bt_v3_dot(i, h), eta);   /* eq. 22 */
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
BT_INLINE REAL rd_ft_canonical(const bt_microfacet* mf, bt_vec3 i, bt_vec3 o, REAL eta, int fresnel)
{
    if (!(i.z > R(0.0)) || !(o.z < R(0.0))) return R(0.0);
    if (!rd_fresnel_transmits(fresnel)) return R(0.0);
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
    REAL F = rd_fresnel(fresnel, ih, eta); /* eq. 22 */
    REAL D = bt_mf_d(mf, h);
    REAL G = bt_mf_g(mf, i, o, h);
    return ih * (-oh) / (i.z * (-o.z)) * eta * eta * (R(1.0) - F) * D * G / d2;
}

/* ---------------------------------------------------- public evaluators
 * i, o: unit directions pointing away from the surface, any side;
 * eta: inside/outside index (p[5]).  The "below" flag of i decides the
 * mirroring; i.z must not be 0 (callers use bt_direction). */
BT_INLINE REAL rough_dielectric_fr_dir(const bt_microfacet* mf, bt_vec3 i, bt_vec3 o, REAL eta,
                                       int fresnel)
{
    if (i.z < R(0.0)) {
        i.z = -i.z;
        o.z = -o.z;
        eta = R(1.0) / eta;
    }
    return rd_fr_canonical(mf, i, o, eta, fresnel);
}

BT_INLINE REAL rough_dielectric_ft_dir(const bt_microfacet* mf, bt_vec3 i, bt_vec3 o, REAL eta,
                                       int fresnel)
{
    if (i.z < R(0.0)) {
        i.z = -i.z;
        o.z = -o.z;
        eta = R(1.0) / eta;
    }
    return rd_ft_canonical(mf, i, o, eta, fresnel);
}

/* Point/option forms (the registry's layout). */
BT_INLINE REAL rough_dielectric_fr(const REAL* p, const int* o)
{
    bt_vec3 vi, vo;
    int above_i = bt_direction(p[0], p[1], RD_MIN_COS, BT_DIR_SIGNED_COS, &vi);
    int above_o = bt_direction(p[2], p[3], RD_MIN_COS, BT_DIR_SIGNED_COS, &vo);
    if (above_i != above_o) return R(0.0);
    bt_microfacet mf = rd_microfacet(p, o);
    return rough_dielectric_fr_dir(&mf, vi, vo, p[RD_PARAM_ETA], o[RD_OPT_FRESNEL]);
}

BT_INLINE REAL rough_dielectric_ft(const REAL* p, const int* o)
{
    bt_vec3 vi, vo;
    int above_i = bt_direction(p[0], p[1], RD_MIN_COS, BT_DIR_SIGNED_COS, &vi);
    int above_o = bt_direction(p[2], p[3], RD_MIN_COS, BT_DIR_SIGNED_COS, &vo);
    if (above_i == above_o) return R(0.0);
    bt_microfacet mf = rd_microfacet(p, o);
    return rough_dielectric_ft_dir(&mf, vi, vo, p[RD_PARAM_ETA], o[RD_OPT_FRESNEL]);
}

/* f_r where i and o are on one side, f_t where not: the values of
 * rough_dielectric_fr / _ft, with the directions and the distribution formed
 * once.  On a SIMD device the work items of a group take both branches
 * (masked), so calling those two would form four directions (eight
 * sin/cos) per evaluation instead of two (measured: 11 -> 13.4 M
 * evaluations per CPU-second on PoCL).  Evaluating F, D
 * and G once for both lobes (the facet normal chosen per lane) would save
 * more, but every way of writing it tried let clang's SLP vectoriser pack
 * the sine and cosine of one direction into <2 x double>, and the work-item
 * loop then stayed scalar (twice slower). */
BT_INLINE REAL rough_dielectric_fs(const REAL* p, const int* o)
{
    bt_vec3 vi, vo;
    bt_direction(p[0], p[1], RD_MIN_COS, BT_DIR_SIGNED_COS, &vi);
    bt_direction(p[2], p[3], RD_MIN_COS, BT_DIR_SIGNED_COS, &vo);
    bt_microfacet mf = rd_microfacet(p, o);
    REAL eta = p[RD_PARAM_ETA];
    if (vi.z < R(0.0)) { /* the mirroring of rough_dielectric_fr_dir / _ft_dir */
        vi.z = -vi.z;
        vo.z = -vo.z;
        eta = R(1.0) / eta;
    }
    /* vo.z > 0 now exactly where i and o were on one side (bt_direction's
     * z carries the side's sign), the lobe that rough_dielectric_fr serves. */
    return vo.z > R(0.0) ? rd_fr_canonical(&mf, vi, vo, eta, o[RD_OPT_FRESNEL])
                         : rd_ft_canonical(&mf, vi, vo, eta, o[RD_OPT_FRESNEL]);
}

/* ---------------------------------------------------- albedo estimator
 * One sample of the directional albedo for light from canonical direction i
 * (i.z > 0) and relative index eta.  Returns the reflected part in *wr and
 * the transmitted part in *wt (the same m for both).  `fresnel` is the facet
 * reflectance mode (RD_FRESNEL_*, rd_fresnel): RD_FRESNEL_NONE (1) replaces
 * F by 1 (and hence 1 - F by 0), the pure geometric reflection albedo; the
 * split-sum modes weight the reflection by their factor and transmit
 * nothing.
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
                                 REAL u0, REAL u1, int fresnel, REAL* wr, REAL* wt)
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
    REAL F = rd_fresnel(fresnel, im, eta); /* eq. 22 */
    bt_vec3 o_r = bt_reflect(i, m);                                  /* eq. 39 */
    bt_vec3 o_t = bt_v3(R(0.0), R(0.0), R(0.0)); /* set by bt_refract; zeroed to quiet -Wmaybe-uninitialized */
    int has_t = rd_fresnel_transmits(fresnel) && F < R(1.0) && bt_refract(i, m, eta, &o_t) &&
                o_t.z < R(0.0); /* eq. 40 */
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
                                    int sampling, int fresnel, REAL u0, REAL u1)
{
    if (i.z < R(0.0)) {
        i.z = -i.z;
        eta = R(1.0) / eta;
    }
    REAL wr, wt;
    rd_albedo_weights(mf, i, eta, sampling, u0, u1, fresnel, &wr, &wt);
    if (lobe == RD_LOBE_REFLECTION) return wr;
    if (lobe == RD_LOBE_TRANSMISSION) return wt;
    return wr + wt;
}

/* ---------------------------------------------------- albedo quadrature
 * Deterministic tensor Gauss-Legendre for the directional albedos
 * (method quadrature; docs/models/rough-dielectric.md, "Quadrature").
 *
 * The integral.  With q(m) = (i.m)+ D(m) (canonical i, i.z > 0) both albedos
 * are q-weighted means of the visible-normal weights of rd_albedo_weights:
 *   A = int q w dw_m / int q dw_m,  w_r = F (G1(i)/G1s(i)) G/G1(i)(o_r),
 *   w_t = (1 - F) (G1(i)/G1s(i)) G/G1(i)(o_t),
 * because D_v = q G1s(i) / i.z and int q dw_m = i.z / G1s(i) (Smith).  The
 * rule is self-normalised (numerator and denominator on the same nodes), so
 * a constant w, e.g. F at alpha -> 0, is integrated exactly.
 *
 * Coordinates: the stretched (unit-width) frame of the visible-normal
 * samplers.  m = normalize(alpha m~x, alpha m~y, m~z), and the pushforward
 * of q dw_m is (v~.m~)+ D~(m~) dw~ with v~ = normalize(alpha i.x, 0, i.z)
 * and D~ the unit-width distribution (GGX: 1/pi, the hemisphere; Beckmann:
 * exp(-tan^2)/ (pi cos^4)), whatever alpha is: the integrand does not
 * sharpen as alpha -> 0.  In spherical coordinates (theta~, phi) of m~
 * about the macro normal, dw~ = sin theta~ dtheta~ dphi, and
 *   tan theta_m = alpha tan theta~,  phi_m = phi,
 * so every row theta~ = const is a row of constant m.z.  Heitz's disk map
 * (r = sqrt(u1), then the lift sqrt(1 - r^2)) is not used: it puts square
 * roots at r = 0 and at the silhouette, where Gauss-Legendre converges
 * slowly.  The integrand is even in phi (i in the xz plane, isotropic D), so
 * phi runs over [0, pi].
 *
 * Splits.  On a row, c = i.m = sin th_m sin th_i cos phi + cos th_m cos th_i
 * falls monotonically in phi, and every place where the weight is not
 * smooth is a level c = c* of it, so phi* = acos((c* - cos th_m cos th_i)
 * / (sin th_m sin th_i)) is explicit (rd_quad_row):
 *   c* = 0                   facet turns its back to i (v~.m~ = 0): end of
 *                            the row's visible range, the weight q has a kink;
 *   c* = sqrt(1 - eta^2)     total internal reflection (eta < 1): F -> 1
 *                            like sqrt(c - c*); both sub-intervals are
 *                            graded towards phi* (bt_graded_map, power 2);
 *   c* = i.z / (2 m.z)       reflected direction on the horizon
 *                            (o_r.z = 2 c m.z - i.z): G1(o_r) -> 0 linearly;
 *   c* = (K^2 - 1 + eW^2) / (2 eW K), K = eW i.z / m.z, eW = 1/eta > 1
 *                            refracted direction on the horizon (o_t.z =
 *                            k(c) m.z - eW i.z, k(c) = eW c - sqrt(1 - eW^2
 *                            (1 - c^2)), solved for c; only for eta < 1, as
 *                            o_t.z < 0 always when eta > 1);
 *   c* = (i.z + h)/(2 m.z), h = alpha, 4 alpha   the G1(o_r) ramp (G1 ~ 2 o_r.z
 *                            / alpha while o_r.z << alpha), no grading;
 *   c* = c0 + w, c0 + 4w, w = sqrt|eta^2 - 1|    the Fresnel layer for eta
 *                            near 1 (c0 = 0 or the TIR level), no grading.
 * Between splits the weight is smooth.  Across rows, the row integral is
 * not smooth where a split is born or dies at phi = 0 or pi, i.e. at the
 * in-plane normals of each boundary (rd_quad_add_inplane): theta~ is split
 * there and graded with power 2 (a split moving like sqrt(theta~ - theta~c))
 * or 4 (the TIR edge, whose sqrt(c - c*) gives a 3/4 power); the ramp and
 * layer levels' in-plane points too (power 2: harmless where smooth), and
 * every interval next to a graded point is split again at 1/8 and 1/64 of
 * its length from it (rd_quad_refine).  Beckmann's
 * theta~ ends at atan(7) (the slope cut of its sampler; mass beyond it
 * < 1e-21) and is split at tan theta~ = 1 and 2.5.
 * Left to the error estimate: Walter's G1 fit (its a = 1.6 switch is a kink
 * not split), the 3/4-power tangency terms beyond the grading, rounding.
 *
 * Phong (no unit-width form) runs the same rows in real theta_m with q =
 * (i.m)+ D(m) and the absolute normalisation A = G1(i) int q G/G1(i) F / i.z
 * (the Walter-weight integral); theta_m is split at 1, 2, 4 and 8 times
 * alpha (the width of D). */

#define RD_QUAD_MAX_NODES 64
#define RD_QUAD_MAX_SPLITS 64
#define RD_QUAD_LAYERS 2
/* The coarse rule of the error estimate (batch 1). */
#define RD_QUAD_COARSE(n) (((n) + 1) / 2)

typedef struct {
    bt_microfacet mf;
    bt_vec3 i;        /* canonical light, i.z > 0 */
    REAL eta;         /* canonical relative index */
    int fresnel;      /* facet reflectance mode (rd_fresnel) */
    REAL ratio, gi;   /* G1(i)/G1s(i), G1(i) of the model's G1 */
    REAL vx, vz;      /* stretched view (v~.y = 0) */
    int stretched;    /* 1: Beckmann/GGX rows in theta~, 0: Phong in theta_m */
    REAL c_tir;       /* critical c (eta < 1), else -1 */
    REAL layer[RD_QUAD_LAYERS]; /* c levels of the Fresnel layer, or -1 */
    REAL rise[RD_QUAD_LAYERS];  /* o_r.z levels of the G1(o_r) ramp, or -1 */
    int tir_rule;     /* RD_TIR_RULE_*: map of the panels near the TIR split */
} rd_quad_ctx;

/* Weights of one normal m (the visible-normal weights of rd_albedo_weights,
 * without the sampling). */
BT_INLINE void rd_quad_weights(const rd_quad_ctx* q, bt_vec3 m, REAL* wr, REAL* wt)
{
    *wr = R(0.0);
    *wt = R(0.0);
    REAL im = bt_v3_dot(q->i, m);
    if (!(im > R(0.0)) || !(m.z > R(0.0))) return;
    REAL F = rd_fresnel(q->fresnel, im, q->eta); /* eq. 22 */
    bt_vec3 o_r = bt_reflect(q->i, m);          /* eq. 39 */
    bt_vec3 o_t;
    int has_t = rd_fresnel_transmits(q->fresnel) && F < R(1.0) &&
                bt_refract(q->i, m, q->eta, &o_t) && o_t.z < R(0.0); /* eq. 40 */
    int has_r = o_r.z > R(0.0) && F > R(0.0);
    if (has_r) *wr = F * q->ratio * bt_mf_g_over_g1(&q->mf, q->gi, o_r, m);
    if (has_t) *wt = (R(1.0) - F) * q->ratio * bt_mf_g_over_g1(&q->mf, q->gi, o_t, m);
}

/* Insert x (with grading power g) into the sorted list e[0..*ne-1]. */
BT_INLINE void rd_quad_insert(REAL* e, int* g, int* ne, REAL x, int grade)
{
    if (*ne >= RD_QUAD_MAX_SPLITS) return;
    int j = *ne - 1;
    while (j >= 0 && e[j] > x) {
        e[j + 1] = e[j];
        g[j + 1] = g[j];
        --j;
    }
    e[j + 1] = x;
    g[j + 1] = grade;
    ++*ne;
}

/* The c* levels of a row with cos theta_m = mz (see above); returns their
 * count, *tir_index the position of the TIR level (or -1). */
BT_INLINE int rd_quad_levels(const rd_quad_ctx* q, REAL mz, REAL* lv, int* tir_index)
{
    int n = 0;
    *tir_index = -1;
    lv[n++] = R(0.0);
    if (q->c_tir > R(0.0)) {
        *tir_index = n;
        lv[n++] = q->c_tir;
        REAL ew = R(1.0) / q->eta;
        REAL K = ew * q->i.z / mz;
        REAL c = (K * K - R(1.0) + ew * ew) / (R(2.0) * ew * K);
        if (ew * c >= K) lv[n++] = c;
    }
    lv[n++] = q->i.z / (R(2.0) * mz);
    for (int k = 0; k < RD_QUAD_LAYERS; ++k) {
        if (q->layer[k] > R(0.0)) lv[n++] = q->layer[k];
        /* o_r.z = rise: the G1(o_r) ramp */
        if (q->rise[k] > R(0.0)) lv[n++] = (q->i.z + q->rise[k]) / (R(2.0) * mz);
    }
    return n;
}

/* Row integrals at cos/sin theta_m = (mz, ms): sum over phi in [0, pi] of
 * (weights) * (row density factor in phi, i.e. v~.m~ up to the row's
 * constant, supplied by the caller as vm(phi) = a cos phi + b).  Adds
 * int vm (wr, wt, 1) dphi to *sr, *st, *sn. */
BT_INLINE void rd_quad_row(const rd_quad_ctx* q, REAL mz, REAL ms, REAL va, REAL vb, int n,
                           const REAL* gx, const REAL* gw, REAL* sr, REAL* st, REAL* sn)
{
    REAL lv[4 + 2 * RD_QUAD_LAYERS];
    int tir;
    int nl = rd_quad_levels(q, mz, lv, &tir);
    REAL e[RD_QUAD_MAX_SPLITS + 2];
    int g[RD_QUAD_MAX_SPLITS + 2];
    int ne = 0;
    REAL ss = ms * q->i.x, cc = mz * q->i.z;
    REAL phi_end = BT_PI; /* end of the visible range */
    if (ss > R(0.0)) {
        for (int k = 0; k < nl; ++k) {
            REAL x = (lv[k] - cc) / ss;
            if (k == 0 && !(x < R(1.0))) return; /* the whole row faces away from i */
            if (!(x > -R(1.0) && x < R(1.0))) continue;
            REAL phi = bt_acos(x);
            if (k == 0)
                phi_end = phi;
            else
                rd_quad_insert(e, g, &ne, phi, k == tir ? 2 : 1);
        }
    } else if (!(cc > R(0.0))) {
        return; /* the whole row faces away from i */
    }
    /* sub-intervals [0, e0, e1, ..., phi_end] */
    /* phi of the TIR split (the one split graded 2 on a row), or -1 */
    REAL phi_tir = -R(1.0);
    for (int k = 0; k < ne; ++k)
        if (g[k] == 2) phi_tir = e[k];
    REAL lo = R(0.0);
    int glo = 1;
    REAL a_r = R(0.0), a_t = R(0.0), a_n = R(0.0);
    for (int k = 0; k <= ne; ++k) {
        REAL hi = k < ne ? e[k] : phi_end;
        int ghi = k < ne ? g[k] : 1;
        if (hi > phi_end) {
            hi = phi_end;
            ghi = 1;
        }
        REAL L = hi - lo;
        /* tir_rule = sqrt: a panel on the transmitting side (c > c_tir, phi
         * < phi_tir) that stops short of phi_tir, closer to it than its own
         * length, carries F's sqrt(c - c_tir) ~ sqrt(phi_tir - phi) from
         * just outside (the refracted-horizon level sits a hair before the
         * TIR level: o_t grazes the facet at the TIR edge, so o_t.z = 0 is
         * reached within ~(c - c_tir) ~ 1e-5).  There u = sqrt(phi_tir -
         * phi) is the variable: linear in the node, phi = phi_tir - u^2,
         * dphi = 2 u (u_lo - u_hi) dt, so the sqrt becomes a polynomial. */
        int sqrt_map = q->tir_rule == RD_TIR_RULE_SQRT && phi_tir > R(0.0) && hi < phi_tir &&
                       phi_tir - hi < L;
        REAL u_lo = sqrt_map ? sqrt(phi_tir - lo) : R(0.0);
        REAL u_hi = sqrt_map ? sqrt(phi_tir - hi) : R(0.0);
        if (L > R(0.0)) {
            for (int j = 0; j < n; ++j) {
                REAL jac;
                REAL t = bt_graded_map(R(0.5) * (gx[j] + R(1.0)), glo, ghi, &jac);
                REAL phi = lo + L * t;
                if (sqrt_map) {
                    REAL tl = R(0.5) * (gx[j] + R(1.0));
                    REAL u = u_lo + (u_hi - u_lo) * tl;
                    phi = phi_tir - u * u;
                    jac = R(2.0) * u * (u_lo - u_hi) / L; /* times L below */
                }
                REAL cp = bt_cos(phi), sp = bt_sin(phi);
                REAL wq = R(0.5) * gw[j] * jac * L * fmax(va * cp + vb, R(0.0));
                bt_vec3 m = bt_v3(ms * cp, ms * sp, mz);
                REAL wr, wt;
                rd_quad_weights(q, m, &wr, &wt);
                a_r += wq * wr;
                a_t += wq * wt;
                a_n += wq;
            }
        }
        if (hi >= phi_end) break;
        lo = hi;
        glo = ghi;
    }
    *sr += a_r;
    *st += a_t;
    *sn += a_n;
}

/* theta_m of the in-plane normals (phi = 0 or pi) on a boundary: signed
 * in-plane angles psi (from +z towards i) are added as |psi| when
 * |psi| < pi/2, converted to the row variable (theta~ when stretched). */
BT_INLINE void rd_quad_add_psi(const rd_quad_ctx* q, REAL psi, int grade, REAL top, REAL* e,
                               int* g, int* ne)
{
    REAL th = fabs(psi);
    if (!(th < BT_HALF_PI)) return;
    if (q->stretched) th = bt_atan(bt_tan(th) / q->mf.ax);
    if (th > R(0.0) && th < top) rd_quad_insert(e, g, ne, th, grade);
}

BT_INLINE void rd_quad_add_inplane(const rd_quad_ctx* q, REAL top, REAL* e, int* g, int* ne)
{
    REAL ti = bt_acos(fmin(q->i.z, R(1.0)));
    /* visibility c = 0 and TIR c = c_tir: cos(theta_i - psi) = c */
    rd_quad_add_psi(q, ti - BT_HALF_PI, 2, top, e, g, ne);
    if (q->c_tir > R(0.0)) {
        REAL a = bt_acos(q->c_tir);
        rd_quad_add_psi(q, ti - a, 4, top, e, g, ne);
        rd_quad_add_psi(q, ti + a, 4, top, e, g, ne);
        /* o_t horizontal: m ~ i + eta o with o = (+-1, 0, 0) */
        rd_quad_add_psi(q, bt_atan((q->i.x + q->eta) / q->i.z), 2, top, e, g, ne);
        rd_quad_add_psi(q, bt_atan((q->i.x - q->eta) / q->i.z), 2, top, e, g, ne);
    }
    for (int k = 0; k < RD_QUAD_LAYERS; ++k) {
        if (!(q->layer[k] > R(0.0))) continue;
        REAL a = bt_acos(q->layer[k]);
        rd_quad_add_psi(q, ti - a, 2, top, e, g, ne);
        rd_quad_add_psi(q, ti + a, 2, top, e, g, ne);
    }
    /* o_r horizontal: psi = (theta_i +- pi/2)/2; o_r at height `rise`:
     * m along i + o_r, o_r = (+-sqrt(1 - rise^2), 0, rise) */
    rd_quad_add_psi(q, R(0.5) * (ti + BT_HALF_PI), 2, top, e, g, ne);
    rd_quad_add_psi(q, R(0.5) * (ti - BT_HALF_PI), 2, top, e, g, ne);
    for (int k = 0; k < RD_QUAD_LAYERS; ++k) {
        REAL h = q->rise[k];
        if (!(h > R(0.0))) continue;
        REAL ox = bt_safe_sqrt(R(1.0) - h * h);
        rd_quad_add_psi(q, bt_atan2(q->i.x + ox, q->i.z + h), 2, top, e, g, ne);
        rd_quad_add_psi(q, bt_atan2(q->i.x - ox, q->i.z + h), 2, top, e, g, ne);
    }
}

/* tir_rule = sqrt: the rows on which a horizon level meets the TIR level.
 * On a row the reflected weight is F G1(o_r)-like with F = 1 - O(sqrt(c -
 * c_tir)) and a kink at the o_r horizon c_r = i.z / (2 m.z); the
 * transmitted one is (1 - F) G1(o_t)-like with a kink at the o_t horizon.
 * Where the kink and the TIR level coincide, the row integral has a
 * (theta~ - theta~*)^(3/2) term: not at an in-plane normal, so the splits
 * above miss it.  The o_r horizon meets c_tir at m.z = i.z / (2 c_tir); the
 * o_t horizon (o_t.z = k(c) m.z - eW i.z, k(c_tir) = eW c_tir, eW = 1/eta)
 * at m.z = i.z / c_tir.  Split there, graded with power 2. */
BT_INLINE void rd_quad_add_crossings(const rd_quad_ctx* q, REAL top, REAL* e, int* g, int* ne)
{
    if (!(q->c_tir > R(0.0))) return;
    REAL mz_r = q->i.z / (R(2.0) * q->c_tir), mz_t = q->i.z / q->c_tir;
    if (mz_r < R(1.0)) rd_quad_add_psi(q, bt_acos(mz_r), 2, top, e, g, ne);
    if (mz_t < R(1.0)) rd_quad_add_psi(q, bt_acos(mz_t), 2, top, e, g, ne);
}

/* Geometric refinement towards the graded (singular) outer points: the
 * row integral has features on scales set by alpha near them (the G1(o_r)
 * ramp, the Fresnel layer), compressed near theta~ = pi/2, so each interval
 * next to a graded point p gets extra splits at RD_QUAD_REFINE^-k of its
 * length from p (k = 1 .. RD_QUAD_REFINE_LEVELS). */
#define RD_QUAD_REFINE R(8.0)
#define RD_QUAD_REFINE_LEVELS 2
BT_INLINE int rd_quad_refine(REAL* e, int* g, int ne, REAL lo_end, REAL hi_end)
{
    REAL add[2 * RD_QUAD_MAX_SPLITS * RD_QUAD_REFINE_LEVELS];
    int na = 0;
    for (int k = 0; k < ne; ++k) {
        if (g[k] < 2) continue;
        REAL left = k > 0 ? e[k - 1] : lo_end, right = k + 1 < ne ? e[k + 1] : hi_end;
        REAL dl = e[k] - left, dr = right - e[k];
        for (int j = 0; j < RD_QUAD_REFINE_LEVELS; ++j) {
            dl /= RD_QUAD_REFINE;
            dr /= RD_QUAD_REFINE;
            if (dl > R(0.0)) add[na++] = e[k] - dl;
            if (dr > R(0.0)) add[na++] = e[k] + dr;
        }
    }
    for (int k = 0; k < na; ++k) rd_quad_insert(e, g, &ne, add[k], 1);
    return ne;
}

/* Both albedos for canonical light i (i.z > 0) and index eta, n nodes per
 * sub-interval in each direction, with facet reflectance mode `fresnel`
 * (rd_fresnel; a mode that does not read eta splits at no TIR or Fresnel
 * level, as it has none). */
BT_INLINE void rd_albedo_quadrature_rule(const bt_microfacet* mf, bt_vec3 i, REAL eta, int fresnel,
                                         int n, int tir_rule, REAL* ar, REAL* at)
{
    REAL gx[RD_QUAD_MAX_NODES], gw[RD_QUAD_MAX_NODES];
    /* n = 1 (one midpoint per sub-interval) only as the coarse rule of
     * nodes = 2: clamped to 2, the two rules were one and the estimate 0. */
    n = n < 1 ? 1 : (n > RD_QUAD_MAX_NODES ? RD_QUAD_MAX_NODES : n);
    bt_gauss_legendre_rule(n, gx, gw);
    rd_quad_ctx q;
    q.mf = *mf;
    q.i = i;
    q.eta = eta;
    q.fresnel = fresnel;
    q.tir_rule = tir_rule;
    q.stretched = bt_mf_has_visible(mf);
    q.gi = bt_mf_g1_nochi(mf, i);
    REAL gs = bt_mf_g1_smith_nochi(mf, i);
    q.ratio = !q.stretched ? R(1.0) : (q.gi == gs ? R(1.0) : (gs > R(0.0) ? q.gi / gs : R(0.0)));
    const int reads_eta = rd_fresnel_reads_eta(fresnel);
    q.c_tir = reads_eta && eta < R(1.0) ? sqrt((R(1.0) - eta) * (R(1.0) + eta)) : -R(1.0);
    {
        /* eta near 1: F climbs from ~0 to 1 within c ~ w = sqrt(|eta^2 - 1|)
         * of c = 0 (eta > 1) or of the TIR edge (eta < 1); levels at w and 4w
         * past it resolve that layer (splits, no grading: F is smooth there). */
        REAL w = sqrt(fabs((eta - R(1.0)) * (eta + R(1.0))));
        REAL base = q.c_tir > R(0.0) ? q.c_tir : R(0.0);
        REAL scale = R(1.0);
        for (int k = 0; k < RD_QUAD_LAYERS; ++k, scale *= R(4.0)) {
            REAL c = base + scale * w;
            q.layer[k] = reads_eta && w > R(0.0) && w < R(0.25) && c < R(1.0) ? c : -R(1.0);
        }
        /* G1(o_r) ~ 2 o_r.z / alpha while o_r.z << alpha: a ramp of width
         * ~alpha next to the o_r horizon (thin for smooth surfaces, and it
         * carries the whole reflection lobe at grazing incidence): levels at
         * o_r.z = alpha and 4 alpha. */
        scale = R(1.0);
        for (int k = 0; k < RD_QUAD_LAYERS; ++k, scale *= R(4.0)) {
            REAL h = scale * mf->ax;
            q.rise[k] = h < R(0.5) ? h : -R(1.0);
        }
    }
    REAL alpha = mf->ax;
    bt_vec3 v = q.stretched ? bt_mf_stretch_view(i, alpha, alpha) : i;
    q.vx = v.x;
    q.vz = v.z;

    REAL top = BT_HALF_PI;
    REAL e[RD_QUAD_MAX_SPLITS + 2];
    int g[RD_QUAD_MAX_SPLITS + 2];
    int ne = 0;
    int beck = mf->dist == BT_MF_BECKMANN;
    if (beck) {
        top = bt_atan(BT_MF_SLOPE_MAX);
        rd_quad_insert(e, g, &ne, bt_atan(R(1.0)), 1);
        rd_quad_insert(e, g, &ne, bt_atan(R(2.5)), 1);
    }
    if (!q.stretched) {
        for (REAL k = R(1.0); k <= R(8.0); k *= R(2.0))
            if (k * alpha < top) rd_quad_insert(e, g, &ne, k * alpha, 1);
    }
    rd_quad_add_inplane(&q, top, e, g, &ne);
    if (tir_rule == RD_TIR_RULE_SQRT) rd_quad_add_crossings(&q, top, e, g, &ne);
    ne = rd_quad_refine(e, g, ne, R(0.0), top);

    REAL alpha_p = bt_phong_exponent(alpha);
    REAL sr = R(0.0), st = R(0.0), sn = R(0.0);
    REAL lo = R(0.0);
    int glo = 1;
    for (int k = 0; k <= ne; ++k) {
        REAL hi = k < ne ? e[k] : top;
        int ghi = k < ne ? g[k] : 1;
        REAL L = hi - lo;
        if (L > R(0.0)) {
            for (int j = 0; j < n; ++j) {
                REAL jac;
                REAL t = bt_graded_map(R(0.5) * (gx[j] + R(1.0)), glo, ghi, &jac);
                REAL th = lo + L * t;
                REAL sin_th = bt_sin(th), ct = bt_cos(th);
                REAL w = R(0.5) * gw[j] * jac * L * sin_th;
                REAL mz, ms;
                if (q.stretched) {
                    /* m = normalize(alpha sin th~, ., cos th~) */
                    REAL r = alpha * sin_th, len = sqrt(r * r + ct * ct);
                    mz = ct / len;
                    ms = r / len;
                    /* D~(m~), constant factors dropped (self-normalised) */
                    if (beck) {
                        REAL t2 = sin_th * sin_th / (ct * ct);
                        w *= bt_exp(-t2) / (ct * ct * ct * ct);
                    }
                } else {
                    mz = ct;
                    ms = sin_th;
                    w *= bt_phong_d(mz, alpha_p);
                }
                /* v.m = v.x ms cos phi + v.z mz on the row */
                REAL va = q.stretched ? q.vx * sin_th : q.vx * ms;
                REAL vb = q.stretched ? q.vz * ct : q.vz * mz;
                REAL r_r = R(0.0), r_t = R(0.0), r_n = R(0.0);
                rd_quad_row(&q, mz, ms, va, vb, n, gx, gw, &r_r, &r_t, &r_n);
                sr += w * r_r;
                st += w * r_t;
                sn += w * r_n;
            }
        }
        lo = hi;
        glo = ghi;
    }
    if (q.stretched) {
        *ar = sn > R(0.0) ? sr / sn : R(0.0);
        *at = sn > R(0.0) ? st / sn : R(0.0);
    } else {
        /* Walter-weight integral: G1(i) * 2 int_0^pi (rows) / i.z; the model's
         * G/G1(i) already sits in the weights. */
        REAL f = R(2.0) * q.gi / i.z;
        *ar = f * sr;
        *at = f * st;
    }
}

/* rd_albedo_quadrature_rule with the split rule near the TIR level. */
BT_INLINE void rd_albedo_quadrature_mode(const bt_microfacet* mf, bt_vec3 i, REAL eta, int fresnel,
                                         int n, REAL* ar, REAL* at)
{
    rd_albedo_quadrature_rule(mf, i, eta, fresnel, n, RD_TIR_RULE_SPLIT, ar, at);
}

/* rd_albedo_quadrature_mode with the dielectric Fresnel factor (eq. 22). */
BT_INLINE void rd_albedo_quadrature(const bt_microfacet* mf, bt_vec3 i, REAL eta, int n, REAL* ar,
                                    REAL* at)
{
    rd_albedo_quadrature_mode(mf, i, eta, RD_FRESNEL_DIELECTRIC, n, ar, at);
}

/* Node count of the quadrature for this batch: batch 0 the accurate rule
 * (p[RD_PARAM_NODES]), batch 1 the coarse one, whose distance to it the
 * engine reports as the error: half as many nodes (RD_QUAD_COARSE), or with
 * coarse_rule = three-quarters ceil(3n/4) (RD_QUAD_COARSE_34), whose error
 * is closer to the accurate rule's, so that the estimate overstates it less. */
#define RD_QUAD_COARSE_34(n) ((3 * (n) + 3) / 4)
BT_INLINE int rd_quad_nodes(const REAL* p, const int* o, const bt_sampler* s)
{
    int n = (int)(p[RD_PARAM_NODES] + R(0.5));
    n = n < 2 ? 2 : (n > RD_QUAD_MAX_NODES ? RD_QUAD_MAX_NODES : n);
    if (s->batch != 0u)
        n = o[RD_OPT_COARSE_RULE] == RD_COARSE_RULE_THREE_QUARTERS ? RD_QUAD_COARSE_34(n)
                                                                    : RD_QUAD_COARSE(n);
    return n;
}

/* Directional albedo (lobe) for light direction i (either side) by quadrature. */
BT_INLINE REAL rd_albedo_quadrature_dir(const bt_microfacet* mf, bt_vec3 i, REAL eta, int lobe,
                                        int fresnel, int n, int tir_rule)
{
    if (i.z < R(0.0)) {
        i.z = -i.z;
        eta = R(1.0) / eta;
    }
    REAL ar, at;
    rd_albedo_quadrature_rule(mf, i, eta, fresnel, n, tir_rule, &ar, &at);
    if (lobe == RD_LOBE_REFLECTION) return ar;
    if (lobe == RD_LOBE_TRANSMISSION) return at;
    return ar + at;
}

/* albedo_avg by quadrature: 2 int_0^1 E(mu) mu dmu, Gauss-Legendre in mu
 * split at the critical cosine (the smooth-surface TIR edge, where E has a
 * kink that roughness only softens) and graded there (power 2). */
BT_INLINE REAL rd_albedo_avg_quadrature(const bt_microfacet* mf, REAL eta, int side, int lobe,
                                        int fresnel, int n, int tir_rule)
{
    REAL gx[RD_QUAD_MAX_NODES], gw[RD_QUAD_MAX_NODES];
    int nn = n < 1 ? 1 : (n > RD_QUAD_MAX_NODES ? RD_QUAD_MAX_NODES : n); /* 1: see rd_albedo_quadrature */
    bt_gauss_legendre_rule(nn, gx, gw);
    REAL ec = side == 1 ? R(1.0) / eta : eta; /* canonical index */
    REAL e[5];
    int ne = 0;
    e[ne++] = R(0.0);
    if (rd_fresnel_reads_eta(fresnel) && ec < R(1.0)) {
        REAL mu_c = sqrt((R(1.0) - ec) * (R(1.0) + ec));
        e[ne++] = mu_c;
        /* tir_rule = sqrt: E(mu) is also not smooth where the TIR level
         * meets the o_r horizon at the normal m = n (i.z = 2 mu_c, see
         * rd_quad_add_crossings) and where the TIR circle i.m = mu_c
         * reaches the facet horizon m.z = 0 (theta_i + acos(mu_c) = pi/2,
         * i.z = sqrt(1 - mu_c^2) = eta): split and grade there too. */
        if (tir_rule == RD_TIR_RULE_SQRT) {
            REAL extra[2] = {R(2.0) * mu_c, ec};
            for (int k = 0; k < 2; ++k) {
                REAL x = extra[k];
                if (!(x < R(1.0)) || x == mu_c) continue;
                int j = ne - 1; /* insert into e[1 .. ne-1], ascending */
                while (j >= 1 && e[j] > x) {
                    e[j + 1] = e[j];
                    --j;
                }
                e[j + 1] = x;
                ++ne;
            }
        }
    }
    e[ne] = R(1.0);
    REAL sum = R(0.0);
    for (int k = 0; k < ne; ++k) {
        REAL lo = e[k], L = e[k + 1] - lo;
        int glo = k > 0 ? 2 : 1, ghi = k + 1 < ne ? 2 : 1;
        for (int j = 0; j < nn; ++j) {
            REAL jac;
            REAL t = bt_graded_map(R(0.5) * (gx[j] + R(1.0)), glo, ghi, &jac);
            REAL mu = fmax(lo + L * t, RD_MIN_COS);
            bt_vec3 i = bt_v3(bt_safe_sqrt(R(1.0) - mu * mu), R(0.0), mu);
            REAL ar, at;
            rd_albedo_quadrature_rule(mf, i, ec, fresnel, nn, tir_rule, &ar, &at);
            REAL a = lobe == RD_LOBE_REFLECTION ? ar : lobe == RD_LOBE_TRANSMISSION ? at : ar + at;
            sum += R(0.5) * gw[j] * jac * L * R(2.0) * mu * a;
        }
    }
    return sum;
}

/* albedo_avg by quadrature on graded panels (mu_rule = graded).  E(mu)
 * changes on the scale of alpha near grazing (masking of i and of the
 * reflected directions), behaves like a + b sqrt(1 - mu) at normal incidence
 * (smooth in theta_i, not in mu), and has kinks that roughness only softens,
 * over ~alpha: the critical cosine mu_c (light from the denser side) and,
 * with tir_rule = sqrt, 2 mu_c and 1/eta as in the single rule
 * (rd_albedo_avg_quadrature).  One rule per smooth piece resolves those
 * slowly (measured: 4.5e-5 between 16 and 8 nodes for GGX, F = 1).  Panel
 * ends, merged into one ascending list:
 *   grazing   4^-k (k = 1 .. RD_AVG_GRAZING_LEVELS);
 *   kinks     K -+ d 4^-k (k = 1 .. RD_AVG_CRITICAL_LEVELS at mu_c,
 *             RD_AVG_KINK_LEVELS at the others), d the distance to the
 *             midpoint to the neighbouring kink (or to 0 and 1); the panels
 *             touching K are graded towards it (power 2);
 *   normal    1 - d/4, d the length of the last panel, the panel touching 1
 *             graded towards it (power 2).
 * (n + 1)/2 Gauss-Legendre nodes in mu per panel, each an albedo quadrature
 * with n nodes. */
#define RD_AVG_GRAZING_LEVELS 6
#define RD_AVG_CRITICAL_LEVELS 3
#define RD_AVG_KINK_LEVELS 1
#define RD_AVG_MAX_KINKS 3
#define RD_AVG_MAX_EDGES (4 + RD_AVG_GRAZING_LEVELS + RD_AVG_MAX_KINKS * (2 * RD_AVG_CRITICAL_LEVELS + 2))

/* The kinks of E(mu) in (0, 1), ascending and distinct (see above). */
BT_INLINE int rd_avg_kinks(REAL ec, int fresnel, int tir_rule, REAL* kink)
{
    int nk = 0;
    if (!(rd_fresnel_reads_eta(fresnel) && ec < R(1.0))) return 0;
    REAL mu_c = sqrt((R(1.0) - ec) * (R(1.0) + ec));
    REAL cand[RD_AVG_MAX_KINKS] = {mu_c, R(2.0) * mu_c, ec};
    int nc = tir_rule == RD_TIR_RULE_SQRT ? 3 : 1;
    for (int c = 0; c < nc; ++c) {
        REAL x = cand[c];
        if (!(x > R(0.0) && x < R(1.0))) continue;
        int dup = 0;
        for (int k = 0; k < nk; ++k) dup |= kink[k] == x;
        if (dup) continue;
        int j = nk - 1;
        while (j >= 0 && kink[j] > x) {
            kink[j + 1] = kink[j];
            --j;
        }
        kink[j + 1] = x;
        ++nk;
    }
    return nk;
}

/* Adds panel end x in (0, 1) with grading g to the ascending list e[0..*ne-1]
 * (an end already there keeps the larger grading). */
BT_INLINE void rd_avg_add_edge(REAL* e, int* g, int* ne, REAL x, int grade)
{
    if (!(x > R(0.0) && x < R(1.0)) || *ne >= RD_AVG_MAX_EDGES) return;
    int j = *ne - 1;
    while (j >= 0 && e[j] > x) --j;
    if (j >= 0 && e[j] == x) {
        if (grade > g[j]) g[j] = grade;
        return;
    }
    for (int k = *ne; k > j + 1; --k) {
        e[k] = e[k - 1];
        g[k] = g[k - 1];
    }
    e[j + 1] = x;
    g[j + 1] = grade;
    ++*ne;
}

BT_INLINE REAL rd_albedo_avg_quadrature_graded(const bt_microfacet* mf, REAL eta, int side,
                                               int lobe, int fresnel, int n, int tir_rule)
{
    REAL gx[RD_QUAD_MAX_NODES], gw[RD_QUAD_MAX_NODES];
    int nn = n < 1 ? 1 : (n > RD_QUAD_MAX_NODES ? RD_QUAD_MAX_NODES : n);
    int nm = (nn + 1) / 2;
    bt_gauss_legendre_rule(nm, gx, gw);
    REAL ec = side == 1 ? R(1.0) / eta : eta; /* canonical index */
    REAL kink[RD_AVG_MAX_KINKS];
    int nk = rd_avg_kinks(ec, fresnel, tir_rule, kink);
    REAL mu_c = nk > 0 ? sqrt((R(1.0) - ec) * (R(1.0) + ec)) : -R(1.0); /* critical cosine */
    /* Interior panel ends, ascending; g = 2 where the panels are graded. */
    REAL e[RD_AVG_MAX_EDGES + 2];
    int g[RD_AVG_MAX_EDGES + 2];
    int ne = 0;
    REAL t = R(1.0);
    for (int k = 1; k <= RD_AVG_GRAZING_LEVELS; ++k) {
        t *= R(0.25);
        rd_avg_add_edge(e, g, &ne, t, 1);
    }
    for (int j = 0; j < nk; ++j) {
        REAL K = kink[j];
        REAL before = j > 0 ? R(0.5) * (kink[j - 1] + K) : R(0.0);
        REAL after = j + 1 < nk ? R(0.5) * (K + kink[j + 1]) : R(1.0);
        int levels = K == mu_c ? RD_AVG_CRITICAL_LEVELS : RD_AVG_KINK_LEVELS;
        rd_avg_add_edge(e, g, &ne, K, 2);
        if (j + 1 < nk) rd_avg_add_edge(e, g, &ne, after, 1);
        t = R(1.0);
        for (int k = 1; k <= levels; ++k) {
            t *= R(0.25);
            rd_avg_add_edge(e, g, &ne, K - (K - before) * t, 1);
            rd_avg_add_edge(e, g, &ne, K + (after - K) * t, 1);
        }
    }
    REAL last = ne > 0 ? e[ne - 1] : R(0.0);
    rd_avg_add_edge(e, g, &ne, R(1.0) - R(0.25) * (R(1.0) - last), 1);
    /* the ends 0 and 1 */
    for (int k = ne; k > 0; --k) {
        e[k] = e[k - 1];
        g[k] = g[k - 1];
    }
    e[0] = R(0.0);
    g[0] = 1;
    ++ne;
    e[ne] = R(1.0);
    g[ne++] = 2;
    REAL sum = R(0.0);
    for (int k = 0; k + 1 < ne; ++k) {
        REAL lo = e[k], L = e[k + 1] - lo;
        if (!(L > R(0.0))) continue;
        int glo = g[k], ghi = g[k + 1];
        for (int j = 0; j < nm; ++j) {
            REAL jac;
            REAL tm = bt_graded_map(R(0.5) * (gx[j] + R(1.0)), glo, ghi, &jac);
            REAL mu = fmax(lo + L * tm, RD_MIN_COS);
            bt_vec3 i = bt_v3(bt_safe_sqrt(R(1.0) - mu * mu), R(0.0), mu);
            REAL ar, at;
            rd_albedo_quadrature_rule(mf, i, ec, fresnel, nn, tir_rule, &ar, &at);
            REAL a = lobe == RD_LOBE_REFLECTION ? ar : lobe == RD_LOBE_TRANSMISSION ? at : ar + at;
            sum += R(0.5) * gw[j] * jac * L * R(2.0) * mu * a;
        }
    }
    return sum;
}

#include "charlie_sheen.h"

/* The model's sample function (estimator.h signature). */
BT_INLINE REAL rough_dielectric_sample(const REAL* p, const int* o, int quantity,
                                       const bt_sampler* s)
{
    if (quantity == RD_Q_BRDF) return rough_dielectric_fr(p, o);
    if (quantity == RD_Q_BTDF) return rough_dielectric_ft(p, o);
    if (quantity == RD_Q_BSDF) return rough_dielectric_fs(p, o);

    if (quantity == RD_Q_SHEEN_ALBEDO) {
        REAL cv = bt_cos(p[0]);
        if (s->method == BT_METHOD_QUADRATURE)
            return cs_sheen_albedo_quadrature(cv, p[RD_PARAM_ALPHA], rd_quad_nodes(p, o, s));
        return cs_sheen_albedo_sample(cv, p[RD_PARAM_ALPHA], bt_uniform(s, 0u), bt_uniform(s, 1u));
    }

    bt_microfacet mf = rd_microfacet(p, o);
    /* The split-sum factors are F = 1 reflection albedos weighted by their
     * factor of Schlick's F (rd_fresnel); they read neither eta nor the
     * fresnel option. */
    const int split = quantity == RD_Q_SPLIT_A || quantity == RD_Q_SPLIT_B;
    const int fresnel = quantity == RD_Q_SPLIT_A   ? RD_FRESNEL_SPLIT_A
                        : quantity == RD_Q_SPLIT_B ? RD_FRESNEL_SPLIT_B
                                                   : o[RD_OPT_FRESNEL];
    const int lobe = quantity == RD_Q_ALBEDO_T ? RD_LOBE_TRANSMISSION
                     : quantity == RD_Q_ALBEDO ? RD_LOBE_BOTH
                                               : RD_LOBE_REFLECTION;
    const int directional = quantity == RD_Q_ALBEDO_R || quantity == RD_Q_ALBEDO_T ||
                            quantity == RD_Q_ALBEDO || split;
    if (s->method == BT_METHOD_QUADRATURE) {
        int n = rd_quad_nodes(p, o, s);
        if (directional) {
            bt_vec3 i;
            bt_direction(p[0], p[1], RD_MIN_COS, BT_DIR_SIGNED_COS, &i);
            return rd_albedo_quadrature_dir(&mf, i, p[RD_PARAM_ETA], lobe, fresnel, n,
                                            o[RD_OPT_TIR_RULE]);
        }
        if (quantity == RD_Q_ALBEDO_AVG)
            return o[RD_OPT_MU_RULE] == RD_MU_RULE_GRADED
                       ? rd_albedo_avg_quadrature_graded(&mf, p[RD_PARAM_ETA], o[RD_OPT_SIDE],
                                                         o[RD_OPT_LOBE], fresnel, n,
                                                         o[RD_OPT_TIR_RULE])
                       : rd_albedo_avg_quadrature(&mf, p[RD_PARAM_ETA], o[RD_OPT_SIDE],
                                                  o[RD_OPT_LOBE], fresnel, n, o[RD_OPT_TIR_RULE]);
        return R(0.0);
    }
    REAL u0 = bt_uniform(s, 0u), u1 = bt_uniform(s, 1u);
    if (directional) {
        bt_vec3 i;
        bt_direction(p[0], p[1], RD_MIN_COS, BT_DIR_SIGNED_COS, &i);
        return rd_albedo_sample_dir(&mf, i, p[RD_PARAM_ETA], lobe, o[RD_OPT_SAMPLING], fresnel, u0,
                                    u1);
    }
    if (quantity == RD_Q_ALBEDO_AVG) {
        /* 2 int E(mu) mu dmu = E[E(sqrt(u))] with u uniform (pdf of mu: 2 mu). */
        REAL mu = fmax(sqrt(bt_uniform(s, 2u)), RD_MIN_COS);
        REAL st = bt_safe_sqrt(R(1.0) - mu * mu);
        bt_vec3 i = bt_v3(st, R(0.0), o[RD_OPT_SIDE] == 1 ? -mu : mu);
        return rd_albedo_sample_dir(&mf, i, p[RD_PARAM_ETA], o[RD_OPT_LOBE], o[RD_OPT_SAMPLING],
                                    fresnel, u0, u1);
    }
    return R(0.0);
}

#endif /* BRDFTAB_ROUGH_DIELECTRIC_H */

/*
 * microfacet.h — normal distributions D, Smith shadowing-masking G1/G and
 * importance sampling of microfacet normals, shared by every microfacet model.
 *
 * References:
 *   B. Walter, S. R. Marschner, H. Li, K. E. Torrance, "Microfacet Models for
 *   Refraction through Rough Surfaces", EGSR 2007 (equation numbers below).
 *   Anisotropic forms: the standard axis-aligned stretch of the isotropic
 *   slope distributions (alpha_x along +x, alpha_y along +y).
 *
 * Frame: macro normal n = +z; m is a unit microfacet normal, v a unit
 * direction pointing away from the surface (either side).
 *
 * Roughness: every distribution takes the Beckmann-style width alpha.
 *   Phong (eq. 30) has an exponent alpha_p instead; we use Walter's
 *   conversion alpha_p = 2 / alpha^2 - 2 (the Phong lobe that matches a
 *   Beckmann lobe of width alpha near the normal; Walter 2007 §5.2), so the
 *   same `alpha` axis means comparable roughness for all three.  alpha_p lies
 *   in (-2, inf) for every alpha > 0 and D stays normalised; alpha > sqrt(2)
 *   gives alpha_p < 0 (a D that grows toward grazing), still a valid density.
 *   Phong is isotropic only (alpha_y is ignored).
 *
 * Smith G1:
 *   Beckmann exact (eq. 26, erf form), Beckmann rational fit (eq. 27),
 *   GGX exact (eq. 34).  Phong: the exact Smith G1 has no closed form (the
 *   Lambda integral of the Phong slope distribution is not elementary), so —
 *   as Walter does (eq. 31) — Phong always uses the rational fit of eq. 27
 *   with a = sqrt(0.5 alpha_p + 1) / tan(theta_v); the g1 option is ignored
 *   for Phong.  With our alpha_p conversion this a equals 1/(alpha tan theta_v).
 *   Schlick's approximation (Beckmann and GGX, g1 = BT_G1_SCHLICK), as
 *   Karis 2013 uses it for image lighting: G1 = cos / (cos (1 - k) + k) with
 *   k = alpha / 2 (alpha_x; not a Smith G1 of either D, so Smith's identity
 *   and energy conservation hold only approximately).
 *   All G1 include Walter's chi+((v.m)/(v.n)): 0 when v sees the back of m.
 *
 * G(i,o,m):
 *   separable          G1(i,m) G1(o,m)                      (eq. 23)
 *   height-correlated  1 / (1 + Lambda(i) + Lambda(o))  (Heitz 2014 form;
 *                      not in Walter 2007), with Lambda = 1/G1 - 1, written
 *                      as G1i G1o / (G1i + G1o - G1i G1o) to stay finite
 *                      when a G1 is 0; the chi+ factors are kept.
 *
 * Sampling (eqs. 28-29 Beckmann, 32 Phong, 35 GGX): m with pdf D(m)|m.n|
 * w.r.t. solid angle.  The anisotropic Beckmann/GGX cases sample the standard
 * slope distribution and stretch the slopes by (alpha_x, alpha_y); for
 * alpha_x = alpha_y this is exactly Walter's theta_m formula.
 *
 * Visible-normal sampling (end of file): m with pdf
 *   D_v(m) = G1(v,m) max(0, v.m) D(m) / (v.n)
 * (Heitz & d'Eon 2014 eq. 2 / Heitz 2018 eq. 1), the exact Smith G1 as the
 * normaliser.  GGX: Heitz 2018 (JCGT 7(4)), stretched hemisphere and
 * projected disk.  Beckmann: Heitz & d'Eon 2014 (EGSR), inversion of the
 * visible-slope CDF.  Phong: none (no closed-form Smith G1, see above).
 * Both use the same slope-stretch convention as bt_mf_sample, derived below.
 *
 * No pow() anywhere (PoCL's pow is ~10x slower): Phong's cos^alpha_p is
 * exp(alpha_p log c).
 */
#ifndef BRDFTAB_MICROFACET_H
#define BRDFTAB_MICROFACET_H

#include "compat.h"
#include "bt_math.h"
#include "vec3.h"

#define BT_MF_BECKMANN 0
#define BT_MF_GGX 1
#define BT_MF_PHONG 2

#define BT_G1_EXACT 0
#define BT_G1_WALTER_FIT 1
#define BT_G1_SCHLICK 2

#define BT_SHADOW_SEPARABLE 0
#define BT_SHADOW_HEIGHT_CORRELATED 1

/* Smallest width accepted; smaller inputs are clamped so nothing divides by 0. */
#define BT_MF_MIN_ALPHA R(1e-7)

typedef struct {
    int dist;      /* BT_MF_* */
    int g1;        /* BT_G1_* */
    int shadowing; /* BT_SHADOW_* */
    REAL ax, ay;   /* widths along x and y (isotropic: equal) */
} bt_microfacet;

BT_INLINE bt_microfacet bt_microfacet_make(int dist, int g1, int shadowing, REAL ax, REAL ay)
{
    bt_microfacet mf;
    mf.dist = dist;
    mf.g1 = g1;
    mf.shadowing = shadowing;
    mf.ax = fmax(ax, BT_MF_MIN_ALPHA);
    mf.ay = fmax(ay, BT_MF_MIN_ALPHA);
    return mf;
}

/* ---------------------------------------------------------------- D(m) */

/* Walter's Phong exponent for a Beckmann width alpha (§5.2). */
BT_INLINE REAL bt_phong_exponent(REAL alpha) { return R(2.0) / (alpha * alpha) - R(2.0); }

/* Beckmann, eq. 25, anisotropic:
 *   D = exp(-(mx^2/ax^2 + my^2/ay^2)/mz^2) / (pi ax ay mz^4),  mz > 0. */
BT_INLINE REAL bt_beckmann_d(bt_vec3 m, REAL ax, REAL ay)
{
    if (!(m.z > R(0.0))) return R(0.0);
    REAL z2 = m.z * m.z;
    REAL e = (m.x * m.x / (ax * ax) + m.y * m.y / (ay * ay)) / z2;
    /* exp(-80) < 2e-35: D is 0 to every precision we keep, and skipping it
     * avoids 0/0 when mz^4 underflows in float. */
    if (e > R(80.0)) return R(0.0);
    return bt_exp(-e) / (BT_PI * ax * ay * z2 * z2);
}

/* GGX, eq. 33, anisotropic; the algebraically equal form
 *   D = 1 / (pi ax ay (mx^2/ax^2 + my^2/ay^2 + mz^2)^2)
 * has no tan/cos^4 and no 0/0 near grazing. */
BT_INLINE REAL bt_ggx_d(bt_vec3 m, REAL ax, REAL ay)
{
    if (!(m.z > R(0.0))) return R(0.0);
    REAL s = m.x * m.x / (ax * ax) + m.y * m.y / (ay * ay) + m.z * m.z;
    return R(1.0) / (BT_PI * ax * ay * s * s);
}

/* Phong, eq. 30: D = (alpha_p + 2)/(2 pi) cos^alpha_p(theta_m), mz > 0.
 * The exponent argument is capped at 80 so alpha_p < 0 (D -> inf at grazing,
 * an integrable singularity) cannot overflow float. */
BT_INLINE REAL bt_phong_d(REAL mz, REAL alpha_p)
{
    if (!(mz > R(0.0))) return R(0.0);
    REAL t = fmin(alpha_p * bt_log(fmin(mz, R(1.0))), R(80.0));
    return (alpha_p + R(2.0)) * (R(0.5) * BT_INV_PI) * bt_exp(t);
}

BT_INLINE REAL bt_mf_d(const bt_microfacet* mf, bt_vec3 m)
{
    if (mf->dist == BT_MF_GGX) return bt_ggx_d(m, mf->ax, mf->ay);
    if (mf->dist == BT_MF_PHONG) return bt_phong_d(m.z, bt_phong_exponent(mf->ax));
    return bt_beckmann_d(m, mf->ax, mf->ay);
}

/* --------------------------------------------------------------- G1(v,m) */

/* Projected width along v's azimuth times tan(theta_v):
 *   alpha_v tan(theta_v) = sqrt(ax^2 vx^2 + ay^2 vy^2) / |vz|.
 * Everything below is written with |vz| and r = sqrt(ax^2 vx^2 + ay^2 vy^2)
 * so theta_v = 90 deg gives r/|vz| = inf handled as a limit, never as inf. */
BT_INLINE REAL bt_mf_proj_width(bt_vec3 v, REAL ax, REAL ay)
{
    return sqrt(ax * ax * v.x * v.x + ay * ay * v.y * v.y);
}

/* Walter's chi+((v.m)/(v.n)): v must see the front of m from its own side. */
BT_INLINE int bt_mf_visible(bt_vec3 v, bt_vec3 m) { return bt_v3_dot(v, m) * v.z > R(0.0); }

/* Beckmann exact Smith, eq. 26 with a = 1/(alpha tan theta_v):
 *   G1 = 2 / (1 + erf(a) + exp(-a^2)/(a sqrt(pi)))
 * multiplied through by a sqrt(pi):
 *   G1 = 2 a sqrt(pi) / (a sqrt(pi) (1 + erf a) + exp(-a^2)),
 * finite for a = 0 (grazing -> 0) and a -> inf (-> 1).  1 + erf a is
 * computed as 2 - erfc a (a >= 0, so it lies in [1, 2] and nothing
 * cancels): bt_erfc is one polynomial, where bt_erf evaluates a 36-term
 * series and a 30-level continued fraction (30 dependent divisions) and
 * selects one.  Measured: the serial host's Beckmann+Smith body runs about
 * 1.3x faster than with the erf form, the device about the same. */
BT_INLINE REAL bt_beckmann_g1_exact_a(REAL a)
{
    REAL as = a * BT_SQRT_PI;
    return R(2.0) * as / (as * (R(2.0) - bt_erfc(a)) + bt_exp(-a * a));
}

/* Walter's rational fit to eq. 26 (eq. 27). */
BT_INLINE REAL bt_beckmann_g1_fit_a(REAL a)
{
    if (a >= R(1.6)) return R(1.0);
    return (R(3.535) * a + R(2.181) * a * a) / (R(1.0) + R(2.276) * a + R(2.577) * a * a);
}

/* a = |vz| / (alpha_v sin theta_v), capped so a huge a (v near the normal or
 * alpha tiny) is not inf; G1 is 1 to double precision long before 1e30. */
BT_INLINE REAL bt_mf_a(bt_vec3 v, REAL ax, REAL ay)
{
    REAL r = bt_mf_proj_width(v, ax, ay);
    REAL z = fabs(v.z);
    return z < r * R(1e30) ? z / r : R(1e30);
}

/* GGX exact Smith, eq. 34: G1 = 2 / (1 + sqrt(1 + alpha_v^2 tan^2 theta_v)),
 * multiplied through by |vz|: 2|vz| / (|vz| + sqrt(vz^2 + ax^2 vx^2 + ay^2 vy^2)). */
BT_INLINE REAL bt_ggx_g1_nochi(bt_vec3 v, REAL ax, REAL ay)
{
    REAL z = fabs(v.z);
    REAL s = sqrt(z * z + ax * ax * v.x * v.x + ay * ay * v.y * v.y);
    return s > R(0.0) ? R(2.0) * z / (z + s) : R(0.0);
}

/* G1 without the chi+ factor (the distribution's visibility of a direction). */
BT_INLINE REAL bt_mf_g1_nochi(const bt_microfacet* mf, bt_vec3 v)
{
    if (mf->g1 == BT_G1_SCHLICK && mf->dist != BT_MF_PHONG) {
        /* Schlick 1994 / Karis 2013: k = alpha/2 (image-lighting choice) */
        REAL z = fabs(v.z), k = R(0.5) * mf->ax;
        REAL den = z * (R(1.0) - k) + k;
        return den > R(0.0) ? z / den : R(0.0);
    }
    if (mf->dist == BT_MF_GGX) return bt_ggx_g1_nochi(v, mf->ax, mf->ay);
    if (mf->dist == BT_MF_PHONG) {
        /* eq. 31: a = sqrt(0.5 alpha_p + 1)/tan(theta_v) with eq. 27. */
        REAL ap = bt_phong_exponent(mf->ax);
        REAL st = sqrt(fmax(v.x * v.x + v.y * v.y, R(0.0)));
        REAL z = fabs(v.z);
        REAL k = sqrt(fmax(R(0.5) * ap + R(1.0), R(0.0)));
        REAL a = z * k < st * R(1e30) ? z * k / st : R(1e30);
        return bt_beckmann_g1_fit_a(a);
    }
    REAL a = bt_mf_a(v, mf->ax, mf->ay);
    if (mf->g1 == BT_G1_WALTER_FIT) return bt_beckmann_g1_fit_a(a);
    return bt_beckmann_g1_exact_a(a);
}

BT_INLINE REAL bt_mf_g1(const bt_microfacet* mf, bt_vec3 v, bt_vec3 m)
{
    if (!bt_mf_visible(v, m)) return R(0.0);
    return bt_mf_g1_nochi(mf, v);
}

/* Smith Lambda = 1/G1 - 1 (for callers that want it; may be large). */
BT_INLINE REAL bt_mf_lambda(const bt_microfacet* mf, bt_vec3 v)
{
    REAL g = bt_mf_g1_nochi(mf, v);
    return g > R(0.0) ? R(1.0) / g - R(1.0) : R(1e30);
}

/* Combine two G1 values into G (separable or height-correlated). */
BT_INLINE REAL bt_mf_combine(int shadowing, REAL gi, REAL go)
{
    if (shadowing == BT_SHADOW_HEIGHT_CORRELATED) {
        REAL den = gi + go - gi * go; /* >= max(gi, go) for gi, go in [0,1] */
        return den > R(0.0) ? gi * go / den : R(0.0);
    }
    return gi * go; /* eq. 23 */
}

BT_INLINE REAL bt_mf_g(const bt_microfacet* mf, bt_vec3 i, bt_vec3 o, bt_vec3 m)
{
    if (!bt_mf_visible(i, m) || !bt_mf_visible(o, m)) return R(0.0);
    return bt_mf_combine(mf->shadowing, bt_mf_g1_nochi(mf, i), bt_mf_g1_nochi(mf, o));
}

/* ------------------------------------------------------------- sampling */

/* m with pdf D(m) mz; u0, u1 in [0, 1).  *pdf receives D(m) mz (solid angle).
 * Beckmann eqs. 28-29: tan^2 theta_m = -alpha^2 log(1 - u0), phi = 2 pi u1.
 * GGX eq. 35: tan theta_m = alpha sqrt(u0 / (1 - u0)).
 * Phong eq. 32: cos theta_m = (1 - u0)^(1/(alpha_p + 2)) (1 - u0 in (0, 1]
 *   instead of Walter's u0: same distribution, and log never sees 0). */
BT_INLINE bt_vec3 bt_mf_sample(const bt_microfacet* mf, REAL u0, REAL u1, REAL* pdf)
{
    REAL phi = BT_TWO_PI * u1;
    REAL cp = bt_cos(phi), sp = bt_sin(phi);
    bt_vec3 m;
    if (mf->dist == BT_MF_PHONG) {
        REAL ap = bt_phong_exponent(mf->ax);
        REAL ct = bt_exp(bt_log(R(1.0) - u0) / (ap + R(2.0)));
        REAL st = bt_safe_sqrt(R(1.0) - ct * ct);
        m = bt_v3(st * cp, st * sp, ct);
    } else {
        /* Radius of the unit-width slope sample; slopes are then scaled by
         * (ax, ay) and m = normalize(-slope, 1) (sign irrelevant: phi uniform). */
        REAL r;
        if (mf->dist == BT_MF_GGX)
            r = sqrt(u0 / (R(1.0) - u0));
        else
            r = sqrt(-bt_log(R(1.0) - u0));
        REAL sx = mf->ax * r * cp, sy = mf->ay * r * sp;
        REAL inv = R(1.0) / sqrt(R(1.0) + sx * sx + sy * sy);
        m = bt_v3(sx * inv, sy * inv, inv);
    }
    *pdf = bt_mf_d(mf, m) * m.z;
    return m;
}

/* pdf of bt_mf_sample at a given m (solid angle). */
BT_INLINE REAL bt_mf_pdf(const bt_microfacet* mf, bt_vec3 m)
{
    return m.z > R(0.0) ? bt_mf_d(mf, m) * m.z : R(0.0);
}

/* ===================================================== visible normals
 *
 * Slope picture (shared by both distributions).  A normal m (m.z > 0) has
 * slope s = (-m.x/m.z, -m.y/m.z); the anisotropic Beckmann and GGX are the
 * unit-width slope densities P(s~) stretched by S = diag(ax, ay):
 * s = S s~, so m prop. to (ax m~.x, ay m~.y, m~.z) for the unit-width normal m~.
 * The visible-slope density for view v is  prop. to max(0, v.m / m.z) P_S(s)
 * (D_v(m) dw_m = G1 (v.m)/(m.z) D(m) m.z dw_m / v.z and D(m) m.z dw_m is the
 * slope measure).  With P_S(s) = P(S^-1 s) / (ax ay) and
 *   v.m / m.z = v.z - v.x s.x - v.y s.y = v.z - (ax v.x) s~.x - (ay v.y) s~.y
 *             = |(ax v.x, ay v.y, v.z)| v~.m~ / m~.z,
 * the change of variables s = S s~ (Jacobian ax ay) turns it into the
 * unit-width visible-slope density for the view
 *   v~ = normalize(ax v.x, ay v.y, v.z).                             (V1)
 * So every sampler below: stretch v to v~ (V1), sample a unit-width visible
 * normal m~ for v~, unstretch m = normalize(ax m~.x, ay m~.y, m~.z).
 *
 * Precondition everywhere: v.z > 0 (the estimator works in the frame where
 * the light is above; rough_dielectric.h mirrors).  v.z <= 0 is clamped to a
 * tiny positive value, never NaN. */

/* Exact Smith G1 without chi+ for Beckmann and GGX, whatever mf->g1 says:
 * the normaliser of D_v.  Phong has none; it returns Walter's fit (only
 * used if a caller asks for Phong's D_v, which is then not normalised). */
BT_INLINE REAL bt_mf_g1_smith_nochi(const bt_microfacet* mf, bt_vec3 v)
{
    if (mf->dist == BT_MF_GGX) return bt_ggx_g1_nochi(v, mf->ax, mf->ay);
    if (mf->dist == BT_MF_PHONG) return bt_mf_g1_nochi(mf, v);
    return bt_beckmann_g1_exact_a(bt_mf_a(v, mf->ax, mf->ay));
}

/* 1 when bt_mf_sample_visible samples D_v exactly (Beckmann, GGX). */
BT_INLINE int bt_mf_has_visible(const bt_microfacet* mf) { return mf->dist != BT_MF_PHONG; }

/* D_v(m) = G1(v,m) max(0, v.m) D(m) / v.z  (solid angle, v.z > 0; else 0).
 * Integrates to 1 over m by Smith's identity int G1 (v.m)+ D dm = v.z. */
BT_INLINE REAL bt_mf_pdf_visible(const bt_microfacet* mf, bt_vec3 v, bt_vec3 m)
{
    REAL vm = bt_v3_dot(v, m);
    if (!(v.z > R(0.0)) || !(vm > R(0.0)) || !(m.z > R(0.0))) return R(0.0);
    return bt_mf_g1_smith_nochi(mf, v) * vm * bt_mf_d(mf, m) / v.z;
}

/* G(v,o,m) / G1(v,m) for a light direction v with chi+(v,m) = 1, given
 * gv = G1(v) (no chi) of the model's own G1:
 *   separable          G1(v) G1(o) / G1(v)                = G1(o,m)
 *   height-correlated  G1v G1o / (G1v + G1o - G1v G1o) / G1v = G1o / (G1v + G1o - G1v G1o)
 * Both lie in [0, 1] (the HC denominator is >= G1o), written without the
 * division by G1v so gv = 0 cannot give 0/0. */
BT_INLINE REAL bt_mf_g_over_g1(const bt_microfacet* mf, REAL gv, bt_vec3 o, bt_vec3 m)
{
    if (!bt_mf_visible(o, m)) return R(0.0);
    REAL go = bt_mf_g1_nochi(mf, o);
    if (mf->shadowing == BT_SHADOW_HEIGHT_CORRELATED) {
        REAL den = gv + go - gv * go;
        return den > R(0.0) ? go / den : R(0.0);
    }
    return go;
}

/* Stretched view (V1), with a strictly positive z. */
BT_INLINE bt_vec3 bt_mf_stretch_view(bt_vec3 v, REAL ax, REAL ay)
{
    return bt_v3_normalize(bt_v3(ax * v.x, BT_SLP_SPLIT(ay * v.y), fmax(v.z, R(1e-30))));
}

/* Unstretch a unit-width normal; the z clamp keeps a rounding-level negative
 * z from flipping the facet. */
BT_INLINE bt_vec3 bt_mf_unstretch_normal(bt_vec3 mt, REAL ax, REAL ay)
{
    return bt_v3_normalize(bt_v3(ax * mt.x, BT_SLP_SPLIT(ay * mt.y), fmax(mt.z, R(0.0))));
}

/* ---------------- GGX (Heitz 2018, JCGT 7(4))
 * The unit-width GGX has D = 1/pi on the upper hemisphere: the normals of a
 * hemisphere of radius 1 (a hemispherical bump).  Seen from v~, the visible
 * normals of a convex body are distributed like its projected area: uniform
 * over the silhouette of {n: |n| = 1, n.z > 0, n.v~ > 0} on the plane
 * orthogonal to v~.  In the basis (t1, t2, v~) with t1 horizontal
 * (t1 = normalize(-v~.y, v~.x, 0)), that silhouette is the half-disk
 * p2 >= 0 plus the half-ellipse p2 in [-v~.z h, 0], h = sqrt(1 - p1^2)
 * (the rim circle n.z = 0 projects to an ellipse of minor axis v~.z).
 * A uniform point of the unit disk is mapped chord by chord: at fixed p1 the
 * chord [-h, h] goes linearly onto [-v~.z h, h], i.e.
 *   p2' = (1 - s) h + s p2,  s = (1 + v~.z) / 2,
 * which scales every chord by the same factor s, so uniform stays uniform.
 * Lifting the point back onto the sphere along v~,
 *   m~ = p1 t1 + p2' t2 + sqrt(1 - p1^2 - p2'^2) v~,
 * gives the visible normal; unstretching gives m.  Inputs u0 (radius^2) and
 * u1 (angle) in [0, 1). */
BT_INLINE bt_vec3 bt_ggx_sample_visible(bt_vec3 v, REAL ax, REAL ay, REAL u0, REAL u1)
{
    bt_vec3 vt = bt_mf_stretch_view(v, ax, ay);
    REAL l2 = vt.x * vt.x + vt.y * vt.y;
    bt_vec3 t1 = l2 > R(0.0) ? bt_v3_scale(bt_v3(-vt.y, vt.x, R(0.0)), R(1.0) / sqrt(l2))
                             : bt_v3(R(1.0), R(0.0), R(0.0)); /* v~ = n: any t1 */
    bt_vec3 t2 = bt_v3_cross(vt, t1);
    REAL r = sqrt(u0), phi = BT_TWO_PI * u1;
    REAL p1 = r * bt_cos(phi), p2 = r * bt_sin(phi);
    REAL s = R(0.5) * (R(1.0) + vt.z);
    p2 = (R(1.0) - s) * bt_safe_sqrt(R(1.0) - p1 * p1) + s * p2;
    REAL p3 = bt_safe_sqrt(R(1.0) - p1 * p1 - p2 * p2);
    bt_vec3 mt = bt_v3_add(bt_v3_add(bt_v3_scale(t1, p1), bt_v3_scale(t2, p2)),
                           bt_v3_scale(vt, p3));
    return bt_mf_unstretch_normal(mt, ax, ay);
}

/* ---------------- Beckmann (Heitz & d'Eon 2014, EGSR)
 * Unit-width Beckmann slopes: P(x, y) = exp(-x^2 - y^2) / pi.  Rotate the
 * slope axes so v~ = (sin t, 0, cos t); with m~ prop. to (-x, -y, 1),
 *   v~.m~ / m~.z = cos t - x sin t,
 * and the visible-slope density is  prop. to max(0, mu - x) exp(-x^2) exp(-y^2),
 * mu = cot t: x and y are independent.
 *   y ~ exp(-y^2)/sqrt(pi):      y = erfinv(2 u1 - 1).
 *   x on (-inf, mu], unnormalised CDF
 *     C(x) = int_{-inf}^x (mu - t) exp(-t^2) dt
 *          = (mu sqrt(pi)/2) erfc(-x) + exp(-x^2)/2,
 *   total C(mu) = sqrt(pi) mu / G1 (the Smith normaliser of eq. 26, a = mu).
 *   x solves C(x) = u0 C(mu).
 * Neither inverse has a closed form; both are roots of
 *   L(x) = ln(a erfc(-x) + b exp(-x^2)) = target
 * (x: a = mu sqrt(pi)/2, b = 1/2; y: a = 1/2, b = 0, target ln u).  L is
 * increasing and concave (the CDF of a log-concave density is log-concave),
 * which makes it nearly quadratic in the tails, where C itself is flat or
 * exponentially steep.  We take Halley steps on L (cubic convergence, 2-5
 * evaluations from the start used below), keep a bracket and bisect
 * whenever a step leaves it, so rounding can never make it wander.
 * Departures from the paper: the paper inverts with a fitted initial guess
 * and plain Newton on C; we use the bracketed log form, and cut the slope
 * range to [-7, 7] (probability lost < erfc(7)/2 = 2e-23, below double
 * resolution of u), which keeps every sample finite including u = 0.
 * L' = C'/C with C' = exp(-x^2) (2a/sqrt(pi) - 2 b x);
 * L'' = C''/C - L'^2 with C'' = exp(-x^2) (-2b - 2x (2a/sqrt(pi) - 2 b x)). */

#if defined(BT_REAL_IS_FLOAT) && BT_REAL_IS_FLOAT && BT_DEVICE
#define BT_MF_SOLVE_TOL R(3e-7)
#else
#define BT_MF_SOLVE_TOL R(1e-13)
#endif
#define BT_MF_SLOPE_MAX R(7.0)
#define BT_MF_SOLVE_ITERS 80
/* Steps of the fixed-step form (BT_MF_SOLVE_STEPS builds, below), chosen by
 * measurement.  Steps the loop takes (2 million uniform u on the 2^-32 grid,
 * mu = cot theta log-uniform in [1e-3, 1e3], host): the y search 1-3 (mean
 * 2.23), the x search 2-4 for 99.9 % (mean 3.16; 5-12 for 2331 of them).
 * interfaced-lambertian's body (`brdftab bench`), device per CPU-second over
 * the serial host's, two rounds: (x, y) = (4, 3) 3.65-3.82, (5, 3) 3.37-3.44,
 * (6, 3) 3.09-3.20, (3, 3) 2.06-2.10, (4, 2) 2.11-2.15 (fewer steps: more
 * samples redone; the usual kernel: 1.66-1.72). */
#ifndef BT_MF_SOLVE_STEPS_X
#define BT_MF_SOLVE_STEPS_X 4
#endif
#ifndef BT_MF_SOLVE_STEPS_Y
#define BT_MF_SOLVE_STEPS_Y 3
#endif

/* One step of the search: Halley on L with the bracket [lo, hi].  Returns 1
 * when the search has ended, with the answer in *x. */
BT_INLINE int bt_mf_solve_step(REAL a, REAL b, REAL target, REAL* lo, REAL* hi, REAL* x)
{
    const REAL k = R(1.12837916709551257390) * a; /* 2a / sqrt(pi) */
    REAL xc = *x;
    REAL e = bt_exp(-xc * xc);
    REAL c = a * bt_erfc(-xc) + b * e;
    REAL g = bt_log(c) - target;
    if (g == R(0.0)) return 1;
    if (g > R(0.0)) *hi = xc; else *lo = xc;
    REAL d1 = e * (k - R(2.0) * b * xc) / c;                           /* L' >= 0 for x <= mu */
    REAL d2 = e * (-R(2.0) * b - R(2.0) * xc * (k - R(2.0) * b * xc)) / c - d1 * d1; /* L'' */
    /* Halley's step (cubic convergence; Newton's when L'' = 0). */
    REAL den = R(2.0) * d1 * d1 - g * d2;
    REAL xn = den > R(0.0) ? xc - R(2.0) * g * d1 / den : R(0.5) * (*lo + *hi);
    /* A converged step may land on the bracket's end: once the correction
     * is below half an ulp, xn == x, and x has just become lo or hi.
     * That ends the search here; the test below would reject it as
     * outside and bisect, and every later Halley step would land on the
     * same end again: bisection alone then shrank the bracket, 8 to 34
     * steps in all for about 3 % of the x solves (measured over uniform
     * u and directions: mean 3.68 steps per x solve before, 3.34 after,
     * at most 12). */
    *x = xn;
    if (fabs(xn - xc) <= BT_MF_SOLVE_TOL * (R(1.0) + fabs(xn)) && xn >= *lo && xn <= *hi) return 1;
    if (!(xn > *lo && xn < *hi)) xn = R(0.5) * (*lo + *hi); /* also catches NaN */
    *x = xn;
    REAL tol = BT_MF_SOLVE_TOL * (R(1.0) + fabs(xn));
    return fabs(xn - xc) <= tol || *hi - *lo <= tol;
}

#if BT_DEVICE && defined(BT_MF_SOLVE_STEPS) && !(defined(BT_REAL_IS_FLOAT) && BT_REAL_IS_FLOAT)
#define BT_MF_FIXED_STEPS 1
#else
#define BT_MF_FIXED_STEPS 0
#endif
#if BT_MF_FIXED_STEPS
/* Device builds with BT_MF_SOLVE_STEPS (the engine's sample-parallel kernels
 * of interfaced-lambertian's body): exactly `steps` steps, a lane that has
 * ended keeps its answer through selects, so the work-item loop has no loop
 * of its own and vectorises; a search that has not ended by then returns NaN,
 * and the engine's redo kernel computes that sample again with the loop
 * below (kernels/common/estimator.h), so every sample is the loop's value. */
BT_INLINE REAL bt_mf_solve_log_cdf_steps(REAL a, REAL b, REAL target, REAL lo, REAL hi, REAL x,
                                         int steps)
{
    int done = 0;
    BT_MATH_UNROLL
    for (int it = 0; it < steps; ++it) {
        REAL l = lo, h = hi, xs = x;
        int ended = bt_mf_solve_step(a, b, target, &l, &h, &xs);
        lo = done ? lo : l;
        hi = done ? hi : h;
        x = done ? x : xs;
        done = done | ended;
    }
    return done ? x : (REAL)NAN;
}
#define BT_MF_SOLVE(a, b, target, lo, hi, x, steps) \
    bt_mf_solve_log_cdf_steps((a), (b), (target), (lo), (hi), (x), (steps))
/* m from bt_mf_sample_visible is NaN: a search has not ended (redo). */
#define BT_MF_UNFINISHED(m) ((m).z != (m).z)
#else
#define BT_MF_SOLVE(a, b, target, lo, hi, x, steps) \
    bt_mf_solve_log_cdf((a), (b), (target), (lo), (hi), (x))
#define BT_MF_UNFINISHED(m) 0
#endif

BT_INLINE REAL bt_mf_solve_log_cdf(REAL a, REAL b, REAL target, REAL lo, REAL hi, REAL x)
{
    for (int it = 0; it < BT_MF_SOLVE_ITERS; ++it)
        if (bt_mf_solve_step(a, b, target, &lo, &hi, &x)) return x;
    return x;
}

/* Starting point for erfinv(2u - 1): Winitzki's closed-form approximation
 * (relative error ~2e-3), with 1 - z^2 = 4 u (1 - u) so nothing cancels. */
BT_INLINE REAL bt_mf_erfinv_unit_guess(REAL u)
{
    const REAL k = R(4.33074675)    /* 2 / (pi 0.147) */, inv_a = R(6.80272109); /* 1/0.147 */
    REAL q = fmax(fmin(u, R(1.0) - u), R(1e-30));
    REAL l = bt_log_split(R(4.0) * q * (R(1.0) - q)); /* not packed with bt_log(q) */
    REAL t = k + R(0.5) * l;
    REAL y = bt_safe_sqrt(bt_safe_sqrt(t * t - l * inv_a) - t);
    return u < R(0.5) ? -y : y;
}

/* y with (1 + erf y)/2 = u (a normal variable of variance 1/2): by symmetry
 * solve for u <= 1/2 (y <= 0) and flip, so 1 - u never cancels. */
BT_INLINE REAL bt_mf_erfinv_unit(REAL u)
{
    int flip = u > R(0.5);
    REAL q = flip ? R(1.0) - u : u;
    q = fmax(q, R(1e-30)); /* u = 0 -> the range cut at -7 */
    REAL x0 = fmax(bt_mf_erfinv_unit_guess(q), -BT_MF_SLOPE_MAX + R(0.5));
    REAL y = BT_MF_SOLVE(R(0.5), R(0.0), bt_log(q), -BT_MF_SLOPE_MAX, R(0.0), x0, BT_MF_SOLVE_STEPS_Y);
    return flip ? -y : y;
}

/* x-slope of the unit-width visible Beckmann slopes for mu = cot(theta~) >= 0. */
BT_INLINE REAL bt_beckmann_visible_slope_x(REAL mu, REAL u)
{
    REAL a = R(0.5) * BT_SQRT_PI * mu;
    REAL total = a * bt_erfc(-mu) + R(0.5) * bt_exp(-mu * mu); /* C(mu) */
    REAL q = fmax(u, R(1e-30));
    REAL target = bt_log(q) + bt_log(total);
    REAL hi = fmin(mu, BT_MF_SLOPE_MAX), lo = -BT_MF_SLOPE_MAX;
    /* Start: blend of the exact inverses of the two limits, mu = 0
     * (C = exp(-x^2)/2: x = -sqrt(-ln u)) and mu -> inf (Gaussian), with
     * weight mu^2/(1 + mu^2): measured 1.4 to 4.3 evaluations on average
     * (Halley from the Gaussian start alone: 5 to 6). */
    REAL w = mu < R(1e4) ? mu * mu / (R(1.0) + mu * mu) : R(1.0);
    REAL x0 = w * bt_mf_erfinv_unit_guess(q) + (R(1.0) - w) * -bt_safe_sqrt(-bt_log(q));
    if (!(x0 > lo && x0 < hi)) x0 = R(0.5) * (lo + hi);
    return BT_MF_SOLVE(a, R(0.5), target, lo, hi, x0, BT_MF_SOLVE_STEPS_X);
}

BT_INLINE bt_vec3 bt_beckmann_sample_visible(bt_vec3 v, REAL ax, REAL ay, REAL u0, REAL u1)
{
    bt_vec3 vt = bt_mf_stretch_view(v, ax, ay);
    REAL st = sqrt(vt.x * vt.x + vt.y * vt.y);
    /* Azimuth of v~ (any at normal incidence); mu = cot(theta~), capped so
     * normal incidence stays finite (mu > 7 already means "no cut"). */
    REAL cp = st > R(0.0) ? vt.x / st : R(1.0);
    REAL sp = BT_SLP_SPLIT(st > R(0.0) ? vt.y / st : R(0.0)); /* splits: compat.h */
    REAL mu = vt.z < st * R(1e15) ? vt.z / st : R(1e15);
    REAL x = bt_beckmann_visible_slope_x(mu, u0);
    REAL y = bt_mf_erfinv_unit(u1);
    /* Rotate the slope back by the azimuth; m~ prop. to (-slope, 1). */
    REAL sx = cp * x - sp * y, sy = BT_SLP_SPLIT(sp * x + cp * y);
    bt_vec3 mt = bt_v3_normalize(bt_v3(-sx, -sy, R(1.0)));
    bt_vec3 m = bt_mf_unstretch_normal(mt, ax, ay);
#if BT_MF_FIXED_STEPS
    /* A search that has not ended gives a NaN normal (BT_MF_UNFINISHED). */
    if (!(x == x) || !(y == y)) m = bt_v3((REAL)NAN, (REAL)NAN, (REAL)NAN);
#endif
    return m;
}

/* m ~ D_v(m) for light/view v (v.z > 0).  Phong has no visible sampler:
 * callers check bt_mf_has_visible and use bt_mf_sample instead; here Phong
 * falls back to bt_mf_sample's m (pdf D|m.n|, NOT D_v). */
BT_INLINE bt_vec3 bt_mf_sample_visible(const bt_microfacet* mf, bt_vec3 v, REAL u0, REAL u1)
{
    if (mf->dist == BT_MF_GGX) return bt_ggx_sample_visible(v, mf->ax, mf->ay, u0, u1);
    if (mf->dist == BT_MF_BECKMANN) return bt_beckmann_sample_visible(v, mf->ax, mf->ay, u0, u1);
    REAL pdf;
    return bt_mf_sample(mf, u0, u1, &pdf);
}

#endif /* BRDFTAB_MICROFACET_H */

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
 * No pow() anywhere (PoCL's pow is ~10x slower): Phong's cos^alpha_p is
 * exp(alpha_p log c).
 */
#ifndef BRDFTAB_MICROFACET_H
#define BRDFTAB_MICROFACET_H

#include "compat.h"
#include "vec3.h"

#define BT_MF_BECKMANN 0
#define BT_MF_GGX 1
#define BT_MF_PHONG 2

#define BT_G1_EXACT 0
#define BT_G1_WALTER_FIT 1

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
    return exp(-e) / (BT_PI * ax * ay * z2 * z2);
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
    REAL t = fmin(alpha_p * log(fmin(mz, R(1.0))), R(80.0));
    return (alpha_p + R(2.0)) * (R(0.5) * BT_INV_PI) * exp(t);
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
 * finite for a = 0 (grazing -> 0) and a -> inf (-> 1). */
BT_INLINE REAL bt_beckmann_g1_exact_a(REAL a)
{
    REAL as = a * BT_SQRT_PI;
    return R(2.0) * as / (as * (R(1.0) + erf(a)) + exp(-a * a));
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
    REAL cp = cos(phi), sp = sin(phi);
    bt_vec3 m;
    if (mf->dist == BT_MF_PHONG) {
        REAL ap = bt_phong_exponent(mf->ax);
        REAL ct = exp(log(R(1.0) - u0) / (ap + R(2.0)));
        REAL st = bt_safe_sqrt(R(1.0) - ct * ct);
        m = bt_v3(st * cp, st * sp, ct);
    } else {
        /* Radius of the unit-width slope sample; slopes are then scaled by
         * (ax, ay) and m = normalize(-slope, 1) (sign irrelevant: phi uniform). */
        REAL r;
        if (mf->dist == BT_MF_GGX)
            r = sqrt(u0 / (R(1.0) - u0));
        else
            r = sqrt(-log(R(1.0) - u0));
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

#endif /* BRDFTAB_MICROFACET_H */

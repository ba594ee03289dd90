/*
 * vec3.h — a minimal 3-vector for the shared kernel math (OpenCL C 1.2 and
 * C++17, see compat.h).
 *
 * Frame: macro normal n = +z.  Every direction points AWAY from the surface
 * (i toward the light, o toward the viewer), as in Walter et al. 2007.
 *
 * Index-of-refraction convention used by bt_refract and by fresnel.h:
 *   eta = eta_t / eta_i  — index of the medium the light ENTERS divided by
 *   the index of the medium it comes FROM (relative index across the facet).
 */
#ifndef BRDFTAB_VEC3_H
#define BRDFTAB_VEC3_H

#include "compat.h"
#include "bt_math.h"

typedef struct {
    REAL x, y, z;
} bt_vec3;

BT_INLINE bt_vec3 bt_v3(REAL x, REAL y, REAL z)
{
    bt_vec3 r;
    r.x = x;
    r.y = y;
    r.z = z;
    return r;
}
BT_INLINE bt_vec3 bt_v3_add(bt_vec3 a, bt_vec3 b) { return bt_v3(a.x + b.x, a.y + b.y, a.z + b.z); }
BT_INLINE bt_vec3 bt_v3_sub(bt_vec3 a, bt_vec3 b) { return bt_v3(a.x - b.x, a.y - b.y, a.z - b.z); }
BT_INLINE bt_vec3 bt_v3_scale(bt_vec3 a, REAL s) { return bt_v3(a.x * s, a.y * s, a.z * s); }
BT_INLINE bt_vec3 bt_v3_neg(bt_vec3 a) { return bt_v3(-a.x, -a.y, -a.z); }
BT_INLINE REAL bt_v3_dot(bt_vec3 a, bt_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
BT_INLINE REAL bt_v3_length(bt_vec3 a) { return sqrt(bt_v3_dot(a, a)); }
BT_INLINE bt_vec3 bt_v3_cross(bt_vec3 a, bt_vec3 b)
{
    return bt_v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

/* Unit vector along a; the zero vector maps to +z so callers never see NaN
 * (they must treat a zero-length input as a degenerate case themselves). */
BT_INLINE bt_vec3 bt_v3_normalize(bt_vec3 a)
{
    REAL l2 = bt_v3_dot(a, a);
    if (!(l2 > R(0.0))) return bt_v3(R(0.0), R(0.0), R(1.0));
    return bt_v3_scale(a, R(1.0) / sqrt(l2));
}

/* Mirror direction of i about the unit normal m; both point away from the
 * surface: o = 2 (i.m) m - i  (Walter 2007 eq. 39, reflection case). */
BT_INLINE bt_vec3 bt_reflect(bt_vec3 i, bt_vec3 m)
{
    return bt_v3_sub(bt_v3_scale(m, R(2.0) * bt_v3_dot(i, m)), i);
}

/* Refraction of i (pointing away from the facet, on the side m points to
 * when i.m > 0) through the facet with unit normal m.  eta = eta_t / eta_i.
 * Walter 2007 eq. 40 with his ratio eta_W = eta_i / eta_t = 1/eta and c = i.m:
 *     o = (eta_W c - sign(c) sqrt(1 + eta_W^2 (c^2 - 1))) m - eta_W i.
 * Returns 0 on total internal reflection (*out untouched), 1 otherwise.  The
 * result points away from the surface on the other side of the facet. */
BT_INLINE int bt_refract(bt_vec3 i, bt_vec3 m, REAL eta, bt_vec3* out)
{
    REAL c = bt_v3_dot(i, m);
    REAL e = R(1.0) / eta;
    REAL k = R(1.0) + e * e * (c * c - R(1.0));
    if (k < R(0.0)) return 0;
    REAL s = c >= R(0.0) ? sqrt(k) : -sqrt(k);
    *out = bt_v3_sub(bt_v3_scale(m, e * c - s), bt_v3_scale(i, e));
    return 1;
}

/* Spherical -> Cartesian: theta from +z in [0, pi], phi from +x. */
BT_INLINE bt_vec3 bt_from_spherical(REAL theta, REAL phi)
{
    REAL ct, cp;
    REAL st = bt_sincos(theta, &ct);
    REAL sp = bt_sincos(phi, &cp);
    return bt_v3(st * cp, st * sp, ct);
}

/* How bt_direction forms the z component (see there). */
#define BT_DIR_CLAMP_COS 0  /* z = max(cos theta, min_cos) on both sides */
#define BT_DIR_SIGNED_COS 1 /* z = max(|cos theta|, min_cos), negated below */

/* The direction of a tabulated point (theta, phi) as the models evaluate it.
 * Returns 1 when it is above the surface, 0 below.  The side comes from
 * theta (theta <= pi/2 is above), not from the sign of cos(theta): in float,
 * theta = pi/2 rounds up and its cosine is -4.4e-8, yet the point is meant
 * to be on the horizon.  x and y are those of bt_from_spherical; z is
 * floored at min_cos so that a grazing direction gives the model's finite
 * grazing value instead of 0/0 (each model passes its own floor and says why
 * that value).  The two rules differ only where cos(theta) <= min_cos:
 *   BT_DIR_CLAMP_COS   z = max(cos theta, min_cos); a direction below the
 *                      surface reads as grazing (models that reject it first);
 *                      float theta = pi/2 gets z = min_cos.
 *   BT_DIR_SIGNED_COS  z = +-max(|cos theta|, min_cos), minus below (models
 *                      defined on both sides); float theta = pi/2 gets
 *                      z = 4.4e-8 when min_cos is smaller. */
BT_INLINE int bt_direction(REAL theta, REAL phi, REAL min_cos, int z_rule, bt_vec3* v)
{
    int above = !(theta > BT_HALF_PI);
    *v = bt_from_spherical(theta, phi);
    if (z_rule == BT_DIR_CLAMP_COS) {
        v->z = fmax(v->z, min_cos);
    } else {
        REAL z = fmax(fabs(v->z), min_cos);
        v->z = above ? z : -z;
    }
    return above;
}

/* Cartesian (any length > 0) -> spherical; phi in (-pi, pi]. */
BT_INLINE void bt_to_spherical(bt_vec3 v, REAL* theta, REAL* phi)
{
    REAL l = bt_v3_length(v);
    *theta = l > R(0.0) ? bt_safe_acos(v.z / l) : R(0.0);
    *phi = atan2(v.y, v.x);
}

#endif /* BRDFTAB_VEC3_H */

/*
 * fresnel.h — exact Fresnel reflectance of a smooth dielectric interface for
 * unpolarised light, with total internal reflection.
 *
 * Walter et al. 2007 eq. 22:
 *     F = 1/2 (g - c)^2 / (g + c)^2 * (1 + (c (g + c) - 1)^2 / (c (g - c) + 1)^2)
 *     g = sqrt(eta^2 - 1 + c^2),   c = |i.m|,   eta = eta_t / eta_i
 * (eta_t: index of the side the light enters, eta_i: the side it comes from;
 * same convention as bt_refract in vec3.h).  g^2 < 0 is total internal
 * reflection: F = 1.
 *
 * Numerical form (departure in the arithmetic only, not the value):
 * (g - c)/(g + c) is evaluated as (eta^2 - 1)/(g + c)^2, which is exact
 * algebra (g^2 - c^2 = eta^2 - 1) and keeps full relative precision as
 * eta -> 1, where g - c would cancel.  The one point where the formula is
 * 0/0, c = 0 with eta = 1 exactly, returns 0 (the value of F for eta = 1 at
 * every other angle: no interface, no reflection).
 */
#ifndef BRDFTAB_FRESNEL_H
#define BRDFTAB_FRESNEL_H

#include "compat.h"

BT_INLINE REAL bt_fresnel_dielectric(REAL cos_i, REAL eta)
{
    REAL c = fmin(fabs(cos_i), R(1.0));
    REAL e2m1 = eta * eta - R(1.0);
    REAL g2 = e2m1 + c * c;
    if (g2 <= R(0.0)) {
        /* Total internal reflection; g2 == 0 exactly is the critical angle,
         * where the formula also gives 1 (c(g - c) + 1 = 1 - c^2, ratio 1). */
        return e2m1 == R(0.0) ? R(0.0) : R(1.0);
    }
    REAL g = sqrt(g2);
    REAL gpc = g + c;
    REAL ratio = e2m1 / (gpc * gpc); /* = (g - c)/(g + c) */
    REAL num = c * gpc - R(1.0);
    REAL den = c * (g - c) + R(1.0); /* >= 1 - c^2 >= 0; 0 only if eta = 0 */
    REAL q = den > R(0.0) ? num / den : R(1.0);
    REAL f = R(0.5) * ratio * ratio * (R(1.0) + q * q);
    return bt_clamp(f, R(0.0), R(1.0));
}

/* Reflectance at normal incidence, ((eta - 1)/(eta + 1))^2: the c = 1 case of
 * eq. 22, kept separate for tests and for callers that need F0. */
BT_INLINE REAL bt_fresnel_normal(REAL eta)
{
    REAL r = (eta - R(1.0)) / (eta + R(1.0));
    return r * r;
}

#endif /* BRDFTAB_FRESNEL_H */

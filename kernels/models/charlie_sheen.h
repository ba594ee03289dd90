/*
 * charlie_sheen.h — directional albedo of the cloth (sheen) lobe of
 * Filament's DFG texture: the "Charlie" distribution of A. C. Estevez and
 * C. Kulla, "Production Friendly Microfacet Sheen BRDF" (2017),
 *   D(h) = (2 + 1/alpha) sin(theta_h)^(1/alpha) / (2 pi),          (eq. 2)
 * with the visibility term of D. Neubelt and M. Pettineo, "Crafting a
 * Next-Gen Material Pipeline for The Order: 1886" (SIGGRAPH 2013 course),
 * after Ashikhmin,
 *   V(v, l) = 1 / (4 (n.l + n.v - n.l n.v)),
 * so f = D V (no Fresnel term) and the albedo is
 *   E(v) = int D(h) V(v, l) n.l dl   over the hemisphere n.l > 0.
 * D is normalised, int D n.h dh = 1.  At n.v = 1 the albedo is closed
 * form, E = 2^(-k/2) / (k + 4) with k = 1/alpha (tests/test_renderer_luts.cpp).
 *
 * Quadrature.  In microfacet normals h (u = n.h, phi from the plane of v),
 * dl = 4 (v.h) dh and l = 2 (v.h) h - v, so
 *   E = 2 int du int_0^phi*(u) dphi D(u) V 4 (v.h) n.l,
 * n.l = 2 (v.h) u - n.v.  D is constant on a row u; the row ends where
 * n.l = 0 (the integrand vanishes linearly there).  With theta_v the view
 * angle and u = cos theta_h, some phi has n.l > 0 iff theta_h < (theta_v +
 * pi/2)/2 (u > u_min) and every phi does iff theta_h < (pi/2 - theta_v)/2
 * (u > u_full): the row length behaves like sqrt(u - u_min) and like
 * sqrt(u_full - u) at those two ends, so the u panels end there, graded
 * (power 2).  D ~ (1 - u^2)^(k/2) decays from u_min on a scale ~ 1/(k u_min)
 * (k reaches ~7e3 at Filament's smoothest row): the panel above u_min is cut
 * geometrically towards it, at u_min + d 4^-j (j = 1 .. CS_DECAY_LEVELS).
 * Near u = 1, D ~ (1 - u)^(k/2), not smooth unless k is even: graded there
 * too, power 4 (u = 1 - O(s^4): D du ~ s^(2k + 3) ds).
 * n Gauss-Legendre nodes per panel in u and n on each row in phi.
 */
#ifndef BRDFTAB_CHARLIE_SHEEN_H
#define BRDFTAB_CHARLIE_SHEEN_H

#include "../common/bt_math.h"
#include "../common/compat.h"
#include "../common/gauss_legendre.h"
#include "../common/sampler.h"

#define CS_MAX_NODES 64
#define CS_MIN_COS R(1e-9) /* floor on n.v, as the rough-dielectric albedos' */
#define CS_DECAY_LEVELS 8
#define CS_MAX_EDGES (4 + CS_DECAY_LEVELS)

/* D(u) of eq. 2 with k = 1/alpha, u = n.h. */
BT_INLINE REAL cs_charlie_d(REAL u, REAL k)
{
    REAL s2 = fmax(R(1.0) - u * u, R(0.0));
    if (!(s2 > R(0.0))) return R(0.0);
    return (R(2.0) + k) * bt_exp(R(0.5) * k * bt_log(s2)) / (R(2.0) * BT_PI); /* eq. 2 */
}

/* The integrand D V 4 (v.h) n.l at normal h = (s_h cos phi, s_h sin phi, u)
 * for v = (sv, 0, cv), 0 where n.l <= 0. */
BT_INLINE REAL cs_integrand(REAL sv, REAL cv, REAL u, REAL sh, REAL cphi, REAL d)
{
    REAL vh = sv * sh * cphi + cv * u;
    REAL nl = R(2.0) * vh * u - cv;
    if (!(nl > R(0.0)) || !(vh > R(0.0))) return R(0.0);
    REAL vis = R(1.0) / (R(4.0) * (nl + cv - nl * cv)); /* Neubelt's V */
    return d * vis * R(4.0) * vh * nl;
}

/* The albedo E(n.v = cv) at roughness alpha by quadrature, n nodes per panel. */
BT_INLINE REAL cs_sheen_albedo_quadrature(REAL cv, REAL alpha, int n)
{
    REAL gx[CS_MAX_NODES], gw[CS_MAX_NODES];
    n = n < 1 ? 1 : (n > CS_MAX_NODES ? CS_MAX_NODES : n);
    bt_gauss_legendre_rule(n, gx, gw);
    cv = fmin(fmax(cv, CS_MIN_COS), R(1.0));
    REAL sv = bt_safe_sqrt(R(1.0) - cv * cv);
    REAL k = R(1.0) / alpha;
    REAL tv = bt_acos(cv);
    REAL u_min = bt_cos(R(0.5) * (tv + BT_HALF_PI));
    REAL u_full = bt_cos(R(0.5) * (BT_HALF_PI - tv));
    /* Panel ends: u_min, the decay levels above it, u_full, 1; grading 2 at
     * u_min and u_full, 4 at 1. */
    REAL e[CS_MAX_EDGES];
    int g[CS_MAX_EDGES];
    int ne = 0;
    e[ne] = u_min;
    g[ne++] = 2;
    REAL next = u_full > u_min ? u_full : R(1.0);
    REAL t = R(1.0);
    for (int j = 0; j < CS_DECAY_LEVELS; ++j) t *= R(0.25);
    for (int j = CS_DECAY_LEVELS; j >= 1; --j, t *= R(4.0)) { /* ascending */
        e[ne] = u_min + (next - u_min) * t;
        g[ne++] = 1;
    }
    if (u_full > u_min && u_full < R(1.0)) {
        e[ne] = u_full;
        g[ne++] = 2;
    }
    e[ne] = R(1.0);
    g[ne++] = 4;
    REAL sum = R(0.0);
    for (int p = 0; p + 1 < ne; ++p) {
        REAL lo = e[p], L = e[p + 1] - lo;
        if (!(L > R(0.0))) continue;
        for (int a = 0; a < n; ++a) {
            REAL jac;
            REAL tu = bt_graded_map(R(0.5) * (gx[a] + R(1.0)), g[p], g[p + 1], &jac);
            REAL u = lo + L * tu;
            REAL d = cs_charlie_d(u, k);
            if (!(d > R(0.0))) continue;
            REAL sh = bt_safe_sqrt(R(1.0) - u * u);
            /* the row's end: n.l = 0 at cos phi* = (cv / (2u) - cv u) / (sv sh) */
            REAL phi_end = BT_PI;
            if (sv * sh > R(0.0)) {
                REAL c = (cv / (R(2.0) * u) - cv * u) / (sv * sh);
                if (!(c < R(1.0))) continue;
                if (c > -R(1.0)) phi_end = bt_acos(c);
            } else if (!(R(2.0) * u * u > R(1.0))) {
                continue; /* v = n: n.l = 2u^2 - 1 */
            }
            REAL row = R(0.0);
            for (int b = 0; b < n; ++b) {
                REAL phi = R(0.5) * phi_end * (gx[b] + R(1.0));
                row += R(0.5) * phi_end * gw[b] * cs_integrand(sv, cv, u, sh, bt_cos(phi), d);
            }
            sum += R(0.5) * L * gw[a] * jac * R(2.0) * row; /* 2: phi in [-pi, 0] */
        }
    }
    return sum;
}

/* One sample of E by uniform hemisphere sampling of h (pdf 1/(2 pi)), the
 * estimator Filament's cmgen uses: D V n.l 4 (v.h) 2 pi. */
BT_INLINE REAL cs_sheen_albedo_sample(REAL cv, REAL alpha, REAL u0, REAL u1)
{
    cv = fmin(fmax(cv, CS_MIN_COS), R(1.0));
    REAL sv = bt_safe_sqrt(R(1.0) - cv * cv);
    REAL u = R(1.0) - u0; /* cos theta_h uniform in (0, 1] */
    REAL sh = bt_safe_sqrt(R(1.0) - u * u);
    REAL cphi = bt_cos(R(2.0) * BT_PI * u1);
    return R(2.0) * BT_PI * cs_integrand(sv, cv, u, sh, cphi, cs_charlie_d(u, R(1.0) / alpha));
}

#endif /* BRDFTAB_CHARLIE_SHEEN_H */

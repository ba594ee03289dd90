/*
 * gauss_legendre.h — Gauss-Legendre nodes and weights on [-1, 1], computed
 * in place (no tables), shared by the H-function moments (hfunction.h) and
 * the psi-function solver (horak_chandrasekhar.h).
 *
 * Node k (0-based) of n: Newton's method on the Legendre polynomial P_n from
 * the Tricomi-type initial guess cos(pi (k + 3/4) / (n + 1/2)); weight
 * w = 2 / ((1 - x^2) P_n'(x)^2).  Computed in ACCUM (double whenever the
 * device has fp64, also in float builds) and rounded by the caller.
 */
#ifndef BRDFTAB_GAUSS_LEGENDRE_H
#define BRDFTAB_GAUSS_LEGENDRE_H

#include "compat.h"

/* P_n(z) by the three-term recurrence; *p_prev = P_(n-1)(z).  n >= 1. */
BT_INLINE ACCUM bt_legendre_p(int n, ACCUM z, ACCUM* p_prev)
{
    ACCUM p0 = (ACCUM)1.0, p1 = z;
    for (int j = 2; j <= n; ++j) {
        ACCUM p2 = (((ACCUM)2.0 * (ACCUM)j - (ACCUM)1.0) * z * p1 - ((ACCUM)j - (ACCUM)1.0) * p0) /
                   (ACCUM)j;
        p0 = p1;
        p1 = p2;
    }
    *p_prev = p0;
    return p1;
}

BT_INLINE void bt_gauss_legendre(int n, int k, ACCUM* x, ACCUM* w)
{
    const ACCUM pi = (ACCUM)3.14159265358979323846;
    ACCUM z = cos(pi * ((ACCUM)k + (ACCUM)0.75) / ((ACCUM)n + (ACCUM)0.5));
    ACCUM pn, pm, dp;
    for (int it = 0; it < 100; ++it) {
        pn = bt_legendre_p(n, z, &pm);
        dp = (ACCUM)n * (z * pn - pm) / (z * z - (ACCUM)1.0);
        ACCUM dz = pn / dp;
        z -= dz;
        if (fabs(dz) < (ACCUM)1e-15) break;
    }
    /* P_n' at the converged node, for the weight */
    pn = bt_legendre_p(n, z, &pm);
    dp = (ACCUM)n * (z * pn - pm) / (z * z - (ACCUM)1.0);
    *x = z;
    *w = (ACCUM)2.0 / (((ACCUM)1.0 - z * z) * dp * dp);
}

#endif /* BRDFTAB_GAUSS_LEGENDRE_H */

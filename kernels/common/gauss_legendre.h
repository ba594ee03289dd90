/*
 * gauss_legendre.h — every Gauss-Legendre rule of the kernels, on [-1, 1]:
 *   bt_gauss_legendre        one node and weight at a time, in ACCUM
 *                            (H-function moments, the psi-function solver);
 *   bt_gauss_legendre_rule   the whole n-point rule in REAL (Oren-Nayar
 *                            quadratures, n chosen at run time);
 *   bt_gauss_legendre_table  the 16- and 32-point rules from tables (the
 *                            interfaced Lambertian r_e, r_i and Gaussian
 *                            normalisation, inside per-sample code, where a
 *                            lookup avoids n Newton solves per call).
 * Both computed forms run Newton's method on the Legendre polynomial P_n
 * (three-term recurrence) from the initial guess cos(pi (k + 3/4) / (n + 1/2))
 * for node k, and take the weight w = 2 / ((1 - x^2) P_n'(x)^2).
 *
 * The three forms agree only to rounding, and each model's results must stay
 * bit-identical, so none replaces another.  Measured in double against a long
 * double Newton solution, largest relative weight error for n = 16/32/48/64:
 * bt_gauss_legendre 1.9e-15/5.7e-15/3.9e-14/9.3e-14; bt_gauss_legendre_rule
 * 8e-14 to 3e-13 (its weight uses P_n' one Newton step before the final
 * node); the tables 3e-15 (16) and 1.1e-13 (32).  Between the two computed
 * forms, n = 2..64, 41 of 2079 nodes and 723 weights differ; each table
 * differs from both in 2 nodes and in most weights.
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

/* Node k (0..n-1, descending: k = 0 is the node nearest +1) and its weight,
 * in ACCUM (double whenever the device has fp64, also in float builds; the
 * caller rounds).  Iterates to |dz| < 1e-15 (at most 100 steps) and takes
 * the weight at the converged node. */
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

/* The whole n-point rule (n <= the length of x and w), nodes ascending, in
 * REAL.  Nodes come in symmetric pairs (the negative one is the mirror of
 * the positive one); the weight uses P_n' from the last Newton step, one step
 * before the final node; the iteration stops at |dz| < 1e-14 (1e-6 in a float
 * device build) or after 12 steps. */
BT_INLINE void bt_gauss_legendre_rule(int n, REAL* x, REAL* w)
{
#if defined(BT_REAL_IS_FLOAT) && BT_REAL_IS_FLOAT && BT_DEVICE
    const REAL eps = R(1e-6);
#else
    const REAL eps = R(1e-14);
#endif
    for (int i = 0; i < (n + 1) / 2; ++i) {
        REAL z = cos(BT_PI * ((REAL)i + R(0.75)) / ((REAL)n + R(0.5)));
        REAL pp = R(1.0);
        for (int it = 0; it < 12; ++it) {
            REAL p1 = R(1.0), p2 = R(0.0);
            for (int j = 1; j <= n; ++j) {
                REAL p3 = p2;
                p2 = p1;
                p1 = ((R(2.0) * j - R(1.0)) * z * p2 - (R(1.0) * j - R(1.0)) * p3) / (REAL)j;
            }
            pp = (REAL)n * (z * p1 - p2) / (z * z - R(1.0));
            REAL dz = p1 / pp;
            z -= dz;
            if (fabs(dz) < eps) break;
        }
        x[i] = -z;
        x[n - 1 - i] = z;
        w[i] = R(2.0) / ((R(1.0) - z * z) * pp * pp);
        w[n - 1 - i] = w[i];
    }
}

/* Tabulated 32- and 16-point rules: the non-negative half of the nodes,
 * ascending, and their weights (the rules are symmetric). */
BT_TABLE REAL bt_gl32_x[16] = {
    R(0.04830766568773831), R(0.14447196158279649), R(0.23928736225213706),
    R(0.33186860228212767), R(0.42135127613063533), R(0.50689990893222936),
    R(0.5877157572407623),  R(0.66304426693021523), R(0.73218211874028971),
    R(0.79448379596794239), R(0.84936761373256997), R(0.8963211557660522),
    R(0.93490607593773967), R(0.96476225558750639), R(0.98561151154526838),
    R(0.99726386184948157)};
BT_TABLE REAL bt_gl32_w[16] = {
    R(0.096540088514727812), R(0.095638720079274833), R(0.093844399080804566),
    R(0.091173878695763863), R(0.087652093004403908), R(0.083311924226946846),
    R(0.078193895787070311), R(0.072345794108848449), R(0.065822222776361752),
    R(0.058684093478535704), R(0.050998059262376244), R(0.042835898022226426),
    R(0.034273862913021626), R(0.025392065309262427), R(0.016274394730905965),
    R(0.0070186100094692984)};
BT_TABLE REAL bt_gl16_x[8] = {R(0.095012509837637454), R(0.28160355077925892),
                              R(0.45801677765722737),  R(0.61787624440264377),
                              R(0.755404408355003),    R(0.86563120238783176),
                              R(0.9445750230732326),   R(0.98940093499164994)};
BT_TABLE REAL bt_gl16_w[8] = {R(0.18945061045506859), R(0.18260341504492361),
                              R(0.16915651939500262), R(0.14959598881657676),
                              R(0.12462897125553403), R(0.095158511682492591),
                              R(0.062253523938647706), R(0.027152459411754037)};

/* Node k (0..n-1, ascending) of the tabulated n-point rule (n = 32 or 16)
 * mapped to [a, b]; *w gets its weight, scaled to [a, b]. */
BT_INLINE REAL bt_gauss_legendre_table(int n, int k, REAL a, REAL b, REAL* w)
{
    int h = n / 2;
    int j = k < h ? h - 1 - k : k - h;
    REAL x = n == 32 ? bt_gl32_x[j] : bt_gl16_x[j];
    REAL ww = n == 32 ? bt_gl32_w[j] : bt_gl16_w[j];
    if (k < h) x = -x;
    *w = R(0.5) * (b - a) * ww;
    return a + R(0.5) * (b - a) * (x + R(1.0));
}

/* Graded map of [0, 1] onto itself for Gauss-Legendre on an interval whose
 * ends carry a known algebraic singularity: x(t) = I_t(p, q), the regularised
 * incomplete beta function with integer p, q >= 1, i.e. the binomial tail
 *   I_t(p, q) = sum_{j=p}^{p+q-1} C(p+q-1, j) t^j (1 - t)^(p+q-1-j),
 * with dx/dt = t^(p-1) (1 - t)^(q-1) / B(p, q), B(p, q) = (p-1)! (q-1)! / (p+q-1)!.
 * Near t = 0, x ~ t^p: a term (x - x0)^s at the left end becomes t^(p s), so
 * p = 2 turns a square root (or a 3/2 power) into a polynomial term and p = 4
 * does the same for a 3/4 power; q acts likewise at the right end; p = q = 1 is
 * the identity.  Returns x, *jac = dx/dt.  p + q <= 16. */
BT_INLINE REAL bt_graded_map(REAL t, int p, int q, REAL* jac)
{
    int n = p + q - 1;
    REAL u = R(1.0) - t;
    /* C(n, j) t^j u^(n-j) for j = p .. n, by the ratio of successive terms. */
    REAL term = R(1.0);
    for (int k = 0; k < p; ++k) term *= t * (REAL)(n - k) / (REAL)(k + 1);
    for (int k = p; k < n; ++k) term *= u;
    REAL x = R(0.0);
    for (int j = p; j <= n; ++j) {
        x += term;
        if (j < n) term = u > R(0.0) ? term * t * (REAL)(n - j) / ((REAL)(j + 1) * u) : R(0.0);
    }
    if (u <= R(0.0)) x = R(1.0);
    /* 1 / B(p, q) = n! / ((p-1)! (q-1)!) = p C(n, p) */
    REAL inv_beta = (REAL)p;
    for (int k = 0; k < p; ++k) inv_beta *= (REAL)(n - k) / (REAL)(k + 1);
    REAL d = inv_beta;
    for (int k = 1; k < p; ++k) d *= t;
    for (int k = 1; k < q; ++k) d *= u;
    *jac = d;
    return x;
}

#endif /* BRDFTAB_GAUSS_LEGENDRE_H */

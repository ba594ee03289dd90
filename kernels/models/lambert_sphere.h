/*
 * lambert_sphere.h — half space of Lambertian spheres (d'Eon).
 *
 * E. d'Eon, "An analytic BRDF for materials with spherical Lambertian
 * scatterers", Computer Graphics Forum 40(4) (EGSR 2021).  Equation numbers
 * are that paper's; its symbols and the equations as implemented, with every
 * correction, are in docs/models/lambert-sphere.md.
 *
 * Geometry: a semi-infinite, optically thick, plane-parallel medium of
 * sparse, independently placed Lambertian spheres of diffuse albedo c
 * (= single-scattering albedo), no boundary reflection.  Depth tau in optical
 * units (unit extinction).  Directions point away from the surface (n = +z),
 * phi = phi_o - phi_i, phi = 0 is back-scattering (viewer on the light's side).
 *
 * Point p[]:  p[0..3] theta_i, phi_i, theta_o, phi_o (radians),
 *             p[4] c, p[5] order, p[6] max_order, p[7] mode, p[8] tail_order;
 *             brdf_analytic and brdf_three_term also p[9..28]: the exact
 *             l, m, A..F at c and exact H-functions at mu_i, mu_o (derived
 *             slots LS_DERIVED_K, LS_DERIVED_H, filled by the host:
 *             ls_fill_derived).
 * Options o[]: o[0] phase_mc   0 exact (eq. 1, sampled with eq. 5),
 *                              1 three-term (eqs. 2, 8: A0..A2 only; sampled
 *                                uniformly with a signed weight 4 pi p3,
 *                                because p3 < 0 near forward scattering)
 *              o[1] cos_phi    analytic/fit: weight of the multiple-scattering
 *                              cos(phi) mode fm1 = eq. 22 - eq. 28 in eq. 12:
 *                              0 "corrected" (x2, default: what the Monte Carlo
 *                              reference measures), 1 "paper" (x1, as printed)
 *                              — see docs/models/lambert-sphere.md
 *              o[2] fm1        brdf_fit: 0 eq. 22 - eq. 28 with fitted H1, l, m;
 *                              1 the fast fit eq. 29
 *              o[3] h1_fit     brdf_fit: 0 eqs. 23-25 as printed,
 *                              1 normalised: H1(1) Hc1(mu)/Hc1(1),
 *                              2 power: H1(1)^(mu^e(mu)) (our reading)
 *              o[4] constants  brdf_analytic, constant: l, m, A..F
 *                              0 exact (hc_constants, horak_chandrasekhar.h),
 *                              1 the paper's fits (eqs. 26-27, 33-37)
 *              o[5] constant   constant: which one, 0..7 = l, m, A, B, C, D, E, F
 *
 * Quantities (ids):
 *   0 phase          p(cos theta_o): theta_o is the SCATTERING angle
 *                    (0 = forward), eq. 1.  1/sr.
 *   1 brdf_mc        exact BRDF by random walk with next-event estimation
 *                    (unbiased; truncated at max_order scatterings).
 *   2 albedo_mc      directional albedo E(mu_i) by random walk.
 *   3 brdf_analytic  eqs. 9-12, 22, 28, 30, 33, 38 with EXACT H0, H1
 *                    (hfunction.h) and exact l, m, A..F (o[4] = 0, from the
 *                    psi-function system in horak_chandrasekhar.h) or the
 *                    paper's fits (o[4] = 1: eqs. 26-27, 33-37).
 *   4 brdf_fit       eqs. 9-12 with fitted H0 (eq. 31), H1 (eqs. 23-25) and
 *                    fitted constants: the paper's model as a formula.
 *   5 brdf_fast      eq. 41 with kd from eq. 40.
 *   6 brdf_single    eq. 10 (exact single scattering).
 *   7 kd_fit         eq. 40 (spherical albedo from c).
 *   8 kd_mc          spherical (bond) albedo 2 int E(mu) mu dmu by random walk.
 *   9 c_fit          eq. 39 (c from kd; kd is read from the c slot p[4]).
 *  10 brdf_three_term  exact single scattering (eq. 10) + the EXACT multiple
 *                    scattering of the three-term phase function (eq. 8):
 *                    modes 0, 1 with exact H and constants (cos phi mode at
 *                    its exact weight, 2 x eq. 22) and mode 2, which eq. 21
 *                    drops.  Its distance to brdf_mc is the 3-term phase
 *                    truncation alone.
 *  11 constant       one of l, m, A..F (o[5]) at c, exact or fitted (o[4]).
 *
 * Scattering orders (brdf_mc, albedo_mc, kd_mc): order = 0 sums orders
 * 1..max_order, order = -1 sums orders 2..max_order (multiple scattering
 * only), order = k >= 1 gives order k alone.  The walk itself does not
 * depend on c; order k carries the factor c^k exactly, so a table at c = 1
 * per order gives every c by multiplying with c^k.
 * Truncation remainder (order = -2):
 *   albedo_mc, kd_mc: the weight of the walks still inside the medium after
 *     max_order scatterings.  It bounds the energy the truncated tallies miss
 *     (part of it would later be absorbed); at c = 1 nothing is absorbed, so
 *     albedo(order 0) + remainder = 1 walk by walk.
 *   brdf_mc: the next-event BRDF of orders max_order+1 .. tail_order of the
 *     same walk (the walk continues past max_order), so sample by sample
 *     order 0 up to tail_order = order 0 up to max_order + remainder.  The
 *     Russian roulette of the summed tallies (LS_RR_WEIGHT) applies, so at
 *     c < 1 the walks end early.  tail_order <= max_order is invalid: the
 *     host rejects it (check_point), the kernel returns NaN.
 *   tail_order (p[8]) is read by brdf_mc with order = -2 only.
 *
 * Fourier modes (mode = p[7]): -1 the value at the given phi; m = 0, 1, 2 the
 * coefficient f^(m)(mu_i, mu_o) of eq. 9 (f = sum_m f^(m) cos(m phi)):
 * f^(0) = (1/pi) int_0^pi f dphi, f^(m) = (2/pi) int_0^pi f cos(m phi) dphi.
 * brdf_mc samples phi uniformly (dimension 0); the closed forms integrate
 * with the midpoint rule in phi (spectrally accurate for smooth periodic f).
 *
 * Random dimensions of the walk: 0 phi (modes) or mu_i (kd_mc), 1 first free
 * path, then 6 per collision (3 for eq. 5, 1 azimuth, 1 free path, 1 for
 * Russian roulette).
 * Dimensions >= 8 come from Philox (sampler.h).
 */
#ifndef BRDFTAB_LAMBERT_SPHERE_H
#define BRDFTAB_LAMBERT_SPHERE_H

#include "../common/compat.h"
#include "../common/bt_math.h"
#include "../common/sampler.h"
#include "../common/vec3.h"
#include "hfunction.h"
#include "horak_chandrasekhar.h"

#define LS_Q_PHASE 0
#define LS_Q_BRDF_MC 1
#define LS_Q_ALBEDO_MC 2
#define LS_Q_BRDF_ANALYTIC 3
#define LS_Q_BRDF_FIT 4
#define LS_Q_BRDF_FAST 5
#define LS_Q_BRDF_SINGLE 6
#define LS_Q_KD_FIT 7
#define LS_Q_KD_MC 8
#define LS_Q_C_FIT 9
#define LS_Q_BRDF_THREE_TERM 10
#define LS_Q_CONSTANT 11

/* The model contract: slots of the point p[] and of the options o[] and the
 * number of quantities (ids LS_Q_* above).  host/models/lambert_sphere.cpp registers
 * the model by these names; p[0..3] are the directions (estimator.h). */
#define LS_PARAM_C 4
#define LS_PARAM_ORDER 5
#define LS_PARAM_MAX_ORDER 6
#define LS_PARAM_MODE 7
#define LS_PARAM_TAIL_ORDER 8
#define LS_PARAM_COUNT 5
#define LS_OPT_PHASE_MC 0
#define LS_OPT_COS_PHI 1
#define LS_OPT_FM1 2
#define LS_OPT_H1_FIT 3
#define LS_OPT_CONSTANTS 4
#define LS_OPT_CONSTANT 5
#define LS_OPT_COUNT 6
#define LS_Q_COUNT 12

/* Per-cell invariants carried in the point (the model contract's derived
 * slots, host/models/registry.h) for brdf_analytic and brdf_three_term:
 *  - the exact constants l, m, A..F (constants "exact"; three_term always)
 *    depend on c alone and cost 0.5 ms (c < 0.9975) to 6 ms (above) per
 *    solve; solved in the kernel they would be recomputed in every cell and
 *    both quadrature batches (80 % of such a table's time):
 *    p[LS_DERIVED_K + j], j = 0..7 in hc_constants' order;
 *  - the exact H-functions at mu_i and mu_o depend on (mu, c) alone, a
 *    quadrature of ~600 nodes each (96 % of the time once the constants are
 *    hoisted): p[LS_DERIVED_H + 6 b + j], b = 0 for the accurate rule (batch
 *    0), 1 for the coarse one (batch 1), j = 0..5: H0(mi), H0(mo), H1(mi),
 *    H1(mo), H2(mi), H2(mo) (H2: three_term only).
 * The host computes them once per distinct c and (mu, c) (ls_fill_derived)
 * and appends them after the parameters; slots a quantity does not read are
 * 0. */
#define LS_DERIVED_K (4 + LS_PARAM_COUNT)
#define LS_DERIVED_H (LS_DERIVED_K + 8)
#define LS_DERIVED_COUNT 20

/* Smallest mu_o used by the next-event estimator: exp(-tau/mu_o)/mu_o has
 * unbounded variance as mu_o -> 0 (the mean stays finite). */
#define LS_MIN_MU R(1e-6)
/* Summed tallies (order <= 0): once c^k falls below LS_RR_WEIGHT the walk
 * switches from weighting by c to analog absorption (continue with
 * probability c, weight unchanged): unbiased Russian roulette that ends the
 * long walks of c < 1 early.  Per-order tallies (order >= 1) never use it, so
 * they scale exactly as c^k.  At c = 1 it never triggers. */
#define LS_RR_WEIGHT R(0.05)

/* ------------------------------------------------------- phase function */

/* eq. 1; mu = cosine of the scattering angle (1 = forward). */
BT_INLINE REAL ls_phase(REAL mu)
{
    mu = bt_clamp(mu, -R(1.0), R(1.0));
    return R(2.0) * (bt_safe_sqrt(R(1.0) - mu * mu) - mu * bt_acos(mu)) / (R(3.0) * BT_PI * BT_PI);
}

/* Three-term Legendre truncation (eqs. 2, 4, 8 with A_k = 0 for k >= 3). */
BT_INLINE REAL ls_phase3(REAL mu)
{
    REAL p2 = R(0.5) * (R(3.0) * mu * mu - R(1.0));
    return (R(1.0) - R(4.0) / R(3.0) * mu + R(5.0) / R(16.0) * p2) * R(0.25) * BT_INV_PI;
}

/* eq. 5: exact sample of the scattering cosine. */
BT_INLINE REAL ls_sample_exact(REAL u1, REAL u2, REAL u3)
{
    return sqrt((R(1.0) - u1) * (R(1.0) - u2)) * bt_sin(BT_TWO_PI * u3) - sqrt(u1 * u2);
}

/* eq. 6: approximate inverse CDF (|error| < 5e-4 per the paper). */
BT_INLINE REAL ls_sample_approx(REAL u)
{
    if (!(u > R(0.0))) return -R(1.0);
    REAL e = R(0.0401885) * u + R(1.01938);
    REAL inner = R(1.0) - bt_exp(e * bt_log(u));
    if (!(inner > R(0.0))) return R(1.0);
    return R(1.0) - R(2.0) * bt_exp(R(0.397225) * bt_log(inner));
}

/* Direction with cosine mu to d and azimuth 2 pi u about it. */
BT_INLINE bt_vec3 ls_rotate(bt_vec3 d, REAL mu, REAL u)
{
    /* orthonormal basis (Frisvad-style, with the sign trick for d.z < 0) */
    REAL sgn = d.z >= R(0.0) ? R(1.0) : -R(1.0);
    REAL a = -R(1.0) / (sgn + d.z);
    REAL b = d.x * d.y * a;
    bt_vec3 t1 = bt_v3(R(1.0) + sgn * d.x * d.x * a, sgn * b, -sgn * d.x);
    bt_vec3 t2 = bt_v3(b, sgn + d.y * d.y * a, -d.y);
    REAL st = bt_safe_sqrt(R(1.0) - mu * mu);
    REAL ph = BT_TWO_PI * u;
    return bt_v3_normalize(bt_v3_add(bt_v3_scale(d, mu),
                                     bt_v3_add(bt_v3_scale(t1, st * bt_cos(ph)),
                                               bt_v3_scale(t2, st * bt_sin(ph)))));
}

#define LS_ORDER_REMAINDER (-2)

/* Whether collision k is tallied.  order = -2: albedo tallies only at the
 * truncation (ls_walk); the BRDF tallies the orders after max_order. */
BT_INLINE int ls_tally(int order, int k, int max_order, int want_brdf)
{
    /* order 0: all; -2: remainder; other negative: k >= 2; positive: k alone.
     * Written without branches: a chain of tests on order became a switch,
     * which keeps the walk-parallel kernel's work-item loop scalar. */
    int remainder = order == LS_ORDER_REMAINDER;
    return (order == 0) | (remainder & (want_brdf != 0) & (k > max_order)) |
           ((order < 0) & !remainder & (k >= 2)) | ((order > 0) & (k == order));
}

/* ---------------------------------------------------------- random walk */

/* The six random words of the collision whose first dimension is `dim`
 * (dims dim .. dim + 5; dim = 2 + 6 (k - 1) is even), for bt_u32_to_unit.
 * Monte Carlo: the words of the two Philox blocks that hold them (counters
 * (cell, batch, sample, dim / 4) and the next), each block computed once
 * instead of once per word as bt_uniform does: the same words (sampler.h),
 * a third of the Philox rounds.  RQMC: the same from dimension
 * BT_SOBOL_DIMS on (collisions k >= 2), where bt_uniform falls back to
 * Philox; below it (collision 1) w[] is unused and ls_collision_u calls
 * bt_uniform (Sobol'). */
typedef struct {
    uint w[6];
} ls_collision_words;

BT_INLINE void ls_collision_draw(const bt_sampler* s, uint dim, ls_collision_words* r)
{
    if (s->method != BT_METHOD_MC && dim < BT_SOBOL_DIMS) { /* unused; set, written out */
        r->w[0] = r->w[1] = r->w[2] = r->w[3] = r->w[4] = r->w[5] = 0u;
        return;
    }
    uint a[4], b[4];
    bt_philox4x32_10(s->cell, s->batch, s->sample, dim >> 2, s->key0, s->key1, a);
    bt_philox4x32_10(s->cell, s->batch, s->sample, (dim >> 2) + 1u, s->key0, s->key1, b);
    if (dim & 2u) { /* dim = 4 n + 2: words 2, 3 of block n, then block n + 1 */
        r->w[0] = a[2];
        r->w[1] = a[3];
        r->w[2] = b[0];
        r->w[3] = b[1];
        r->w[4] = b[2];
        r->w[5] = b[3];
    } else {
        r->w[0] = a[0];
        r->w[1] = a[1];
        r->w[2] = a[2];
        r->w[3] = a[3];
        r->w[4] = b[0];
        r->w[5] = b[1];
    }
}

/* Uniform j (0..5) of the collision: bt_uniform(s, dim + j). */
BT_INLINE REAL ls_collision_u(const bt_sampler* s, uint dim, const ls_collision_words* r, uint j)
{
    if (s->method == BT_METHOD_MC || dim >= BT_SOBOL_DIMS) return bt_u32_to_unit(r->w[j]);
    return bt_uniform(s, dim + j);
}

/* One walk from direction i (light arrives along -i), as a state machine so
 * that a walk can advance one collision at a time (the walk-parallel kernel,
 * kernels/common/walk_parallel.h, interleaves the walks of a work group that
 * way); ls_walk below runs it to the end.
 * want_brdf != 0: next-event estimate of f(i, o) summed over the tallied
 * orders; else the escape tally (albedo).  tail_order: last order of the
 * BRDF remainder (want_brdf, order = -2; must exceed max_order).
 * `total` is the sample once the walk has ended; `weight` multiplies it
 * (brdf_mc's Fourier weight, ls_brdf_mc_begin). */
typedef struct {
    bt_vec3 d;   /* direction of flight */
    REAL mu_o;   /* cos theta_o, floored at LS_MIN_MU */
    REAL w;      /* product of the signed 3-term weights (phase3 only) */
    REAL ck;     /* c^k, until Russian roulette takes over */
    REAL tau;    /* depth of the current collision */
    REAL total;  /* the tally so far */
    REAL weight; /* factor of the sample (brdf_mc) */
    int k;       /* the next collision's order */
    int last;    /* the last order the walk may reach */
} ls_walk_state;

/* Starts the walk: the first free path (dimension 1). */
BT_INLINE void ls_walk_begin(ls_walk_state* st, bt_vec3 i, bt_vec3 o, int order, int max_order,
                             int tail_order, int want_brdf, const bt_sampler* s)
{
    st->mu_o = fmax(o.z, LS_MIN_MU);
    st->d = bt_v3_neg(i);
    st->w = R(1.0);
    st->ck = R(1.0);
    st->tau = -bt_log(R(1.0) - bt_uniform(s, 1u)) * (-st->d.z);
    st->total = R(0.0);
    st->weight = R(1.0);
    st->last = order > 0 ? order : max_order;
    if (want_brdf && order == LS_ORDER_REMAINDER) st->last = tail_order; /* continue the walk */
    st->k = 1;
}

/* Collision st->k of the walk (dimensions 2 + 6 (k - 1) .. + 5): returns 1
 * when the walk has ended (absorbed, escaped or truncated), else 0 with
 * st->k the next collision. */
BT_INLINE int ls_walk_step(ls_walk_state* st, bt_vec3 o, REAL c, int order, int max_order,
                           int phase3, int want_brdf, const bt_sampler* s)
{
    const int k = st->k;
    const int last = st->last;
    if (k > last) return 1;
    uint dim = 2u + 6u * (uint)(k - 1);
    ls_collision_words r;
    ls_collision_draw(s, dim, &r);
    if (order <= 0 && st->ck < LS_RR_WEIGHT) {
        if (ls_collision_u(s, dim, &r, 5u) >= c) return 1; /* absorbed */
    } else {
        st->ck *= c;
    }
    if (want_brdf && ls_tally(order, k, max_order, 1)) {
        REAL mu = bt_v3_dot(st->d, o);
        REAL p = phase3 ? ls_phase3(mu) : ls_phase(mu);
        st->total += st->w * st->ck * p * bt_exp(-st->tau / st->mu_o) / st->mu_o;
    }
    if (want_brdf && k == last) return 1;
    REAL mu_s;
    if (phase3) {
        mu_s = R(1.0) - R(2.0) * ls_collision_u(s, dim, &r, 0u);
        st->w *= R(4.0) * BT_PI * ls_phase3(mu_s);
    } else {
        mu_s = ls_sample_exact(ls_collision_u(s, dim, &r, 0u), ls_collision_u(s, dim, &r, 1u),
                               ls_collision_u(s, dim, &r, 2u)); /* eq. 5 */
    }
    st->d = ls_rotate(st->d, mu_s, ls_collision_u(s, dim, &r, 3u));
    st->tau -= -bt_log(R(1.0) - ls_collision_u(s, dim, &r, 4u)) * st->d.z;
    if (st->tau < R(0.0)) { /* escaped after scattering k */
        if (!want_brdf && ls_tally(order, k, max_order, 0)) st->total += st->w * st->ck;
        return 1;
    }
    if (k == last) { /* albedo: still inside after the last order */
        if (!want_brdf && order == LS_ORDER_REMAINDER) st->total += st->w * st->ck;
        return 1;
    }
    st->k = k + 1;
    return 0;
}

/* The whole walk; returns the sample (without st.weight). */
BT_INLINE REAL ls_walk(bt_vec3 i, bt_vec3 o, REAL c, int order, int max_order, int tail_order,
                       int phase3, int want_brdf, const bt_sampler* s)
{
    ls_walk_state st;
    ls_walk_begin(&st, i, o, order, max_order, tail_order, want_brdf, s);
    while (!ls_walk_step(&st, o, c, order, max_order, phase3, want_brdf, s)) {
    }
    return st.total;
}

/* ------------------------------------------------------ analytic model */

/* eq. 10 */
BT_INLINE REAL ls_single(bt_vec3 i, bt_vec3 o, REAL c)
{
    /* cosines floored at LS_MIN_MU: f1 diverges when both directions graze,
     * and cos(pi/2) rounds to +-6e-17 (double) / -4e-8 (float) */
    return c * ls_phase(-bt_v3_dot(i, o)) / (fmax(i.z, LS_MIN_MU) + fmax(o.z, LS_MIN_MU));
}

/* eq. 26 */
BT_INLINE REAL ls_l_fit(REAL c) { return -R(0.00473696) * c * c - R(0.0589037) * c; }
/* eq. 27 */
BT_INLINE REAL ls_m_fit(REAL c) { return R(0.44038) * c + R(1.0); }

/* The paper's fitted constants in the layout of hc_constants():
 * k[0..7] = l, m (eqs. 26-27), A (eq. 33), B, C, D (eqs. 34-36), E (eq. 33),
 * F (eq. 37).  hc_constants() gives the exact values (horak_chandrasekhar.h). */
BT_INLINE void ls_constants_fit(REAL c, REAL* k)
{
    REAL s = bt_safe_sqrt(R(1.0) - c);
    REAL s2 = s * s, s3 = s2 * s;
    k[HC_L] = ls_l_fit(c);
    k[HC_M] = ls_m_fit(c);
    k[HC_A] = R(69.0) * c / R(128.0);                                             /* A eq. 33 */
    k[HC_B] = (R(0.346689) * s3 - R(0.777574) * s2 + R(0.515357) * s - R(0.084463)) /
              (R(0.182602) * s2 - R(0.665502) * s + R(0.964893));                 /* B eq. 34 */
    k[HC_C] = (-R(5602.45) * s3 + R(7487.99) * s2 - R(2567.74) * s + R(682.848)) /
              (R(1480.25) * s2 - R(4008.33) * s + R(5850.6));                     /* C eq. 35 */
    k[HC_D] = (R(166.883) * s3 - R(327.428) * s2 + R(160.397) * s + R(0.285529)) /
              (R(596.423) * s2 - R(412.984) * s + R(674.191));                    /* D eq. 36 */
    k[HC_E] = R(15.0) / R(128.0) * (R(1.0) - c) * c * (R(4.0) * c / R(3.0) + R(3.0)); /* E eq. 33 */
    k[HC_F] = (R(266.063) * s3 - R(21.9141) * s2 - R(242.16) * s - R(1.9209)) /
              (R(215.773) * s2 + R(457.42) * s + R(1499.9));                      /* F eq. 37 */
}

/* The constants of eqs. 22 and 30: exact (hc_constants) or the paper's fits.
 * A failed exact solve (it has not happened on [0, 1]) gives NaN constants,
 * so that the cell shows it instead of a plausible wrong number. */
BT_INLINE void ls_constants(REAL c, int exact, REAL* k)
{
    if (!exact) {
        ls_constants_fit(c, k);
        return;
    }
    HC_REAL exact_k[8];
    int ok = hc_constants((HC_REAL)c, exact_k);
    for (int j = 0; j < 8; ++j) k[j] = ok < 0 ? NAN : (REAL)exact_k[j];
}

/* Whether (quantity, options) reads the derived slots (exact H-functions),
 * and among them the exact constants (LS_DERIVED_K): the rules the host
 * (derived slots) and the sample function share. */
BT_INLINE int ls_reads_derived(int quantity)
{
    return quantity == LS_Q_BRDF_THREE_TERM || quantity == LS_Q_BRDF_ANALYTIC;
}
BT_INLINE int ls_reads_derived_constants(int quantity, const int* o)
{
    return quantity == LS_Q_BRDF_THREE_TERM ||
           (quantity == LS_Q_BRDF_ANALYTIC && o[LS_OPT_CONSTANTS] == 0);
}

/* The cosines the analytic model evaluates at: floored as in ls_single. */
BT_INLINE REAL ls_mu_of(REAL theta) { return fmax(bt_cos(theta), LS_MIN_MU); }

/* Exact H-function `kind` (HF_PSI_LAMBERT0/1/2) at (mu, c), accurate rule
 * (coarse = 0) or the coarse one. */
BT_INLINE REAL ls_h_exact(int kind, REAL mu, REAL c, int coarse)
{
    REAL none[HF_NCOEF] = {R(0.0), R(0.0), R(0.0), R(0.0)};
    hf_psi P = hf_make_psi(kind, c, none);
    return hf_h(&P, mu, coarse);
}

/* Writes the exact constants at c into p[LS_DERIVED_K .. + 7] (the point
 * must have LS_DERIVED_K + LS_DERIVED_COUNT slots): the values ls_constants
 * gives, NaN on a failed solve. */
BT_INLINE void ls_fill_constants(REAL* p)
{
    ls_constants(p[LS_PARAM_C], 1, p + LS_DERIVED_K);
}

/* H-function slot j (0..5 of LS_DERIVED_H) of a rule holds H_{j/2} (kind
 * HF_PSI_LAMBERT0 + j/2) at mu_i (j even) or mu_o (j odd); a quantity reads
 * the first ls_h_slot_count of them (H2: brdf_three_term only). */
BT_INLINE int ls_h_slot_count(int quantity) { return quantity == LS_Q_BRDF_THREE_TERM ? 6 : 4; }
BT_INLINE int ls_h_slot_kind(int j) { return HF_PSI_LAMBERT0 + j / 2; }
BT_INLINE REAL ls_h_slot_mu(const REAL* p, int j) { return ls_mu_of(j % 2 == 0 ? p[0] : p[2]); }

/* Writes H-function slot j of rule b (0 accurate, 1 coarse) for the point's
 * directions and c. */
BT_INLINE void ls_fill_h(REAL* p, int b, int j)
{
    p[LS_DERIVED_H + 6 * b + j] = ls_h_exact(ls_h_slot_kind(j), ls_h_slot_mu(p, j), p[LS_PARAM_C], b);
}

/* Every derived slot quantity (and options o) reads, the others 0: what
 * the engine appends to the point (host/models/lambert_sphere.cpp memoises
 * the same values per c and (mu, c)). */
BT_INLINE void ls_fill_derived(REAL* p, int quantity, const int* o)
{
    for (int j = 0; j < LS_DERIVED_COUNT; ++j) p[LS_DERIVED_K + j] = R(0.0);
    if (!ls_reads_derived(quantity)) return;
    if (ls_reads_derived_constants(quantity, o)) ls_fill_constants(p);
    for (int b = 0; b < 2; ++b)
        for (int j = 0; j < ls_h_slot_count(quantity); ++j) ls_fill_h(p, b, j);
}

/* eq. 31 (a, d as printed; 1/H0(inf) = sqrt(K0(0)) from eq. 32). */
BT_INLINE REAL ls_h0_fit(REAL mu, REAL c)
{
    REAL s = bt_safe_sqrt(R(1.0) - c);
    REAL s6 = s > R(0.0) ? bt_exp(R(6.05435) * bt_log(s)) : R(0.0);
    REAL s96 = s > R(0.0) ? bt_exp(R(0.961546) * bt_log(s)) : R(0.0);
    REAL s7 = s * s * s * s * s * s * s;
    REAL a = (R(1.50112) * s6 + R(8.21644)) / (R(4.17593) - R(1.21222) * s);
    REAL d = (R(7.7731) - R(0.565811) * s96) / (R(8.65912) - R(0.159974) * s7);
    REAL inv_hinf = bt_safe_sqrt((c - R(16.0)) * (c - R(1.0)) * (R(4.0) * c + R(9.0))) / R(12.0);
    REAL amd = mu > R(0.0) ? a * bt_exp(d * bt_log(mu)) : R(0.0);
    return (R(1.0) + amd) / (R(1.0) + amd * inv_hinf);
}

/* eqs. 23-25.  variant 0: as printed, H1(1) Hc1(mu) — eq. 24 as printed has
 * Hc1(1) = exp(-0.0894878) = 0.914 although the exact H1 at c = 1 has
 * H1(1) = 0.886, and the product misses H1 by up to 11 %.  Variant 1: the
 * printed form divided by Hc1(1).  Variant 2 (our reading, not the paper's):
 * H1(mu) = H1(1)^(mu^e(mu)) with e(mu) the cubic exponent of eq. 24 and
 * H1(1) from eq. 25 — the exponent's shape mu^e(mu) matches
 * log H1(mu) / log H1(1) closely; see the doc for the measured errors. */
BT_INLINE REAL ls_h1_fit(REAL mu, REAL c, int variant)
{
    REAL e = ((-R(1.12831) * mu + R(1.85728)) * mu - R(1.07879)) * mu + R(0.459442);
    REAL mue = mu > R(0.0) ? bt_exp(e * bt_log(mu)) : R(0.0);
    REAL log_h11 = R(0.0242851) * c * c - R(0.144839) * c; /* eq. 25 */
    if (variant == 2) return bt_exp(log_h11 * mue);
    REAL hc1 = bt_exp(-R(0.0894878) * mue);                    /* eq. 24 */
    REAL norm = variant == 1 ? bt_exp(R(0.0894878)) : R(1.0);  /* 1/Hc1(1) */
    return bt_exp(log_h11) * hc1 * norm;                       /* eq. 23 */
}

/* eq. 22 as printed (prefactor c/(6 pi)); the exact cos(phi) coefficient is
 * twice this (hc_f1, derived in horak_chandrasekhar.h). */
BT_INLINE REAL ls_f1_mode(REAL mi, REAL mo, REAL c, REAL h1i, REAL h1o, const REAL* k)
{
    return R(0.5) * hc_f1(mi, mo, h1i, h1o, c, k);
}

/* eq. 28: single-scattering part subtracted from f^(1). */
BT_INLINE REAL ls_ss1(REAL mi, REAL mo, REAL c)
{
    REAL S = bt_safe_sqrt((R(1.0) - mi * mi) * (R(1.0) - mo * mo));
    return c * (R(45.0) * mi * mo + R(64.0)) * S / (R(384.0) * BT_PI * (mi + mo));
}

/* eq. 38: single-scattering part subtracted from f^(0). */
BT_INLINE REAL ls_ss0(REAL mi, REAL mo, REAL c)
{
    return c * (R(45.0) * mi * mi * (R(3.0) * mo * mo - R(1.0)) + R(256.0) * mi * mo -
                R(45.0) * mo * mo + R(207.0)) /
           (R(768.0) * BT_PI * (mi + mo));
}

/* eq. 29: fast fit of fm1. */
BT_INLINE REAL ls_fm1_fast(REAL mi, REAL mo, REAL c)
{
    REAL S = bt_safe_sqrt((R(1.0) - mi * mi) * (R(1.0) - mo * mo));
    return -R(0.0117) * c * bt_atan(c) * S * sqrt(tanh(mi + mi * mo + mo)) / (mi + mo);
}

/* eq. 40 */
BT_INLINE REAL ls_kd_fit(REAL c)
{
    REAL s = bt_safe_sqrt(R(1.0) - c);
    return (-R(0.453029) * (R(1.0) - c) - R(0.544162) * s + R(1.0)) / (R(1.42931) * s + R(1.0));
}

/* eq. 39.  Departure: as printed the fit goes negative for kd below
 * 1 - 1.00425^(-1/2.67103) = 0.00159 (c = -0.0054 at kd = 0), where its
 * numerator changes sign; c is an albedo, so the result is clamped to 0
 * there (docs/models/lambert-sphere.md). */
BT_INLINE REAL ls_c_fit(REAL kd)
{
    REAL x = R(1.0) - kd;
    REAL a = x > R(0.0) ? bt_exp(R(2.67103) * bt_log(x)) : R(0.0);
    REAL b = x > R(0.0) ? bt_exp(R(2.44559) * bt_log(x)) : R(0.0);
    return fmax((R(1.0) - R(1.00425) * a) / (R(1.0) - R(0.219924) * b), R(0.0));
}

/* eq. 41 (phi in [-pi, pi]). */
BT_INLINE REAL ls_fast(bt_vec3 i, bt_vec3 o, REAL c, REAL phi)
{
    REAL mi = fmax(i.z, LS_MIN_MU), mo = fmax(o.z, LS_MIN_MU);
    REAL S = bt_safe_sqrt(R(1.0) - mi * mi) * bt_safe_sqrt(R(1.0) - mo * mo);
    REAL kd = ls_kd_fit(c);
    REAL term = R(0.0);
    if (S > R(1e-12)) /* acos(S)/S -> inf as S -> 0: the term vanishes */
        term = R(0.0151829) * (c - R(0.249978)) * (fabs(phi) + sqrt(mi * mo)) /
               (bt_acos(fmin(S, R(1.0))) / S + R(0.113706));
    REAL kdp = kd > R(0.0) ? bt_exp(R(1.85432) * bt_log(kd)) : R(0.0);
    return fmax(R(0.0), ls_single(i, o, c) + term + R(0.234459) * kdp);
}

/* Multiple-scattering modes fm0 (eq. 30 - eq. 38) and fm1 (eq. 22 - eq. 28,
 * the printed normalisation: callers double it for the exact mode), with
 * H-functions exact (fitted = 0: exact_h = H0(mi), H0(mo), H1(mi), H1(mo)
 * from the derived slots) or fitted (fitted = 1) and the constants l, m, A..F
 * exact (exact_k: the solved constants, p + LS_DERIVED_K) or the paper's fits
 * (exact_k = 0). */
BT_INLINE void ls_ms_modes(REAL mi, REAL mo, REAL c, int fitted, const REAL* exact_h,
                           const REAL* exact_k, int fm1_choice, int h1_norm, REAL* fm0,
                           REAL* fm1)
{
    REAL h0i, h0o, h1i, h1o;
    if (fitted) {
        h0i = ls_h0_fit(mi, c);
        h0o = ls_h0_fit(mo, c);
        h1i = ls_h1_fit(mi, c, h1_norm);
        h1o = ls_h1_fit(mo, c, h1_norm);
    } else {
        h0i = exact_h[0];
        h0o = exact_h[1];
        h1i = exact_h[2];
        h1o = exact_h[3];
    }
    REAL fitted_k[8];
    if (!exact_k) ls_constants_fit(c, fitted_k);
    const REAL* k = exact_k ? exact_k : fitted_k;
    *fm0 = hc_f0(mi, mo, h0i, h0o, k) - ls_ss0(mi, mo, c); /* eqs. 30, 38 */
    if (fitted && fm1_choice == 1)
        *fm1 = ls_fm1_fast(mi, mo, c);
    else
        *fm1 = ls_f1_mode(mi, mo, c, h1i, h1o, k) - ls_ss1(mi, mo, c); /* eqs. 22, 28 */
}

/* cos(2 phi) coefficient of the three-term single scattering: with the
 * addition theorem P2(cos Theta) contains (3/4)(1 - mi^2)(1 - mo^2) cos 2phi,
 * so c p3 / (mi + mo) has 15 c (1 - mi^2)(1 - mo^2) / (256 pi (mi + mo)) —
 * the c -> 0 limit of hc_f2 (H2 -> 1). */
BT_INLINE REAL ls_ss2(REAL mi, REAL mo, REAL c)
{
    return hc_f2(mi, mo, R(1.0), R(1.0), c);
}

/* Exact multiple scattering of the three-term phase function, mode 2
 * (dropped by eq. 21): hc_f2 minus its single-scattering part, with
 * H2(mi), H2(mo) from the derived slots. */
BT_INLINE REAL ls_ms_mode2(REAL mi, REAL mo, REAL c, REAL h2i, REAL h2o)
{
    return hc_f2(mi, mo, h2i, h2o, c) - ls_ss2(mi, mo, c);
}

/* Fourier mode m of f1 (eq. 10) by the midpoint rule over phi in [0, pi]. */
BT_INLINE REAL ls_single_mode(REAL ti, REAL to, REAL c, int m)
{
    const int n = 96;
    REAL sum = R(0.0);
    bt_vec3 i = bt_from_spherical(ti, R(0.0));
    for (int k = 0; k < n; ++k) {
        REAL ph = BT_PI * ((REAL)k + R(0.5)) / (REAL)n;
        bt_vec3 o = bt_from_spherical(to, ph);
        sum += ls_single(i, o, c) * bt_cos((REAL)m * ph);
    }
    return sum / (REAL)n * (m == 0 ? R(1.0) : R(2.0));
}

BT_INLINE REAL ls_wrap_phi(REAL phi)
{
    phi = phi - BT_TWO_PI * floor(phi / BT_TWO_PI); /* [0, 2 pi) */
    return phi > BT_PI ? phi - BT_TWO_PI : phi;
}

/* ------------------------------------------- brdf_mc, one collision at a time */

/* brdf_mc's sample as setup / begin / step / value, the form the
 * walk-parallel kernel (kernels/common/walk_parallel.h) runs;
 * lambert_sphere_sample runs the same functions in a loop, so both give the
 * same bits.  setup reads the point once per work item (whole-number
 * parameters, the incident direction); begin and step run per sample and
 * per collision. */
typedef struct {
    ls_walk_state walk;
    bt_vec3 i0;     /* incident direction at phi_i = 0 */
    bt_vec3 o;      /* the outgoing direction of this sample */
    REAL c;
    int order, max_order, mode, tail_order;
    int known;      /* 1: every sample is 0 (below the horizon) or NaN (invalid range) */
} ls_brdf_mc_state;

BT_INLINE void ls_brdf_mc_setup(const REAL* p, const int* o, int quantity, ls_brdf_mc_state* st)
{
    (void)o;
    (void)quantity;
    st->c = p[LS_PARAM_C];
    st->order = (int)floor(p[LS_PARAM_ORDER] + R(0.5));
    st->max_order = (int)floor(p[LS_PARAM_MAX_ORDER] + R(0.5));
    st->mode = (int)floor(p[LS_PARAM_MODE] + R(0.5));
    st->tail_order = (int)floor(p[LS_PARAM_TAIL_ORDER] + R(0.5));
    st->i0 = bt_from_spherical(p[0], R(0.0));
    /* phi_o - phi_i fixed (mode -1): the outgoing direction of every sample */
    st->o = bt_from_spherical(p[2], ls_wrap_phi(p[3] - p[1]));
    /* Reflection only: directions below the horizon give 0. */
    st->known = p[0] > BT_HALF_PI || p[2] > BT_HALF_PI ||
                (st->order == LS_ORDER_REMAINDER && st->tail_order <= st->max_order);
}

/* Starts sample s->sample; returns 1 when the sample is known already
 * (directions below the horizon: 0; invalid remainder range: NaN). */
BT_INLINE int ls_brdf_mc_begin(const REAL* p, const int* o, int quantity, const bt_sampler* s,
                               ls_brdf_mc_state* st)
{
    (void)o;
    (void)quantity;
    if (st->known) {
        st->walk.weight = R(1.0);
        st->walk.total = p[0] > BT_HALF_PI || p[2] > BT_HALF_PI ? R(0.0) : R(0.0) / R(0.0);
        return 1;
    }
    REAL weight = R(1.0);
    if (st->mode >= 0) { /* Fourier coefficient: phi uniform on [0, pi] */
        REAL phi = BT_PI * bt_uniform(s, 0u);
        weight = st->mode == 0 ? R(1.0) : R(2.0) * bt_cos((REAL)st->mode * phi);
        st->o = bt_from_spherical(p[2], phi);
    }
    ls_walk_begin(&st->walk, st->i0, st->o, st->order, st->max_order, st->tail_order, 1, s);
    st->walk.weight = weight;
    return 0;
}

/* The next collision of the walk ls_brdf_mc_begin started; 1 when it ended. */
BT_INLINE int ls_brdf_mc_step(const REAL* p, const int* o, int quantity, const bt_sampler* s,
                              ls_brdf_mc_state* st)
{
    (void)p;
    (void)quantity;
    return ls_walk_step(&st->walk, st->o, st->c, st->order, st->max_order, o[LS_OPT_PHASE_MC], 1, s);
}

/* The sample, once the walk has ended. */
BT_INLINE REAL ls_brdf_mc_value(const ls_brdf_mc_state* st)
{
    return st->walk.weight * st->walk.total;
}

/* ------------------------------------------------------------ sample fn */
BT_INLINE REAL lambert_sphere_sample(const REAL* p, const int* o, int quantity,
                                     const bt_sampler* s)
{
    REAL c = p[LS_PARAM_C];
    int order = (int)floor(p[LS_PARAM_ORDER] + R(0.5));
    int max_order = (int)floor(p[LS_PARAM_MAX_ORDER] + R(0.5));
    int mode = (int)floor(p[LS_PARAM_MODE] + R(0.5));
    int tail_order = (int)floor(p[LS_PARAM_TAIL_ORDER] + R(0.5));
    if (quantity == LS_Q_PHASE) return ls_phase(bt_cos(p[2]));
    if (quantity == LS_Q_KD_FIT) return ls_kd_fit(c);
    if (quantity == LS_Q_C_FIT) return ls_c_fit(c);
    if (quantity == LS_Q_CONSTANT) { /* o[LS_OPT_CONSTANTS] constants, o[LS_OPT_CONSTANT] which (l, m, A..F) */
        REAL k[8];
        ls_constants(c, o[LS_OPT_CONSTANTS] == 0, k);
        return k[o[LS_OPT_CONSTANT]];
    }
    if (quantity == LS_Q_KD_MC) {
        REAL mi = sqrt(R(1.0) - bt_uniform(s, 0u)); /* cosine-weighted mu_i */
        bt_vec3 i = bt_v3(bt_safe_sqrt(R(1.0) - mi * mi), R(0.0), mi);
        return ls_walk(i, i, c, order, max_order, tail_order, o[LS_OPT_PHASE_MC], 0, s);
    }
    /* Reflection only: directions below the horizon give 0. */
    if (p[0] > BT_HALF_PI) return R(0.0);
    bt_vec3 i = bt_from_spherical(p[0], p[1]);
    if (quantity == LS_Q_ALBEDO_MC)
        return ls_walk(i, i, c, order, max_order, tail_order, o[LS_OPT_PHASE_MC], 0, s);
    if (p[2] > BT_HALF_PI) return R(0.0);
    REAL phi = ls_wrap_phi(p[3] - p[1]);
    if (quantity == LS_Q_BRDF_MC) {
        ls_brdf_mc_state st;
        ls_brdf_mc_setup(p, o, quantity, &st);
        if (!ls_brdf_mc_begin(p, o, quantity, s, &st))
            while (!ls_brdf_mc_step(p, o, quantity, s, &st)) {
            }
        return ls_brdf_mc_value(&st);
    }
    /* side from theta (above), cosines floored as in ls_single */
    REAL mi = ls_mu_of(p[0]), mo = ls_mu_of(p[2]);
    if (quantity == LS_Q_BRDF_SINGLE) {
        if (mode >= 0) return ls_single_mode(p[0], p[2], c, mode);
        return ls_single(i, bt_from_spherical(p[2], p[3]), c);
    }
    if (quantity == LS_Q_BRDF_FAST) {
        if (mode >= 0) { /* eq. 41 has no mode structure: integrate over phi */
            const int n = 96;
            REAL sum = R(0.0);
            bt_vec3 i0 = bt_from_spherical(p[0], R(0.0));
            for (int k = 0; k < n; ++k) {
                REAL ph = BT_PI * ((REAL)k + R(0.5)) / (REAL)n;
                sum += ls_fast(i0, bt_from_spherical(p[2], ph), c, ph) * bt_cos((REAL)mode * ph);
            }
            return sum / (REAL)n * (mode == 0 ? R(1.0) : R(2.0));
        }
        return ls_fast(i, bt_from_spherical(p[2], p[3]), c, phi);
    }
    if (quantity == LS_Q_BRDF_ANALYTIC || quantity == LS_Q_BRDF_FIT ||
        quantity == LS_Q_BRDF_THREE_TERM) {
        int coarse = (s->method == BT_METHOD_QUADRATURE && s->batch == 1u) ? 1 : 0;
        int fitted = quantity == LS_Q_BRDF_FIT;
        int three = quantity == LS_Q_BRDF_THREE_TERM;
        /* exact constants and H-functions of this rule: computed once per
         * c and (mu, c) on the host (LS_DERIVED_K, LS_DERIVED_H) */
        const REAL* exact_k = ls_reads_derived_constants(quantity, o) ? p + LS_DERIVED_K : 0;
        const REAL* exact_h = p + LS_DERIVED_H + 6 * coarse;
        REAL fm0, fm1;
        ls_ms_modes(mi, mo, c, fitted, exact_h, exact_k, o[LS_OPT_FM1], o[LS_OPT_H1_FIT], &fm0,
                    &fm1);
        /* cos_phi: 0 corrected (x2, = the exact mode), 1 paper (x1);
         * brdf_three_term is exact: always x2, plus mode 2. */
        REAL w1 = (o[LS_OPT_COS_PHI] == 1 && !three) ? R(1.0) : R(2.0);
        REAL fm2 = three ? ls_ms_mode2(mi, mo, c, exact_h[4], exact_h[5]) : R(0.0); /* eq. 21 drops it */
        if (mode >= 0) {
            REAL ms = mode == 0 ? fm0 : mode == 1 ? w1 * fm1 : mode == 2 ? fm2 : R(0.0);
            return ls_single_mode(p[0], p[2], c, mode) + ms;
        }
        return ls_single(i, bt_from_spherical(p[2], p[3]), c) + fm0 + w1 * fm1 * bt_cos(phi) +
               fm2 * bt_cos(R(2.0) * phi); /* eqs. 11-12 */
    }
    return R(0.0);
}

#endif /* BRDFTAB_LAMBERT_SPHERE_H */

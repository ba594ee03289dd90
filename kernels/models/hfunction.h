/*
 * hfunction.h — Chandrasekhar H-functions for even polynomial characteristic
 * functions, from the Fock/Chandrasekhar integral.
 *
 * E. d'Eon, "An analytic BRDF for materials with spherical Lambertian
 * scatterers", Computer Graphics Forum 40(4) (EGSR 2021).  Equation numbers
 * are that paper's; its symbols and the equations as implemented are in
 * docs/models/lambert-sphere.md.
 * Background: S. Chandrasekhar, Radiative Transfer (1960), ch. V;
 * H. G. Horak, S. Chandrasekhar, ApJ 134 (1961) 45.
 *
 * Characteristic functions (all even polynomials, Psi(mu) = sum_k a_k mu^(2k)):
 *   lambert0, lambert1, lambert2  Psi0, Psi1, Psi2 of eqs. 13-15 (parameter c)
 *   isotropic                     Psi = c/2 (Chandrasekhar's classic case)
 *   poly                          Psi = psi_0 + psi_1 mu^2 + psi_2 mu^4 + psi_3 mu^6
 *
 * Method (eq. 16):  H(mu) = exp(-(mu/pi) int_0^inf log K(t) / (1 + mu^2 t^2) dt),
 * K(t) = 1 - 2 int_0^1 Psi(x)/(1 + x^2 t^2) dx   (eq. 17 in real form; closed
 * forms eqs. 18-20 for the Lambert-sphere Psi's).
 *
 * Departures / additions (all exact rewritings, no approximation):
 *  1. Small t.  With the moments m_j = int_0^1 Psi x^(2j) dx,
 *       K(t) = (1 - 2 m_0) + 2 m_1 t^2 - 2 m_2 t^4 + ...   (|t| < 1),
 *     used for t < HF_T_SERIES: eqs. 18-20 cancel catastrophically there
 *     (terms of size 1/t^5 summing to O(1)).
 *  2. The conservative singularity.  a = K(0) = 1 - 2 m_0 vanishes at c = 1
 *     for Psi0 and for isotropic scattering: then K ~ b t^2 (b = 2 m_1) and
 *     log K has a log singularity at t = 0.  We split
 *       log K = log(K/Q) + log Q,     Q(t) = (a + b t^2)/(1 + b t^2)   (b > 0, see below),
 *     and integrate log Q analytically with
 *       int_0^inf log(p^2 + t^2)/(q^2 + t^2) dt = (pi/q) log(p + q):
 *       exp(-(mu/pi) int log Q/(1+mu^2 t^2) dt) = (mu + sqrt b)/(mu sqrt a + sqrt b).
 *     log(K/Q) is smooth, O(t^2) at 0 and O(1/t) at infinity, for every a >= 0.
 *     The factor reproduces H(inf) = 1/sqrt(K(0)) (eq. 32) exactly.
 *     When b <= 0 (Psi1 is negative for the Lambert sphere; K > 1) Q uses
 *     beta = 1 in place of b: any beta > 0 keeps log(K/Q) = O(t^2) at 0,
 *     which the trapezoidal tails below rely on.
 *  3. Quadrature.  With t = e^s the remaining integral becomes
 *       (1/pi) int L(e^s) (mu e^s)/(1 + mu^2 e^(2s)) ds,   L = log(K/Q),
 *     whose integrand decays exponentially at both ends and is analytic in
 *     the strip |Im s| < pi/2 (every singularity of K, of atan and of the
 *     kernel lies on purely imaginary t).  The trapezoidal rule converges
 *     like exp(-pi^2/h): h = HF_H_FINE gives ~1e-15, and the coarse rule
 *     (every second node, batch 1 of BT_METHOD_QUADRATURE) ~1e-8 — the
 *     reported error estimate is therefore very conservative.
 *  4. Moments alpha_n = int_0^1 mu^n H(mu) dmu by Gauss-Legendre in u with
 *     mu = u^2 (H has a mu log mu term at 0 that plain Gauss-Legendre in mu
 *     resolves slowly).
 *
 * Validity: H exists for a = 1 - 2 int Psi >= 0.  For poly coefficients with
 * a < 0 (or K <= 0 somewhere) the functions return NaN.
 */
#ifndef BRDFTAB_HFUNCTION_H
#define BRDFTAB_HFUNCTION_H

#include "../common/compat.h"
#include "../common/bt_math.h"
#include "../common/gauss_legendre.h"
#include "../common/sampler.h"

#define HF_PSI_LAMBERT0 0
#define HF_PSI_LAMBERT1 1
#define HF_PSI_LAMBERT2 2
#define HF_PSI_ISOTROPIC 3
#define HF_PSI_POLY 4

#define HF_NCOEF 4
#define HF_T_SERIES R(0.5)
#define HF_H_FINE R(0.25)
/* H(mu) = 1 to the working precision below this mu (hf_h_nodes): the
 * correction O(mu log(1/mu)) is below 1e-97 there in double and below 3e-9
 * (a fortieth of float's ulp at 1) in float, whose t^2 overflows below mu
 * ~ 4e-12. */
#if BT_DEVICE && defined(BT_REAL_IS_FLOAT) && BT_REAL_IS_FLOAT
#define HF_MU_TINY R(1e-10)
#else
#define HF_MU_TINY R(1e-100)
#endif
#define HF_SERIES_TERMS 40

/* Fixed-count loops are unrolled on the device (as BT_MATH_UNROLL in
 * bt_math.h, which float builds do not define): a loop left in the body of
 * the node-parallel kernel keeps PoCL's work-item loop from being innermost. */
#if BT_DEVICE
#define HF_UNROLL _Pragma("unroll")
#else
#define HF_UNROLL
#endif

typedef struct {
    int kind;
    REAL c;
    REAL a[HF_NCOEF]; /* Psi = sum a_k mu^(2k) */
    REAL k0;          /* a = K(0) = 1 - 2 m_0 */
    REAL b;           /* 2 m_1 */
    /* m_j = int_0^1 Psi x^(2j) dx, j < HF_SERIES_TERMS (hf_moment_psi; the
     * series of note 1 reads them): computed once per Psi rather than once
     * per term of every series evaluation. */
    REAL m[HF_SERIES_TERMS];
} hf_psi;

/* m_j = int_0^1 Psi(x) x^(2j) dx. */
BT_INLINE REAL hf_moment_psi(const hf_psi* P, int j)
{
    REAL m = R(0.0);
    HF_UNROLL
    for (int k = 0; k < HF_NCOEF; ++k) m += P->a[k] / (REAL)(2 * k + 2 * j + 1);
    return m;
}

/* Psi as an even polynomial (eqs. 13-15 expanded). */
BT_INLINE hf_psi hf_make_psi(int kind, REAL c, const REAL* poly)
{
    hf_psi P;
    P.kind = kind;
    P.c = c;
    HF_UNROLL
    for (int k = 0; k < HF_NCOEF; ++k) P.a[k] = R(0.0);
    if (kind == HF_PSI_LAMBERT0) { /* eq. 13 */
        P.a[0] = R(207.0) * c / R(384.0);
        P.a[1] = c * (c * (R(20.0) * c + R(281.0)) - R(346.0)) / R(384.0);
        P.a[2] = -R(15.0) * c * (c - R(1.0)) * (R(4.0) * c + R(9.0)) / R(384.0);
    } else if (kind == HF_PSI_LAMBERT1) { /* eq. 14 */
        REAL q = R(5.0) * (R(4.0) * c + R(9.0));
        P.a[0] = -R(64.0) * c / R(192.0);
        P.a[1] = c * (q + R(64.0)) / R(192.0);
        P.a[2] = -c * q / R(192.0);
    } else if (kind == HF_PSI_LAMBERT2) { /* eq. 15 */
        P.a[0] = R(15.0) * c / R(256.0);
        P.a[1] = -R(30.0) * c / R(256.0);
        P.a[2] = R(15.0) * c / R(256.0);
    } else if (kind == HF_PSI_ISOTROPIC) {
        P.a[0] = R(0.5) * c;
    } else {
        HF_UNROLL
        for (int k = 0; k < HF_NCOEF; ++k) P.a[k] = poly[k];
    }
    REAL m0 = R(0.0), m1 = R(0.0);
    HF_UNROLL
    for (int k = 0; k < HF_NCOEF; ++k) {
        m0 += P.a[k] / (REAL)(2 * k + 1);
        m1 += P.a[k] / (REAL)(2 * k + 3);
    }
    /* K(0) in factored form where it vanishes at c = 1, so that a is exactly
     * 0 there (rounding of 1 - 2 m_0 would leave ~1e-16 and an error of
     * ~mu 1e-8 in the factor of note 2). */
    if (kind == HF_PSI_LAMBERT0)
        P.k0 = (c - R(16.0)) * (c - R(1.0)) * (R(4.0) * c + R(9.0)) / R(144.0); /* eq. 32 */
    else if (kind == HF_PSI_ISOTROPIC)
        P.k0 = R(1.0) - c;
    else
        P.k0 = R(1.0) - R(2.0) * m0;
    P.b = R(2.0) * m1;
    for (int j = 0; j < HF_SERIES_TERMS; ++j) P.m[j] = hf_moment_psi(&P, j);
    return P;
}

/* K(t) - a - b t^2 for t < HF_T_SERIES (alternating series, note 1). */
BT_INLINE REAL hf_k_series_rest(const hf_psi* P, REAL t)
{
    REAL t2 = t * t;
    REAL tp = t2 * t2; /* t^(2j), j = 2 */
    REAL sum = R(0.0);
    REAL sign = -R(1.0);
    HF_UNROLL
    for (int j = 2; j < HF_SERIES_TERMS; ++j) {
        sum += sign * tp * P->m[j];
        tp *= t2;
        sign = -sign;
    }
    return R(2.0) * sum;
}

/* K(t) for t >= HF_T_SERIES: closed forms eqs. 18-20 for the Lambert Psi's,
 * otherwise 1 - 2 sum a_k I_k(t) with I_0 = atan(t)/t and the upward
 * recurrence I_k = (1/(2k-1) - I_(k-1))/t^2 (stable enough for t >= 0.5:
 * at most a factor 4 per step). */
BT_INLINE REAL hf_k_direct(const hf_psi* P, REAL t)
{
    /* Eqs. 18-20 divided through by t^5 and written in u = 1/t, so that no
     * power of t above 2 is formed (t^5 overflows float for t > 5e7). */
    REAL c = P->c;
    REAL at = bt_atan(t);
    REAL u = R(1.0) / t;
    REAL u2 = u * u;
    REAL t2 = t * t;
    if (P->kind == HF_PSI_LAMBERT0) { /* eq. 18 */
        REAL q = R(15.0) * (c - R(1.0)) * (R(4.0) * c + R(9.0));
        REAL num = (R(256.0) * c - R(301.0)) * u2 +
                   ((R(346.0) - c * (R(20.0) * c + R(281.0))) * u2 * u - q * u2 * u2 * u +
                    R(207.0) * u) * at +
                   q * u2 * u2;
        return R(1.0) - c * num / R(192.0);
    }
    if (P->kind == HF_PSI_LAMBERT1) { /* eq. 19 */
        REAL num = (R(40.0) * c + R(282.0)) * u2 -
                   R(3.0) * u * (R(1.0) + u2) * (R(64.0) + (R(20.0) * c + R(45.0)) * u2) * at +
                   R(15.0) * (R(4.0) * c + R(9.0)) * u2 * u2;
        return R(1.0) - c * num / R(288.0);
    }
    if (P->kind == HF_PSI_LAMBERT2) { /* eq. 20 */
        REAL v = R(1.0) + u2;
        REAL num = R(3.0) * u * v * v * at - (R(5.0) * u2 + R(3.0) * u2 * u2);
        return R(1.0) - R(5.0) * c * num / R(128.0);
    }
    REAL I = at / t;
    REAL s = P->a[0] * I;
    HF_UNROLL
    for (int k = 1; k < HF_NCOEF; ++k) {
        I = (R(1.0) / (REAL)(2 * k - 1) - I) / t2;
        s += P->a[k] * I;
    }
    return R(1.0) - R(2.0) * s;
}

/* Width of Q (note 2): b when positive, else 1 (any beta > 0 makes
 * log(K/Q) vanish at t = 0; the analytic factor holds for every beta). */
BT_INLINE REAL hf_beta(const hf_psi* P) { return P->b > R(0.0) ? P->b : R(1.0); }

/* bt_log and bt_log1p, each call in a basic block of its own: the same
 * values (the other branch returns what bt_log / bt_log1p return there:
 * -inf at 0 resp. -1, else bt_math's NaN), so that clang's SLP vectoriser,
 * which PoCL runs when it builds a program, finds no two logarithms in one
 * block to pack into a 2-wide vector: that packing keeps PoCL from running
 * the node-parallel kernel's work items as SIMD lanes (docs/contributing.md,
 * "What keeps PoCL's work-item loop scalar").  Float builds use the OpenCL
 * built-ins (bt_math.h), calls that propagate NaN inputs: unchanged there. */
#if BT_DEVICE && defined(BT_REAL_IS_FLOAT) && BT_REAL_IS_FLOAT
#define hf_log(x) bt_log(x)
#define hf_log1p(x) bt_log1p(x)
#else
BT_INLINE REAL hf_log(REAL x)
{
    if (x > R(0.0)) return bt_log(x);
    return x == R(0.0) ? -BT_M_INF : BT_M_NAN;
}
BT_INLINE REAL hf_log1p(REAL x)
{
    if (x > -R(1.0)) return bt_log1p(x);
    return x == -R(1.0) ? -BT_M_INF : BT_M_NAN;
}
#endif

/* L(t) = log(K(t)/Q(t)), note 2: by the series for t < HF_T_SERIES, else
 * from K directly.  The two forms apart, for the node-parallel kernels that
 * run each on its own nodes (hfunction_h_node_term_series/_direct). */
BT_INLINE REAL hf_log_k_over_q_series(const hf_psi* P, REAL t)
{
    REAL a = P->k0, beta = hf_beta(P);
    REAL t2 = t * t;
    REAL bt2 = beta * t2;
    REAL rest = (P->b - beta) * t2 + hf_k_series_rest(P, t);
    REAL aq = a + bt2;
    /* 0 where !(aq > 0) (t = 0 with a = 0), by a select: behind an early
     * return LLVM moves the series' loads of P under the branch, gathers an
     * AVX2 target cannot mask, and the node kernel stays scalar there. */
    REAL l = hf_log1p(rest / aq) + hf_log1p(bt2);
    return aq > R(0.0) ? l : R(0.0);
}

BT_INLINE REAL hf_log_k_over_q_direct(const hf_psi* P, REAL t)
{
    REAL a = P->k0, beta = hf_beta(P);
    REAL t2 = t * t;
    REAL bt2 = beta * t2;
    return hf_log(hf_k_direct(P, t)) - hf_log(a + bt2) + hf_log1p(bt2);
}

BT_INLINE REAL hf_log_k_over_q(const hf_psi* P, REAL t)
{
    if (t < HF_T_SERIES) return hf_log_k_over_q_series(P, t);
    return hf_log_k_over_q_direct(P, t);
}

/* The trapezoid rule of H(mu) (eq. 16 with notes 2-3) in three parts, so
 * that the serial loop (hf_h below) and the engine's node-parallel kernels
 * (kernels/common/node_parallel.h: one work item per node, then a sum in
 * node order) evaluate the very same expressions in the same order:
 *   hf_h_nodes   the number n of nodes s_k = s_lo + step k of one (mu, rule),
 *                0 where H needs no sum (mu <= 0, or no H-function);
 *   hf_h_term    the k-th term of the sum (before the factor step/pi);
 *   hf_h_finish  H from the sum of the n terms, added in order k = 0, 1, ...
 * `coarse` != 0 uses every second node (error estimate of
 * BT_METHOD_QUADRATURE). */
BT_INLINE int hf_h_nodes(const hf_psi* P, REAL mu, int coarse, REAL* s_lo, REAL* step)
{
    *s_lo = R(0.0);
    *step = R(0.0);
    if (!(mu > R(0.0)) || P->k0 < R(0.0)) return 0;
    /* Below HF_MU_TINY no nodes: the empty sum makes hf_h_finish return
     * factor * exp(0) = 1 (mu vanishes next to sqrt(beta) in the factor),
     * and H(mu) = 1 + O(mu log(1/mu)) is 1 to the working precision there
     * (HF_MU_TINY).  The rule below would reach t = e^18/mu, whose square
     * overflows for mu below ~5e-147 in double, ~4e-12 in float (H would be
     * NaN there). */
    if (mu < HF_MU_TINY) return 0;
    /* Integration limits in s = log t (note 3): the integrand is ~ mu b t^3
     * below t ~ 1/mu and ~ 1/(mu t^2) above max(1, 1/mu). */
    REAL lmu = bt_log(mu);
    REAL lo = -R(13.0) - (lmu > R(0.0) ? lmu / R(3.0) : R(0.0));
    REAL hi = R(18.0) + (lmu < R(0.0) ? -lmu : R(0.0));
    REAL h = HF_H_FINE;
    int n = (int)((hi - lo) / h) + 1;
    if (coarse) n = n / 2 + 1; /* same grid origin, twice the step */
    *s_lo = lo;
    *step = coarse ? R(2.0) * h : h;
    return n;
}

/* Node k's t, and its term from L(t) (hf_h_term, in two steps for the
 * node-parallel kernels of one form). */
BT_INLINE REAL hf_h_node_t(REAL s_lo, REAL step, int k) { return bt_exp(s_lo + step * (REAL)k); }

BT_INLINE REAL hf_h_term_of(REAL log_k_over_q, REAL mu, REAL t)
{
    REAL mt = mu * t;
    return log_k_over_q * mt / (R(1.0) + mt * mt);
}

BT_INLINE REAL hf_h_term(const hf_psi* P, REAL mu, REAL s_lo, REAL step, int k)
{
    REAL t = hf_h_node_t(s_lo, step, k);
    return hf_h_term_of(hf_log_k_over_q(P, t), mu, t);
}

BT_INLINE REAL hf_h_finish(const hf_psi* P, REAL mu, REAL step, REAL sum)
{
    if (!(mu > R(0.0))) return R(1.0);
    if (P->k0 < R(0.0)) return R(0.0) / R(0.0); /* no H-function: K has a real zero */
    REAL sb = sqrt(hf_beta(P));
    REAL factor = (mu + sb) / (mu * sqrt(P->k0) + sb); /* note 2 */
    return factor * bt_exp(-step * sum * BT_INV_PI);
}

/* H(mu) for mu >= 0 (eq. 16 with notes 2-3). */
BT_INLINE REAL hf_h(const hf_psi* P, REAL mu, int coarse)
{
    REAL s_lo, step;
    int n = hf_h_nodes(P, mu, coarse, &s_lo, &step);
    REAL sum = R(0.0);
    for (int k = 0; k < n; ++k) sum += hf_h_term(P, mu, s_lo, step, k);
    return hf_h_finish(P, mu, step, sum);
}

/* alpha_n = int_0^1 mu^n H(mu) dmu with mu = u^2 (note 4). */
BT_INLINE REAL hf_alpha(const hf_psi* P, int n, int coarse)
{
    int nodes = coarse ? 12 : 24;
    REAL sum = R(0.0);
    for (int k = 0; k < nodes; ++k) {
        ACCUM xa, wa;
        REAL x, w;
        bt_gauss_legendre(nodes, k, &xa, &wa);
        x = (REAL)xa;
        w = (REAL)wa;
        REAL u = R(0.5) * (x + R(1.0));
        REAL mu = u * u;
        REAL mun = R(1.0);
        for (int j = 0; j < n; ++j) mun *= mu;
        sum += w * mun * hf_h(P, mu, coarse) * u; /* dmu = 2u du, du = dx/2 */
    }
    return sum;
}

/* ------------------------------------------------------------ sample fn */
/* Point: p[4] mu, p[5] c, p[6] n, p[7..10] psi_0..psi_3.  Option o[0] psi. */
#define HF_Q_H 0
#define HF_Q_MOMENT 1
#define HF_Q_HINF 2
#define HF_Q_K 3

/* The model contract: slots of the point p[] and of the options o[] and the
 * number of quantities (ids HF_Q_* above).  host/models/lambert_sphere.cpp registers
 * the model by these names; p[0..3] are the directions (estimator.h). */
#define HF_PARAM_MU 4
#define HF_PARAM_C 5
#define HF_PARAM_N 6
#define HF_PARAM_PSI_0 7
#define HF_PARAM_PSI_1 8
#define HF_PARAM_PSI_2 9
#define HF_PARAM_PSI_3 10
#define HF_PARAM_COUNT 7
#define HF_OPT_PSI 0
#define HF_OPT_COUNT 1
#define HF_Q_COUNT 4

/* Psi of a kernel point (slots and option above). */
BT_INLINE hf_psi hfunction_point_psi(const REAL* p, const int* o)
{
    REAL poly[HF_NCOEF];
    HF_UNROLL
    for (int k = 0; k < HF_NCOEF; ++k) poly[k] = p[HF_PARAM_PSI_0 + k];
    return hf_make_psi(o[HF_OPT_PSI], p[HF_PARAM_C], poly);
}

/* Deterministic: the same value under every method; only batch 1 of
 * BT_METHOD_QUADRATURE uses the coarse rule. */
BT_INLINE int hfunction_coarse(const bt_sampler* s)
{
    return (s->method == BT_METHOD_QUADRATURE && s->batch == 1u) ? 1 : 0;
}

BT_INLINE REAL hfunction_sample(const REAL* p, const int* o, int quantity, const bt_sampler* s)
{
    hf_psi P = hfunction_point_psi(p, o);
    int coarse = hfunction_coarse(s);
    if (quantity == HF_Q_H) return hf_h(&P, p[HF_PARAM_MU], coarse);
    if (quantity == HF_Q_MOMENT) return hf_alpha(&P, (int)floor(p[HF_PARAM_N] + R(0.5)), coarse);
    if (quantity == HF_Q_HINF) /* eq. 32 (general form 1/sqrt(K(0))) */
        return P.k0 > R(0.0) ? R(1.0) / sqrt(P.k0) : R(1.0) / R(0.0);
    if (quantity == HF_Q_K) { /* K(t) at t = mu (diagnostic) */
        REAL t = p[HF_PARAM_MU];
        if (t < HF_T_SERIES) return P.k0 + P.b * t * t + hf_k_series_rest(&P, t);
        return hf_k_direct(&P, t);
    }
    return R(0.0);
}

/* The node functions of quantity H (HF_Q_H only) for the engine's
 * node-parallel path (kernels/common/node_parallel.h; registered as
 * QuantityInfo::node_parallel in host/models/lambert_sphere.cpp):
 *     finish(sum over k < count of term(state, k), added in order k = 0, 1, ...)
 * with the state from prepare is hfunction_sample(p, o, HF_Q_H, s) bit for
 * bit, because hf_h is that very sum of hf_h_term between hf_h_nodes and
 * hf_h_finish, and the state holds the exact values the loop uses.
 * State (HF_NODE_STATE values): mu, s_lo, step, then Psi's c, k0, b, a[],
 * m[] (its kind is the option o[HF_OPT_PSI]). */
#define HF_NODE_STATE (6 + HF_NCOEF + HF_SERIES_TERMS)

BT_INLINE int hfunction_h_node_count(const REAL* p, const int* o, int quantity,
                                     const bt_sampler* s)
{
    (void)quantity;
    hf_psi P = hfunction_point_psi(p, o);
    REAL s_lo, step;
    return hf_h_nodes(&P, p[HF_PARAM_MU], hfunction_coarse(s), &s_lo, &step);
}

BT_INLINE void hfunction_h_node_prepare(const REAL* p, const int* o, int quantity,
                                        const bt_sampler* s, REAL* state)
{
    (void)quantity;
    hf_psi P = hfunction_point_psi(p, o);
    REAL s_lo, step;
    (void)hf_h_nodes(&P, p[HF_PARAM_MU], hfunction_coarse(s), &s_lo, &step);
    state[0] = p[HF_PARAM_MU];
    state[1] = s_lo;
    state[2] = step;
    state[3] = P.c;
    state[4] = P.k0;
    state[5] = P.b;
    for (int k = 0; k < HF_NCOEF; ++k) state[6 + k] = P.a[k];
    for (int j = 0; j < HF_SERIES_TERMS; ++j) state[6 + HF_NCOEF + j] = P.m[j];
}

BT_INLINE hf_psi hfunction_h_node_psi(const REAL* state, const int* o)
{
    hf_psi P;
    P.kind = o[HF_OPT_PSI];
    P.c = state[3];
    P.k0 = state[4];
    P.b = state[5];
    HF_UNROLL
    for (int i = 0; i < HF_NCOEF; ++i) P.a[i] = state[6 + i];
    HF_UNROLL
    for (int j = 0; j < HF_SERIES_TERMS; ++j) P.m[j] = state[6 + HF_NCOEF + j];
    return P;
}

BT_INLINE REAL hfunction_h_node_term(const REAL* state, const int* o, int quantity, int k)
{
    (void)quantity;
    hf_psi P = hfunction_h_node_psi(state, o);
    return hf_h_term(&P, state[0], state[1], state[2], k);
}

/* The two forms of a term (the node-parallel split, node_parallel.h): a
 * vectorised node kernel computes both sides of hf_log_k_over_q's branch for
 * every node, and the series (38 terms) costs more than the direct form; the
 * engine runs the nodes with t < HF_T_SERIES (a prefix: t grows with k) on
 * the series kernel and the others on the direct one.  Each returns its
 * form's term, hfunction_h_node_term's value, where its form is the one
 * hf_log_k_over_q takes at the node's t, else NaN (the sum kernel then
 * computes the term itself). */
BT_INLINE REAL hfunction_h_node_term_series(const REAL* state, const int* o, int quantity, int k)
{
    (void)quantity;
    hf_psi P = hfunction_h_node_psi(state, o);
    REAL t = hf_h_node_t(state[1], state[2], k);
    REAL v = hf_h_term_of(hf_log_k_over_q_series(&P, t), state[0], t);
    return t < HF_T_SERIES ? v : R(0.0) / R(0.0);
}

BT_INLINE REAL hfunction_h_node_term_direct(const REAL* state, const int* o, int quantity, int k)
{
    (void)quantity;
    hf_psi P = hfunction_h_node_psi(state, o);
    REAL t = hf_h_node_t(state[1], state[2], k);
    REAL v = hf_h_term_of(hf_log_k_over_q_direct(&P, t), state[0], t);
    return t < HF_T_SERIES ? R(0.0) / R(0.0) : v;
}

/* The series nodes of a work item (the host's guess, for the layout): k
 * with s_lo + step k < log(HF_T_SERIES), from the grid rather than from
 * n calls of exp; a node it puts on the wrong side comes back NaN and is
 * computed by the sum kernel, so the guess moves no value. */
BT_INLINE int hfunction_h_node_split(const REAL* p, const int* o, int quantity, const bt_sampler* s)
{
    (void)quantity;
    hf_psi P = hfunction_point_psi(p, o);
    REAL s_lo, step;
    int n = hf_h_nodes(&P, p[HF_PARAM_MU], hfunction_coarse(s), &s_lo, &step);
    if (n <= 0 || !(step > R(0.0))) return 0;
    REAL first_direct = ceil((bt_log(HF_T_SERIES) - s_lo) / step);
    if (!(first_direct > R(0.0))) return 0;
    return first_direct < (REAL)n ? (int)first_direct : n;
}

BT_INLINE REAL hfunction_h_node_finish(const REAL* p, const int* o, int quantity,
                                       const bt_sampler* s, REAL sum)
{
    (void)quantity;
    hf_psi P = hfunction_point_psi(p, o);
    REAL s_lo, step;
    (void)hf_h_nodes(&P, p[HF_PARAM_MU], hfunction_coarse(s), &s_lo, &step);
    return hf_h_finish(&P, p[HF_PARAM_MU], step, sum);
}

#endif /* BRDFTAB_HFUNCTION_H */

/*
 * bt_math.h — branch-free, inlinable double-precision replacements for the
 * transcendental functions the kernels call in their hot loops:
 *
 *   bt_sin, bt_cos, bt_sincos, bt_tan, bt_exp, bt_log, bt_log1p,
 *   bt_atan, bt_atan2, bt_asin, bt_acos, bt_erf, bt_erfc
 *
 * Why: PoCL (measured, docs/contributing.md "bt_math") calls its double
 * sin/cos/acos/atan2/log out of line, one lane at a time, so a kernel whose
 * work items each call one of them is not vectorised across work items and
 * runs about ten times slower than the same kernel without the call.  The
 * functions below are plain arithmetic, integer bit operations and selects:
 * once inlined, the vectoriser can if-convert them and run 8 double lanes.
 *
 * One source of truth: the host C++ reference path includes this file too
 * and calls the same functions, so host and device compute the same
 * arithmetic (they still differ in the last bit where PoCL contracts a*b + c
 * into an FMA and the host build does not).
 *
 * Method (each function says its reduced range and truncation bound):
 *   Cody-Waite range reduction by a constant split into pieces whose
 *   products with the (small) integer multiple are exact, then a Taylor
 *   polynomial evaluated by Horner's rule with enough terms that the
 *   truncation error on the reduced range is below 1e-18 relative (1/100 of
 *   a double ulp), so the error is set by rounding alone.  Branches are
 *   ternaries on values that both sides compute anyway.
 *
 * Measured accuracy against long double (tests/test_kernel_math.cpp, host
 * and device; docs/contributing.md has the table): at most 1-2 ulp on the
 * tested domains.  Domains:
 *   sin/cos/sincos/tan  |x| <= 1e5 (the kernels only pass angles of a few pi);
 *                       beyond |x| ~ 1.6e6 the 3-piece reduction loses
 *                       accuracy (no trap; inf/NaN give NaN).
 *   exp                 every double; overflow gives +inf, underflow 0 (with
 *                       denormal results), NaN passes through.
 *   log, log1p          every double; log(0) = -inf, log(x<0) = NaN,
 *                       denormal inputs are exact-scaled first.
 *   atan, atan2         every double, signed zeros and infinities as C99.
 *   asin, acos          [-1, 1] (outside: a number, not NaN; callers clamp).
 *   erf                 every double; erf(+-inf) = +-1, NaN passes through.
 *   erfc                every double; erfc(+inf) = 0, erfc(-inf) = 2, NaN
 *                       passes through; denormal results below 2.2e-308;
 *                       within 2.4 ulp of the exact value (measured).
 *
 * Float: with BT_REAL_IS_FLOAT (`--precision float`, and every device
 * without cl_khr_fp64) the names map to the OpenCL built-ins instead.  The
 * double code below needs fp64 to compile at all, float built-ins are
 * hardware instructions on GPUs (where float matters), and PoCL's float
 * built-ins do not have the double ones' out-of-line cost to remove.
 */
#ifndef BRDFTAB_BT_MATH_H
#define BRDFTAB_BT_MATH_H

#include "compat.h"

/* Forced inlining: measured, PoCL's inliner left bt_atan2 as a call inside
 * micrograin's shadow-area function ("too costly to inline", cost 250 >
 * 225), and a call in per-work-item code is what stops vectorisation. */
#if BT_DEVICE || defined(__GNUC__) || defined(__clang__)
#define BT_MATH_INLINE static inline __attribute__((always_inline))
#else
#define BT_MATH_INLINE static inline
#endif

#if BT_DEVICE && defined(BT_REAL_IS_FLOAT) && BT_REAL_IS_FLOAT

#define bt_sin(x) sin(x)
#define bt_cos(x) cos(x)
#define bt_sincos(x, c) sincos((x), (c))
#define bt_tan(x) tan(x)
#define bt_exp(x) exp(x)
#define bt_log(x) log(x)
#define bt_log_split(x) log(x)
#define bt_log1p(x) log1p(x)
#define bt_atan(x) atan(x)
#define bt_atan2(y, x) atan2((y), (x))
#define bt_asin(x) asin(x)
#define bt_acos(x) acos(x)
#define bt_erf(x) erf(x)
#define bt_erfc(x) erfc(x)

#else /* double */


#if BT_DEVICE
typedef long bt_i64;
BT_MATH_INLINE bt_i64 bt_bits_of(double x) { return as_long(x); }
BT_MATH_INLINE double bt_double_of(bt_i64 b) { return as_double(b); }
#else
#include <cstring>
typedef long long bt_i64;
BT_MATH_INLINE bt_i64 bt_bits_of(double x)
{
    bt_i64 b;
    std::memcpy(&b, &x, sizeof b);
    return b;
}
BT_MATH_INLINE double bt_double_of(bt_i64 b)
{
    double x;
    std::memcpy(&x, &b, sizeof x);
    return x;
}
#endif

#define BT_M_INF (bt_double_of((bt_i64)0x7ff0000000000000LL))
#define BT_M_NAN (bt_double_of((bt_i64)0x7ff8000000000000LL))

/* Round to the nearest integer (ties either way) for |t| < 2^51, as a
 * double: adding and removing 1.5 * 2^52 leaves no fraction bits.  Cheaper
 * than rint() on a host build without SSE4.1, and vectorisable. */
BT_MATH_INLINE double bt_round_small(double t)
{
    const double shifter = 6755399441055744.0; /* 1.5 * 2^52 */
    return (t + shifter) - shifter;
}

/* 2^k for an integer k in [-1022, 1023]: the exponent field itself. */
BT_MATH_INLINE double bt_pow2i(int k) { return bt_double_of(((bt_i64)(k + 1023)) << 52); }

BT_MATH_INLINE int bt_sign_bit(double x) { return bt_bits_of(x) < 0; }

/* ------------------------------------------------------------ sin, cos
 * Reduction: n = nearest integer to x / (pi/2), r = x - n pi/2 with pi/2 in
 * three 33-bit pieces p1 + p2 + p3 and the tail p3t of the rest (an error
 * below 1e-47 in all), so n * p_k is exact for |n| < 2^20: the first
 * subtractions are exact (Sterbenz) and near a multiple of pi/2, where r
 * cancels down to ~1e-18, r keeps full relative precision.
 * |r| <= pi/4.  Then
 *   sin r = r - r^3/3! + ... + r^17/17!   truncation < r^19/19! < 1.1e-19 |r|
 *   cos r = 1 - r^2/2! + ... + r^16/16!   truncation < r^18/18! < 2.1e-18
 * (with |r| <= 0.786), and the quadrant n mod 4 picks +-sin r or +-cos r. */
#define BT_PIO2_1 1.57079632673412561417e+00  /* first 33 bits of pi/2 */
#define BT_PIO2_2 6.07710050630396597660e-11  /* next 33 bits */
#define BT_PIO2_3 2.02226624871116645580e-21  /* next 33 bits */
#define BT_PIO2_3T 8.47842766036889956997e-32 /* pi/2 - (p1 + p2 + p3) */
#define BT_TWO_OVER_PI 6.36619772367581382433e-01

BT_MATH_INLINE double bt_sin_poly(double r)
{
    double z = r * r;
    double p = -1.0 / 355687428096000.0;        /* -1/17! */
    p = p * z + 1.0 / 1307674368000.0;           /* 1/15! */
    p = p * z - 1.0 / 6227020800.0;              /* -1/13! */
    p = p * z + 1.0 / 39916800.0;                /* 1/11! */
    p = p * z - 1.0 / 362880.0;                  /* -1/9! */
    p = p * z + 1.0 / 5040.0;                    /* 1/7! */
    p = p * z - 1.0 / 120.0;                     /* -1/5! */
    p = p * z + 1.0 / 6.0;                       /* 1/3! */
    /* r - r^3 (1/3! - ...); the select keeps sin(-0) = -0 (-0 - -0 is +0). */
    return z == 0.0 ? r : r - r * z * p;
}

BT_MATH_INLINE double bt_cos_poly(double r)
{
    double z = r * r;
    double p = 1.0 / 20922789888000.0;           /* 1/16! */
    p = p * z - 1.0 / 87178291200.0;             /* -1/14! */
    p = p * z + 1.0 / 479001600.0;               /* 1/12! */
    p = p * z - 1.0 / 3628800.0;                 /* -1/10! */
    p = p * z + 1.0 / 40320.0;                   /* 1/8! */
    p = p * z - 1.0 / 720.0;                     /* -1/6! */
    p = p * z + 1.0 / 24.0;                      /* 1/4! */
    /* 1 - z/2 + z^2 p: the big term z/2 <= 0.31 is subtracted last. */
    double hz = 0.5 * z;
    double w = 1.0 - hz;
    /* (1 - w) - hz recovers the rounding error of w exactly (Sterbenz). */
    return w + (((1.0 - w) - hz) + z * z * p);
}

/* Reduced argument and quadrant; |x| is clamped to 2^30 so the integer
 * conversion is always defined (larger |x| are outside the accurate domain
 * anyway; inf and NaN still give a NaN r). */
BT_MATH_INLINE double bt_reduce_pio2(double x, int* quadrant)
{
    double t = fmin(fmax(x * BT_TWO_OVER_PI, -1073741824.0), 1073741824.0);
    /* n = bt_round_small(t), and the quadrant read from the low mantissa
     * bits of the shifted sum (t + 1.5 * 2^52 has an ulp of 1, so its last
     * bits are n's two's complement bits): no double -> int conversion,
     * which the SLP vectoriser pairs across two calls (see bt_sincos). */
    double shifted = t + 6755399441055744.0; /* 1.5 * 2^52 */
    double n = shifted - 6755399441055744.0;
    double r = (((x - n * BT_PIO2_1) - n * BT_PIO2_2) - n * BT_PIO2_3) - n * BT_PIO2_3T;
    *quadrant = (int)(bt_bits_of(shifted) & 3);
    return r;
}

/* sin x; *c receives cos x. */
BT_MATH_INLINE double bt_sincos(double x, double* c)
{
    int q;
    double r = bt_reduce_pio2(x, &q);
    double s_r = bt_sin_poly(r), c_r = bt_cos_poly(r);
    int odd = q & 1;
    double s = odd ? c_r : s_r;
    double co = odd ? s_r : c_r;
    /* sin: quadrants 2, 3 negative; cos: quadrants 1, 2 negative.  The two
     * signs are applied in different ways on purpose (a select of -s, a
     * product with +-1: both exact), and inf/NaN become NaN through a factor
     * (x - x) + 1 (1 for finite x, NaN otherwise: exact, keeps -0) rather
     * than a branch.  Measured (docs/contributing.md): written alike, the sine
     * and cosine lanes are isomorphic, and clang's SLP vectoriser, which
     * PoCL runs when it builds the program, packs them into <2 x double>
     * values; LLVM's loop vectoriser then refuses the work-item loop
     * ("instruction return type cannot be vectorized"), so the whole kernel
     * stays scalar. */
    s = (q & 2) ? -s : s;
    co = co * (1.0 - (double)((q + 1) & 2));
    double nan_unless_finite = (x - x) + 1.0;
    *c = co * nan_unless_finite;
    return s * nan_unless_finite;
}

BT_MATH_INLINE double bt_sin(double x)
{
    int q;
    double r = bt_reduce_pio2(x, &q);
    double v = (q & 1) ? bt_cos_poly(r) : bt_sin_poly(r);
    v = (q & 2) ? -v : v;
    return fabs(x) <= 1.7976931348623157e308 ? v : BT_M_NAN;
}

BT_MATH_INLINE double bt_cos(double x)
{
    int q;
    double r = bt_reduce_pio2(x, &q);
    double v = (q & 1) ? bt_sin_poly(r) : bt_cos_poly(r);
    v = ((q + 1) & 2) ? -v : v;
    return fabs(x) <= 1.7976931348623157e308 ? v : BT_M_NAN;
}

/* tan x = sin x / cos x (two roundings more than sin: <= 2.5 ulp bound). */
BT_MATH_INLINE double bt_tan(double x)
{
    double c;
    double s = bt_sincos(x, &c);
    return s / c;
}

/* ------------------------------------------------------------------ exp
 * x = n ln2 + r, n nearest integer to x / ln2, ln2 = LN2_HI + LN2_LO with
 * LN2_HI holding 32 bits (n * LN2_HI exact for |n| < 2^21): |r| <= 0.347.
 *   exp r = 1 + r + r^2/2! + ... + r^13/13!   truncation < r^14/14! < 4.1e-18
 * 2^n is applied as two factors 2^(n/2) 2^(n - n/2) so that results in the
 * denormal range and up to the overflow threshold need no special case. */
#define BT_LN2_HI 6.93147180369123816490e-01
#define BT_LN2_LO 1.90821492927058770002e-10
#define BT_LOG2_E 1.44269504088896338700e+00

BT_MATH_INLINE double bt_exp(double x)
{
    double xc = fmin(fmax(x, -746.0), 710.0); /* beyond: 0 or inf anyway */
    double n = bt_round_small(xc * BT_LOG2_E);
    double r = (xc - n * BT_LN2_HI) - n * BT_LN2_LO;
    double p = 1.0 / 6227020800.0;               /* 1/13! */
    p = p * r + 1.0 / 479001600.0;               /* 1/12! */
    p = p * r + 1.0 / 39916800.0;                /* 1/11! */
    p = p * r + 1.0 / 3628800.0;                 /* 1/10! */
    p = p * r + 1.0 / 362880.0;                  /* 1/9! */
    p = p * r + 1.0 / 40320.0;                   /* 1/8! */
    p = p * r + 1.0 / 5040.0;                    /* 1/7! */
    p = p * r + 1.0 / 720.0;                     /* 1/6! */
    p = p * r + 1.0 / 120.0;                     /* 1/5! */
    p = p * r + 1.0 / 24.0;                      /* 1/4! */
    p = p * r + 1.0 / 6.0;                       /* 1/3! */
    p = p * r + 0.5;                             /* 1/2! */
    double e = 1.0 + (r + r * r * p);
    int k = (int)n;
    int k1 = k >> 1; /* floor(k/2) */
    double v = e * bt_pow2i(k1) * bt_pow2i(k - k1);
    return x != x ? x : v;
}

/* ------------------------------------------------------------------ log
 * x = 2^k m with m in [sqrt(1/2), sqrt(2)) read from the bits (denormals are
 * scaled by 2^54 first), f = m - 1 (exact), s = f / (2 + f), |s| <= 0.1716:
 *   log(1 + f) = 2 atanh(s) = 2s + 2s (s^2/3 + s^4/5 + ... + s^20/21)
 *   truncation < 2|s| s^22/23 < 6.2e-19 * 2|s|  (s^2 <= 0.02944).
 * Written as f - s (f - R), R = 2 (s^2/3 + ...), because 2s = f - s f: the
 * exact f carries the result and the correction is at most 0.17 f.  Then
 * log x = k LN2_HI + (log(1 + f) + k LN2_LO), k LN2_HI exact. */
BT_MATH_INLINE double bt_log_impl(double x, int split)
{
    int tiny = x < 2.2250738585072014e-308; /* denormal (or <= 0) */
    double xs = tiny ? x * 18014398509481984.0 : x; /* 2^54 */
    bt_i64 bits = bt_bits_of(xs);
    int k = (int)((bits >> 52) & 0x7ff) - 1023 - (tiny ? 54 : 0);
    double m = bt_double_of((bits & 0x000fffffffffffffLL) | 0x3ff0000000000000LL);
    m = split ? BT_SLP_SPLIT(m) : m;
    int big = m > 1.41421356237309504880;
    m = big ? 0.5 * m : m;
    k += big;
    double f = m - 1.0;
    double s = f / (2.0 + f);
    double z = s * s;
    double p = 2.0 / 21.0;
    p = p * z + 2.0 / 19.0;
    p = p * z + 2.0 / 17.0;
    p = p * z + 2.0 / 15.0;
    p = p * z + 2.0 / 13.0;
    p = p * z + 2.0 / 11.0;
    p = p * z + 2.0 / 9.0;
    p = p * z + 2.0 / 7.0;
    p = p * z + 2.0 / 5.0;
    p = p * z + 2.0 / 3.0;
    double log1pf = f - s * (f - z * p);
    double dk = (double)k;
    double v = dk * BT_LN2_HI + (log1pf + dk * BT_LN2_LO);
    double inf = BT_M_INF;
    double special = x == 0.0 ? -inf : (x == inf ? inf : BT_M_NAN);
    return ((x > 0.0) & (x < inf)) ? v : special;
}

BT_MATH_INLINE double bt_log(double x) { return bt_log_impl(x, 0); }
/* The same value as bt_log; for the second of two logs that clang's SLP
 * vectoriser would otherwise pack (compat.h, BT_SLP_SPLIT). */
BT_MATH_INLINE double bt_log_split(double x) { return bt_log_impl(x, 1); }

/* log(1 + x) for x >= -1: with u = 1 + x rounded, log u - ((u - 1) - x) / u
 * corrects the first-order effect of the rounding of u (the error left is
 * O(rounding^2)); u = 1 means |x| < 2^-53 where log(1 + x) = x. */
BT_MATH_INLINE double bt_log1p(double x)
{
    double u = 1.0 + x;
    double l = bt_log(u);
    double corrected = l - ((u - 1.0) - x) / u;
    double v = ((u > 0.0) & (u < BT_M_INF)) ? corrected : l;
    return u == 1.0 ? x : v;
}

/* ----------------------------------------------------------- atan family
 * Core for t in [0, 1]: c = j/4 the nearest multiple of 1/4, and
 *   atan t = atan c + atan((t - c) / (1 + c t)),  |(t - c)/(1 + c t)| <= 1/8,
 *   atan u = u - u^3/3 + ... - u^19/19 + u^21/21
 *   truncation < |u| u^22/23 < 8e-22 |u|  (u^2 <= 1/64).
 * atan(j/4) is held as hi + lo (lo the rounding error of hi, from a 60-digit
 * evaluation) and picked by selects, not by a table: measured, a table read
 * with a per-work-item index kept PoCL from vectorising the caller.  t - c
 * is exact (Sterbenz: c/2 <= t <= 2c when c > 0); j = 0 leaves t itself, so
 * tiny and denormal t stay exact. */
#define BT_PIO2_HI 1.5707963267948966
#define BT_PIO2_LO 6.123233995736766e-17
#define BT_PI_HI 3.141592653589793
#define BT_PI_LO 1.2246467991473532e-16

BT_MATH_INLINE double bt_atan_unit(double t)
{
    /* fmin/fmax also map a NaN t to j = 0. */
    int j = (int)fmin(fmax(t * 4.0 + 0.5, 0.0), 4.0);
    double c = 0.25 * (double)j;
    double u = (t - c) / (1.0 + c * t);
    double z = u * u;
    double p = 1.0 / 21.0;
    p = p * z - 1.0 / 19.0;
    p = p * z + 1.0 / 17.0;
    p = p * z - 1.0 / 15.0;
    p = p * z + 1.0 / 13.0;
    p = p * z - 1.0 / 11.0;
    p = p * z + 1.0 / 9.0;
    p = p * z - 1.0 / 7.0;
    p = p * z + 1.0 / 5.0;
    p = p * z - 1.0 / 3.0;
    double atan_u = u + u * z * p;
    /* atan(j / 4) as hi + lo, picked by j >= ... (0 <= j <= 4): a chain of
     * j == ... tests is turned into a table load, a gather that an AVX2
     * target cannot mask when it sits under a branch. */
    double hi = j >= 4 ? 0.7853981633974483
              : j >= 3 ? 0.6435011087932844
              : j >= 2 ? 0.4636476090008061
              : j >= 1 ? 0.24497866312686414 : 0.0;
    double lo = j >= 4 ? 3.061616997868383e-17
              : j >= 3 ? 1.5834785051444286e-17
              : j >= 2 ? 2.2698777452961687e-17
              : j >= 1 ? 1.0698755618734451e-17 : 0.0;
    return hi + (lo + atan_u);
}

/* atan x = sign(x) (pi/2 - atan(1/|x|)) for |x| > 1. */
BT_MATH_INLINE double bt_atan(double x)
{
    double a = fabs(x);
    int big = a > 1.0;
    double r = bt_atan_unit(big ? 1.0 / a : a);
    r = big ? (BT_PIO2_HI - r) + BT_PIO2_LO : r;
    return copysign(r, x);
}

/* atan2(y, x) in [-pi, pi]: the angle of min(|x|,|y|)/max(|x|,|y|) in
 * [0, pi/4], reflected into the octant of (x, y).  C99's special values:
 * atan2(+-0, +0) = +-0, atan2(+-0, -0) = +-pi, atan2(+-inf, +-inf) = odd
 * multiples of pi/4.  Conditions are combined with & and |, not && and ||:
 * measured, the short-circuit branches kept PoCL from vectorising it. */
BT_MATH_INLINE double bt_atan2(double y, double x)
{
    double ax = fabs(x), ay = fabs(y);
    double hi = fmax(ax, ay), lo = fmin(ax, ay);
    double t = hi > 0.0 ? lo / hi : 0.0;
    t = ((ax == BT_M_INF) & (ay == BT_M_INF)) ? 1.0 : t;
    double r = bt_atan_unit(t);
    r = ay > ax ? (BT_PIO2_HI - r) + BT_PIO2_LO : r;
    /* Left half-plane; x = -0 only for y = +-0 (else the angle is +-pi/2). */
    int left = (x < 0.0) | (bt_sign_bit(x) & (ay == 0.0));
    r = left ? (BT_PI_HI - r) + BT_PI_LO : r;
    return copysign(r, y);
}

/* asin and acos through atan (which vectorises; measured, the atan2 form
 * did not):
 *   asin x = atan(x / sqrt((1 - x)(1 + x))),
 *   acos x = 2 atan(sqrt((1 - x) / (1 + x)))   (half-angle: tan(t/2) =
 *            sqrt((1 - cos t)/(1 + cos t))).
 * 1 - x is exact for x in [1/2, 1], so both keep full relative precision
 * near +-1 (acos x ~ sqrt(2 (1 - x))); x = +-1 gives atan(+-inf) = +-pi/2
 * and acos(-1) = 2 atan(inf) = pi exactly as doubles. */
BT_MATH_INLINE double bt_asin(double x) { return bt_atan(x / sqrt((1.0 - x) * (1.0 + x))); }
BT_MATH_INLINE double bt_acos(double x) { return 2.0 * bt_atan(sqrt((1.0 - x) / (1.0 + x))); }

/* ------------------------------------------------------------------ erf
 * PoCL's double erf is an out-of-line call (Sleef_erf_u10, "too costly to
 * inline"), which keeps every kernel that calls it (Beckmann's Smith G1)
 * from being vectorised across work items.  Two branch-free pieces, both
 * evaluated, one selected (a = |x|):
 *   a < 2.5:  erf a = (2/sqrt(pi)) a exp(-a^2) sum_n (2a^2)^n / (1 3 5 ... (2n+1))
 *             (the series of erf times exp(a^2): every term positive, so no
 *             cancellation), summed by Horner to n = 36: the next term is
 *             below 3e-17 of the sum at a = 2.5 and far smaller below;
 *   a >= 2.5: erf a = 1 - erfc a with Laplace's continued fraction
 *             erfc a = exp(-a^2)/sqrt(pi) / (a + (1/2)/(a + 1/(a + (3/2)/(a + ...))))
 *             cut after 30 levels (measured: erfc within 1.5e-14 relative at
 *             a = 2.5, better above; erfc(2.5) = 4.1e-4, so erf is off by
 *             < 1e-17).
 * Both pieces read exp(-a^2) from bt_exp.  The result is odd in x (signed
 * zero kept).  Measured against glibc's long double erfl in
 * tests/test_kernel_math.cpp (docs/contributing.md). */
/* Fixed-count loops are unrolled on the device: a loop left inside the
 * kernel body makes PoCL's work-item loop an outer loop, which LLVM's loop
 * vectoriser does not touch. */
#if BT_DEVICE
#define BT_MATH_UNROLL _Pragma("unroll")
#else
#define BT_MATH_UNROLL
#endif
#define BT_ERF_SERIES_TERMS 36
#define BT_ERF_CF_LEVELS 30
#define BT_TWO_OVER_SQRT_PI 1.12837916709551257390
#define BT_INV_SQRT_PI 0.56418958354775628695

BT_MATH_INLINE double bt_erf(double x)
{
    double a = fabs(x);
    double as = fmin(a, 2.5); /* the series' argument (large a: unused) */
    double ac = fmax(a, 2.5); /* the fraction's argument (small a: unused) */
    double e = bt_exp(-a * a);
    double z = 2.0 * as * as;
    double sum = 1.0;
    BT_MATH_UNROLL
    for (int n = BT_ERF_SERIES_TERMS; n >= 1; --n) sum = 1.0 + sum * z * (1.0 / (double)(2 * n + 1));
    double series = BT_TWO_OVER_SQRT_PI * as * e * sum;
    double f = ac;
    BT_MATH_UNROLL
    for (int n = BT_ERF_CF_LEVELS; n >= 1; --n) f = ac + (0.5 * (double)n) / f;
    double tail = 1.0 - BT_INV_SQRT_PI * e / f;
    double r = a < 2.5 ? series : tail;
    r = copysign(r, x);
    return x != x ? x : r;
}

/* ----------------------------------------------------------------- erfc
 * PoCL's double erfc (Sleef_erfc_u15) is an out-of-line call ("too costly
 * to inline"), which took a third of the device time of the Beckmann
 * visible-normal sampler (perf: 33 % for interfaced-lambertian's body).  This one is branch-free
 * arithmetic with one polynomial for the whole half-line and no table.
 * With a = |x| and the substitution of Shepherd and Laframboise (Math. Comp.
 * 36, 1981),
 *   f(a) = (1 + 2a) exp(a^2) erfc a,   t = (a - 3) / (a + 3),
 *   erfc a = exp(-a^2) f / (1 + 2a),
 * f runs smoothly from f(0) = 1 to 2/sqrt(pi) = 1.128 as a -> inf, and t
 * maps [0, 28] onto [-1, 0.806].  f is written 1 + (1 + t) h(t), so f - 1
 * (which vanishes at a = 0) keeps its relative precision, and h is the
 * degree-24 polynomial interpolating (f - 1)/(1 + t) at 25 Chebyshev points
 * of that t range (coefficients computed for this file in 60-digit
 * arithmetic and rounded to double): interpolation error below 0.13 * 2^-53
 * of f, so rounding sets the accuracy.  1 + t is formed as 2a / (a + 3),
 * not from a rounded t, which would cost f - 1 its relative precision near
 * a = 0.
 * exp(-a^2) needs a^2 to more than double precision (a^2 ~ 700 near the
 * underflow, where one rounding of a^2 alone would cost up to 5.7e-14
 * relative, hundreds of ulp).
 * a^2 = hi + lo with hi = z^2, z = a with its low 27 significand bits
 * cleared (26 left, so z^2 is exact), lo = (a - z)(a + z) (|lo| < 2^-24
 * a^2, its own rounding negligible); then bt_exp's reduction and Taylor
 * polynomial with lo carried into the reduced argument r, and exp r kept as
 * 1 + w, w = exp r - 1, so that no intermediate is rounded just above 1.
 * Near zero (a < 15/32, erfc a > 0.5, where n = 0 below) the result is
 * formed as 1 - delta, delta = (1 + 2a - (1 + w) f) / (1 + 2a)
 *   = (2a - (f - 1) - w f) / (1 + 2a),
 * which has no cancellation there and whose rounding is scaled by delta.
 * erfc rounds to 0 from a = 27.23 on (erfc 27.25 = 6.7e-325, below half
 * the smallest denormal), so a is clamped at 28; x < 0 uses erfc x = 2 - erfc(-x) (>= 1: no
 * cancellation).  Measured against glibc's long double erfcl and 36-digit
 * references in tests/test_bt_erfc.cpp: within 2.4 ulp, host and device. */
#define BT_ERFC_K 3.0
#define BT_ERFC_A_MAX 28.0
#define BT_ERFC_NEAR_ZERO 0.46875

BT_MATH_INLINE double bt_erfc_scaled_poly(double t)
{
    /* Estrin's scheme: the same polynomial as Horner's rule, in five levels
     * of independent products instead of a chain of 24 dependent ones.
     * Measured: with Horner's rule the
     * chain's latency made the serial host slower than with glibc's erfc,
     * and the device gained less. */
    double t2 = t * t, t4 = t2 * t2, t8 = t4 * t4, t16 = t8 * t8;
    double c0 = 0.25300805826972966 - 0.38862916439431083 * t;
    double c1 = 0.34106687004085967 - 0.21142171133809767 * t;
    double c2 = 0.09214804792282201 - 0.023840020578874244 * t;
    double c3 = 6.950565925160184e-05 + 0.0024598861569852504 * t;
    double c4 = -0.000571195783818694 - 0.00020863648652590645 * t;
    double c5 = 0.00010347657473545704 + 2.1622746739099145e-05 * t;
    double c6 = -1.6672711775565187e-05 - 3.42765423906889e-06 * t;
    double c7 = 2.694395094163832e-06 + 7.772634166366107e-07 * t;
    double c8 = -4.1674496140417014e-07 - 1.9811902397061218e-07 * t;
    double c9 = 5.1411688427551114e-08 + 4.774131982870251e-08 * t;
    double c10 = -1.4278670018172534e-09 - 9.303009750699454e-09 * t;
    double c11 = -1.4941481580841011e-09 + 1.06161474927946e-09 * t;
    double c12 = 3.4111508280225094e-10;
    double d0 = c0 + c1 * t2;
    double d1 = c2 + c3 * t2;
    double d2 = c4 + c5 * t2;
    double d3 = c6 + c7 * t2;
    double d4 = c8 + c9 * t2;
    double d5 = c10 + c11 * t2;
    double d6 = c12;
    double e0 = d0 + d1 * t4;
    double e1 = d2 + d3 * t4;
    double e2 = d4 + d5 * t4;
    double e3 = d6;
    double g0 = e0 + e1 * t8, g1 = e2 + e3 * t8;
    return g0 + g1 * t16;
}

BT_MATH_INLINE double bt_erfc(double x)
{
    double a = fmin(fabs(x), BT_ERFC_A_MAX); /* NaN: 28, replaced below */
    double one_plus_t = 2.0 * a / (a + BT_ERFC_K);
    double t = one_plus_t - 1.0;
    double f_minus_1 = one_plus_t * bt_erfc_scaled_poly(t);
    double f = 1.0 + f_minus_1;
    /* exp(-(hi + lo)) = 2^n exp(r): n * BT_LN2_HI is exact (32-bit
     * constant, |n| < 2^11) and so is -hi - n * BT_LN2_HI (Sterbenz: both
     * within a factor 2 once n != 0). */
    double z = bt_double_of(bt_bits_of(a) & (bt_i64)0xfffffffff8000000LL);
    double hi = z * z;
    double lo = (a - z) * (a + z);
    double n = bt_round_small(-(hi + lo) * BT_LOG2_E);
    double r = (-hi - n * BT_LN2_HI) - (lo + n * BT_LN2_LO);
    /* exp(r) - 1 = r + r^2 (1/2! + r/3! + ... + r^11/13!), bt_exp's Taylor
     * polynomial, by Estrin's scheme (shorter latency than Horner's rule). */
    double r2 = r * r, r4 = r2 * r2, r8 = r4 * r4;
    double q0 = 1.0 / 2.0 + (1.0 / 6.0) * r;
    double q1 = 1.0 / 24.0 + (1.0 / 120.0) * r;
    double q2 = 1.0 / 720.0 + (1.0 / 5040.0) * r;
    double q3 = 1.0 / 40320.0 + (1.0 / 362880.0) * r;
    double q4 = 1.0 / 3628800.0 + (1.0 / 39916800.0) * r;
    double q5 = 1.0 / 479001600.0 + (1.0 / 6227020800.0) * r;
    double q = (q0 + q1 * r2) + (q2 + q3 * r2) * r4 + (q4 + q5 * r2) * r8;
    double w = r + r2 * q;                       /* exp(r) - 1 */
    int near_zero = a < BT_ERFC_NEAR_ZERO;
    double d = 1.0 + 2.0 * a;
    double num = near_zero ? (2.0 * a - f_minus_1) - w * f : 1.0 + (f_minus_1 + w * f);
    /* Divide by 1 + 2a exactly: d + d_lo = 1 + 2a (Fast2Sum, the larger
     * addend first), and (num/d)(1 - d_lo/d) is the quotient up to a term
     * of order 2^-106 (measured: this takes the worst error from 2.9 to 2.2
     * ulp on [1, 3]). */
    double d_lo = a < 0.5 ? (1.0 - d) + 2.0 * a : (2.0 * a - d) + 1.0;
    double m0 = num / d;
    double m = m0 - m0 * (d_lo / d);
    /* 2^n as two factors after the (normal) mantissa, so that a denormal
     * result is rounded once. */
    int k = (int)n;
    int k1 = k >> 1;
    double v = m * bt_pow2i(k1) * bt_pow2i(k - k1);
    double positive = near_zero ? 1.0 - m : v;
    double negative = near_zero ? 1.0 + m : 2.0 - v;
    double result = x < 0.0 ? negative : positive;
    return x != x ? x : result;
}

#endif /* double */

/* acos of an argument clamped to [-1, 1], for cosines that rounding pushed
 * just outside. */
BT_MATH_INLINE REAL bt_safe_acos(REAL x) { return bt_acos(bt_clamp(x, R(-1.0), R(1.0))); }

#endif /* BRDFTAB_BT_MATH_H */

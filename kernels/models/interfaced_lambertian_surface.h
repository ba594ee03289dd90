/*
 * interfaced_lambertian_surface.h — the microfacet surface of the interfaced
 * Lambertian model (Meneveaux et al. 2018, see interfaced_lambertian.h and
 * docs/models/interfaced-lambertian.md): the facets' interface optics
 * (T = 1 - F, r_e, r_i, eqs. 7, 9-10, the body prefactor of eq. 12), the
 * distributions of normals with their GAFs (eqs. 13-21, Table 2) and the
 * samplers of m.  Shared by the model (interfaced_lambertian.h) and its
 * V-cavity multiple-reflection estimator (interfaced_lambertian_vcavity.h).
 *
 * il_make_surface reads the point and options in the layout documented in
 * interfaced_lambertian.h: p[4] sigma, p[5] alpha, p[6] alpha_x, p[7] alpha_y,
 * o[0] distribution.
 */
#ifndef BRDFTAB_INTERFACED_LAMBERTIAN_SURFACE_H
#define BRDFTAB_INTERFACED_LAMBERTIAN_SURFACE_H

#include "../common/compat.h"
#include "../common/bt_math.h"
#include "../common/fresnel.h"
#include "../common/gauss_legendre.h"
#include "../common/microfacet.h"
#include "../common/sampler.h"
#include "../common/vec3.h"

/* The model contract: slots of the point p[] and of the options o[]
 * (quantity ids: IL_Q_* in interfaced_lambertian.h).  host/models/interfaced_lambertian.cpp registers the
 * model by these names; p[0..3] are the directions (estimator.h). */
#define IL_PARAM_SIGMA 4
#define IL_PARAM_ALPHA 5
#define IL_PARAM_ALPHA_X 6
#define IL_PARAM_ALPHA_Y 7
#define IL_PARAM_NI 8
#define IL_PARAM_KD 9
#define IL_PARAM_ORDER 10
#define IL_PARAM_COUNT 7
#define IL_OPT_DISTRIBUTION 0
#define IL_OPT_SAMPLING 1
#define IL_OPT_INTERREFLECTION 2
#define IL_OPT_COUNT 3

#if !BT_DEVICE
using std::asin;
using std::expm1;
using std::log1p;
#endif

/* Option o[0]: distribution of normals and its GAF (Table 2). */
#define IL_GAUSSIAN_TS 0
#define IL_BECKMANN_TS 1
#define IL_BECKMANN_SMITH 2
#define IL_GGX_SMITH 3

/* Option o[1]: how m is sampled. */
#define IL_SAMPLING_VISIBLE 0
#define IL_SAMPLING_DISTRIBUTION 1

/* Philox dimensions of the Gaussian rejection sampler (the model's map of
 * random dimensions is in interfaced_lambertian.h) and its number of tries. */
#ifndef IL_DIM_REJECT
#define IL_DIM_REJECT 1000u
#endif
#define IL_REJECT_TRIES 48

/* Interface transmittance T = 1 - F (eq. 7) for light crossing from outside
 * (index 1) into the facet's medium (index ni). */
BT_INLINE REAL il_t(REAL cos_theta, REAL ni)
{
    return R(1.0) - bt_fresnel_dielectric(cos_theta, ni);
}

/* ------------------------------------------------------ r_e and r_i (eqs. 9-10) */

/* Integrand variable mu = cos theta; r_e = int_0^1 F(mu) 2 mu dmu (the
 * external hemispherical reflectance for Lambertian light, eq. 9 with the
 * external Fresnel).  Near ni = 1, F climbs from ~0 to 1 in a boundary layer
 * mu ~ sqrt(ni^2 - 1): the rule is split at a = min(1, 8 sqrt(ni^2 - 1)). */
BT_INLINE REAL il_re_quadrature(REAL ni, int n)
{
    REAL a = fmin(R(1.0), R(8.0) * bt_safe_sqrt(ni * ni - R(1.0)));
    if (!(a > R(0.0))) return R(0.0);
    REAL sum = R(0.0), w;
    for (int panel = 0; panel < 2; ++panel) {
        REAL lo = panel == 0 ? R(0.0) : a, hi = panel == 0 ? a : R(1.0);
        if (!(hi > lo)) continue;
        for (int k = 0; k < n; ++k) {
            REAL mu = bt_gauss_legendre_table(n, k, lo, hi, &w);
            sum += w * bt_fresnel_dielectric(mu, ni) * R(2.0) * mu;
        }
    }
    return sum;
}

/* Eq. 9 integrated literally over the internal angle theta in [0, pi/2] with
 * the internal Fresnel (eta = 1/ni): beyond the critical angle theta_c F = 1
 * (contributing cos^2 theta_c); below it F has a square-root singularity at
 * theta_c, removed by theta = theta_c (1 - t^2). */
BT_INLINE REAL il_ri_quadrature(REAL ni, int n)
{
    if (!(ni > R(1.0))) return R(0.0);
    REAL inv = R(1.0) / ni;
    REAL tc = bt_asin(fmin(inv, R(1.0)));
    REAL sum = R(1.0) - inv * inv, w; /* int_{theta_c}^{pi/2} sin 2theta = cos^2 theta_c */
    for (int k = 0; k < n; ++k) {
        REAL t = bt_gauss_legendre_table(n, k, R(0.0), R(1.0), &w);
        REAL th = tc * (R(1.0) - t * t);
        sum += w * bt_fresnel_dielectric(bt_cos(th), inv) * bt_sin(R(2.0) * th) * R(2.0) * tc * t;
    }
    return sum;
}

/* Molenaar et al.'s closed form, eq. 10.  It cancels catastrophically as
 * ni -> 1 (terms ~ 1/(ni^4 - 1)^2 sum to ~ (ni - 1)/3); there we use the
 * quadrature above (measured: 32-point split rule agrees with eq. 10 to
 * 1e-15 for ni >= 1.01 in double). */
BT_INLINE REAL il_re(REAL ni)
{
#if defined(BT_REAL_IS_FLOAT) && BT_REAL_IS_FLOAT && BT_DEVICE
    const REAL closed_from = R(1.3);
#else
    const REAL closed_from = R(1.01);
#endif
    if (ni < closed_from) return il_re_quadrature(ni, 32);
    REAL n2 = ni * ni, n3 = n2 * ni, n4 = n2 * n2;
    REAL q = n4 - R(1.0);
    REAL re = R(0.5) - R(2.0) * n3 * (n2 + R(2.0) * ni - R(1.0)) / ((n2 + R(1.0)) * q) +
              (ni - R(1.0)) * (R(3.0) * ni + R(1.0)) / (R(6.0) * bt_sqr(ni + R(1.0))) +
              R(8.0) * n4 * (n4 + R(1.0)) / ((n2 + R(1.0)) * q * q) * bt_log(ni) +
              n2 * bt_sqr(n2 - R(1.0)) / ((n2 + R(1.0)) * (n2 + R(1.0)) * (n2 + R(1.0))) *
                  bt_log((ni - R(1.0)) / (ni + R(1.0))); /* eq. 10 */
    return re;
}

/* n_i^2 (1 - r_i) = 1 - r_e (text after eq. 9). */
BT_INLINE REAL il_ri(REAL ni) { return R(1.0) - (R(1.0) - il_re(ni)) / (ni * ni); }

/* Body prefactor of eq. 12: Kd / (pi ni^2 (1 - ri Kd)). */
BT_INLINE REAL il_body_prefactor(REAL kd, REAL ni)
{
    return kd * BT_INV_PI / (ni * ni * (R(1.0) - il_ri(ni) * kd));
}

/* ------------------------------------------------------ distributions */

typedef struct {
    int dist;        /* IL_* distribution/GAF pair */
    REAL sigma;      /* Gaussian width (radians) */
    REAL gauss_c;    /* Gaussian normalisation C of eq. 13 (0 until needed) */
    bt_microfacet mf; /* Beckmann/GGX widths, exact Smith G1, separable (eq. 16) */
} il_surface;

BT_INLINE il_surface il_make_surface(const REAL* p, const int* o)
{
    il_surface s;
    s.dist = o[IL_OPT_DISTRIBUTION];
    s.sigma = fmax(p[IL_PARAM_SIGMA], R(0.0));
    s.gauss_c = R(0.0);
    REAL ax = p[IL_PARAM_ALPHA_X] > R(0.0) ? p[IL_PARAM_ALPHA_X] : p[IL_PARAM_ALPHA];
    REAL ay = BT_SLP_SPLIT(p[IL_PARAM_ALPHA_Y] > R(0.0) ? p[IL_PARAM_ALPHA_Y] : p[IL_PARAM_ALPHA]); /* compat.h */
    s.mf = bt_microfacet_make(s.dist == IL_GGX_SMITH ? BT_MF_GGX : BT_MF_BECKMANN, BT_G1_EXACT,
                              BT_SHADOW_SEPARABLE, ax, ay);
    return s;
}

/* 1/C = 2 pi int_0^{pi/2} exp(-theta^2 / 2 sigma^2) sin theta dtheta (eq. 13),
 * 32-point Gauss-Legendre on [0, min(pi/2, 10 sigma)] (the integrand is
 * below exp(-50) beyond 10 sigma). */
BT_INLINE REAL il_gaussian_norm(REAL sigma)
{
    REAL b = fmin(BT_HALF_PI, R(10.0) * sigma);
    REAL sum = R(0.0), w;
    for (int k = 0; k < 32; ++k) {
        REAL t = bt_gauss_legendre_table(32, k, R(0.0), b, &w);
        sum += w * bt_exp(-t * t / (R(2.0) * sigma * sigma)) * bt_sin(t);
    }
    return R(1.0) / (BT_TWO_PI * sum);
}

/* D(m), eq. 13 (Gaussian), 15 (Beckmann), 20 (GGX, see header). */
BT_INLINE REAL il_d(il_surface* s, bt_vec3 m)
{
    if (!(m.z > R(0.0))) return R(0.0);
    if (s->dist == IL_GAUSSIAN_TS) {
        if (!(s->sigma > R(1e-7))) return R(0.0); /* a Dirac at n */
        if (s->gauss_c == R(0.0)) s->gauss_c = il_gaussian_norm(s->sigma);
        REAL th = bt_safe_acos(m.z);
        REAL e = th * th / (R(2.0) * s->sigma * s->sigma);
        if (e > R(80.0)) return R(0.0);
        return s->gauss_c * bt_exp(-e) / m.z;
    }
    return bt_mf_d(&s->mf, m);
}

/* Torrance-Sparrow GAF, eq. 14 (V-cavities), with chi+ on both sides:
 * max(0, min(1, 2|i.n||m.n|/|i.m|, 2|o.n||m.n|/|o.m|)). */
BT_INLINE REAL il_g_ts(bt_vec3 i, bt_vec3 o, bt_vec3 m)
{
    REAL im = bt_v3_dot(i, m), om = bt_v3_dot(o, m);
    if (!(im > R(0.0)) || !(om > R(0.0)) || !(m.z > R(0.0))) return R(0.0);
    REAL g = fmin(R(1.0), fmin(R(2.0) * i.z * m.z / im, R(2.0) * o.z * m.z / om));
    return fmax(g, R(0.0));
}

/* G(i, o, m) of the chosen pair: TS (eq. 14) or Smith (eqs. 16-19, 21). */
BT_INLINE REAL il_g(const il_surface* s, bt_vec3 i, bt_vec3 o, bt_vec3 m)
{
    if (s->dist == IL_GAUSSIAN_TS || s->dist == IL_BECKMANN_TS) return il_g_ts(i, o, m);
    return bt_mf_g(&s->mf, i, o, m);
}

/* Gaussian of normals, m with pdf D(m)|m.n| = C exp(-theta^2/2sigma^2)
 * (solid angle).  In theta the density is prop. to exp(-theta^2/2sigma^2)
 * sin(theta) on [0, pi/2]; no closed-form inverse (paper, end of §4.1), so we
 * draw theta from the truncated Rayleigh density prop. to
 * theta exp(-theta^2/2sigma^2) (inverse CDF) and accept with probability
 * sin(theta)/theta >= 2/pi.  The accepted m has exactly the pdf D|m.n|, so
 * estimators never need C.  Tries after the first use Philox dimensions
 * IL_DIM_REJECT..; after IL_REJECT_TRIES (failure probability < 1e-20) the
 * last candidate is kept. */
BT_INLINE bt_vec3 il_sample_gaussian(REAL sigma, const bt_sampler* smp, uint d0, uint d1)
{
    REAL s2 = R(2.0) * sigma * sigma;
    REAL mass = -expm1(-BT_HALF_PI * BT_HALF_PI / s2); /* Rayleigh CDF at pi/2 */
    REAL th = R(0.0);
    for (int k = 0; k < IL_REJECT_TRIES; ++k) {
        REAL u = k == 0 ? bt_uniform(smp, d0) : bt_uniform(smp, IL_DIM_REJECT + 2u * (uint)k);
        REAL a = bt_uniform(smp, IL_DIM_REJECT + 2u * (uint)k + 1u);
        th = fmin(sqrt(-s2 * bt_log1p(-u * mass)), BT_HALF_PI);
        REAL ratio = th > R(1e-6) ? bt_sin(th) / th : R(1.0);
        if (a < ratio) break;
    }
    REAL phi = BT_TWO_PI * bt_uniform(smp, d1);
    REAL ct, cp;
    REAL st = bt_sincos(th, &ct);
    REAL sp = bt_sincos(phi, &cp);
    return bt_v3(st * cp, st * sp, ct);
}

/* pdf-free sample of m ~ D|m.n| for every pair (Gaussian: rejection above;
 * Beckmann/GGX: eqs. 29-31 through microfacet.h). */
BT_INLINE bt_vec3 il_sample_distribution(const il_surface* s, const bt_sampler* smp)
{
    if (s->dist == IL_GAUSSIAN_TS) return il_sample_gaussian(s->sigma, smp, 0u, 1u);
    REAL pdf;
    return bt_mf_sample(&s->mf, bt_uniform(smp, 0u), bt_uniform(smp, 1u), &pdf);
}

BT_INLINE int il_uses_visible(const il_surface* s, int sampling)
{
    return sampling == IL_SAMPLING_VISIBLE && s->dist != IL_GAUSSIAN_TS;
}

#endif /* BRDFTAB_INTERFACED_LAMBERTIAN_SURFACE_H */

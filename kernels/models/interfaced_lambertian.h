/*
 * interfaced_lambertian.h — rough interfaced Lambertian microfacets: every
 * microfacet is a flat dielectric interface (relative index ni = n1/n0) over
 * a Lambertian substrate of reflectance Kd.
 *
 * D. Meneveaux, B. Bringier, E. Tauzia, M. Ribardiere, L. Simonot,
 * "Rendering Rough Opaque Materials with Interfaced Lambertian Microfacets",
 * IEEE Transactions on Visualization and Computer Graphics 24(3), 2018
 * (preprint "Isotropic and Anisotropic Interfaced Lambertian Microfacets",
 * 2015; equation numbers below are the preprint's, restated in
 * /work/shared/MODELS.md §2).
 *
 * Point p[] (kernels/common/estimator.h layout):
 *   p[0] theta_i, p[1] phi_i, p[2] theta_o, p[3] phi_o   radians; theta > pi/2
 *        (below the surface) gives 0: the material is opaque.
 *   p[4]  sigma    Gaussian-of-normals width (radians; gaussian-ts only, eq. 13)
 *   p[5]  alpha    Beckmann/GGX width (isotropic), eqs. 15, 20
 *   p[6]  alpha_x  anisotropic width along +x; 0 = use alpha
 *   p[7]  alpha_y  anisotropic width along +y; 0 = use alpha
 *   p[8]  ni       relative index n1/n0 (>= 1)
 *   p[9]  kd       substrate reflectance (brdf, albedo_body, Rb, vcavity)
 *   p[10] order    vcavity only: 0 = all bounce orders up to IL_MAX_BOUNCES (128),
 *                  k >= 1 = only paths with exactly k facet interactions
 * Options o[]:
 *   o[0] distribution  0 gaussian-ts, 1 beckmann-ts, 2 beckmann-smith,
 *                      3 ggx-smith (Table 2)
 *   o[1] sampling      0 visible normals (Beckmann/GGX), 1 the distribution
 *                      D(m)|m.n| (eqs. 29-31).  Gaussian always samples
 *                      D(m)|m.n| (by rejection, see il_sample_gaussian).
 *   o[2] interreflection  vcavity only: 0 full (each facet hit reflects
 *                      specularly with probability F or enters the body),
 *                      1 body (specular reflections inside the cavity are
 *                      dropped; only body events continue the path)
 * Quantities: see the IL_Q_* list.
 *
 * Departures from the paper (all flagged where they occur):
 *  - eq. 3 as printed divides by 4|i.h||o.h|; eqs. 2 and 5 give
 *    4|i.n||o.n| (Walter 2007 eq. 20), which is what we use.
 *  - eq. 20 (GGX) as printed swaps sigma_x/sigma_y relative to eq. 15; we use
 *    the standard anisotropic GGX with eq. 15's axes (microfacet.h).
 *  - The Gaussian distribution (eq. 13) is isotropic only.
 *  - vcavity: the paper bins exits on a hemispherical sensor (eq. 23); we
 *    connect every body event to the exact direction o with its analytic
 *    visibility in the V-cavity (a point estimator of eq. 22).
 */
#ifndef BRDFTAB_INTERFACED_LAMBERTIAN_H
#define BRDFTAB_INTERFACED_LAMBERTIAN_H

#include "../common/compat.h"
#include "../common/fresnel.h"
#include "../common/microfacet.h"
#include "../common/sampler.h"
#include "../common/vec3.h"

#if !BT_DEVICE
using std::asin;
using std::expm1;
using std::log1p;
#endif

#define IL_Q_BODY 0
#define IL_Q_BRDF 1
#define IL_Q_SPECULAR 2
#define IL_Q_RE 3
#define IL_Q_RI 4
#define IL_Q_RE_INTEGRAL 5
#define IL_Q_RI_INTEGRAL 6
#define IL_Q_RS 7
#define IL_Q_RB 8
#define IL_Q_ALBEDO_BODY 9
#define IL_Q_ALBEDO_SPECULAR 10
#define IL_Q_VCAVITY 11

/* The model contract: slots of the point p[] and of the options o[] and the
 * number of quantities (ids IL_Q_* above).  host/models/interfaced_lambertian.cpp registers
 * the model by these names; p[0..3] are the directions (estimator.h). */
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
#define IL_Q_COUNT 12

#define IL_GAUSSIAN_TS 0
#define IL_BECKMANN_TS 1
#define IL_BECKMANN_SMITH 2
#define IL_GGX_SMITH 3

#define IL_SAMPLING_VISIBLE 0
#define IL_SAMPLING_DISTRIBUTION 1

#define IL_INTERREFLECTION_FULL 0
#define IL_INTERREFLECTION_BODY 1

/* Floor on cos(theta) of i and o: grazing directions give the finite grazing
 * limit instead of 0/0 (the GAFs vanish like cos theta). */
#define IL_MIN_COS R(1e-9)
/* Bounce cut-off of the V-cavity walk (order = 0). */
#ifndef IL_MAX_BOUNCES
#define IL_MAX_BOUNCES 128
#endif
/* Random dimensions: 0-1 microfacet normal, 2 start point in the cavity,
 * 3.. V-cavity bounces (4 per bounce, < 520), 700.. V-cavity roulette,
 * 2-3 the outgoing direction of albedo_body; the Gaussian rejection sampler
 * uses IL_DIM_REJECT.. (all dims >= 8 are Philox). */
#ifndef IL_DIM_REJECT
#define IL_DIM_REJECT 1000u
#endif
#define IL_REJECT_TRIES 48

/* 32-point Gauss-Legendre on [-1, 1], non-negative half (symmetric). */
BT_TABLE REAL il_gl32_x[16] = {
    R(0.04830766568773831), R(0.14447196158279649), R(0.23928736225213706),
    R(0.33186860228212767), R(0.42135127613063533), R(0.50689990893222936),
    R(0.5877157572407623),  R(0.66304426693021523), R(0.73218211874028971),
    R(0.79448379596794239), R(0.84936761373256997), R(0.8963211557660522),
    R(0.93490607593773967), R(0.96476225558750639), R(0.98561151154526838),
    R(0.99726386184948157)};
BT_TABLE REAL il_gl32_w[16] = {
    R(0.096540088514727812), R(0.095638720079274833), R(0.093844399080804566),
    R(0.091173878695763863), R(0.087652093004403908), R(0.083311924226946846),
    R(0.078193895787070311), R(0.072345794108848449), R(0.065822222776361752),
    R(0.058684093478535704), R(0.050998059262376244), R(0.042835898022226426),
    R(0.034273862913021626), R(0.025392065309262427), R(0.016274394730905965),
    R(0.0070186100094692984)};
/* 16-point rule (the coarse rule of the quadrature quantities). */
BT_TABLE REAL il_gl16_x[8] = {R(0.095012509837637454), R(0.28160355077925892),
                              R(0.45801677765722737),  R(0.61787624440264377),
                              R(0.755404408355003),    R(0.86563120238783176),
                              R(0.9445750230732326),   R(0.98940093499164994)};
BT_TABLE REAL il_gl16_w[8] = {R(0.18945061045506859), R(0.18260341504492361),
                              R(0.16915651939500262), R(0.14959598881657676),
                              R(0.12462897125553403), R(0.095158511682492591),
                              R(0.062253523938647706), R(0.027152459411754037)};

/* Node k (0..n-1) and weight of the n-point rule (n = 32 or 16) mapped to
 * [a, b]. */
BT_INLINE REAL il_gl_node(int n, int k, REAL a, REAL b, REAL* w)
{
    int h = n / 2;
    int j = k < h ? h - 1 - k : k - h;
    REAL x = n == 32 ? il_gl32_x[j] : il_gl16_x[j];
    REAL ww = n == 32 ? il_gl32_w[j] : il_gl16_w[j];
    if (k < h) x = -x;
    *w = R(0.5) * (b - a) * ww;
    return a + R(0.5) * (b - a) * (x + R(1.0));
}

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
            REAL mu = il_gl_node(n, k, lo, hi, &w);
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
    REAL tc = asin(fmin(inv, R(1.0)));
    REAL sum = R(1.0) - inv * inv, w; /* int_{theta_c}^{pi/2} sin 2theta = cos^2 theta_c */
    for (int k = 0; k < n; ++k) {
        REAL t = il_gl_node(n, k, R(0.0), R(1.0), &w);
        REAL th = tc * (R(1.0) - t * t);
        sum += w * bt_fresnel_dielectric(cos(th), inv) * sin(R(2.0) * th) * R(2.0) * tc * t;
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
              R(8.0) * n4 * (n4 + R(1.0)) / ((n2 + R(1.0)) * q * q) * log(ni) +
              n2 * bt_sqr(n2 - R(1.0)) / ((n2 + R(1.0)) * (n2 + R(1.0)) * (n2 + R(1.0))) *
                  log((ni - R(1.0)) / (ni + R(1.0))); /* eq. 10 */
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
    REAL ay = p[IL_PARAM_ALPHA_Y] > R(0.0) ? p[IL_PARAM_ALPHA_Y] : p[IL_PARAM_ALPHA];
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
        REAL t = il_gl_node(32, k, R(0.0), b, &w);
        sum += w * exp(-t * t / (R(2.0) * sigma * sigma)) * sin(t);
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
        return s->gauss_c * exp(-e) / m.z;
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
        th = fmin(sqrt(-s2 * log1p(-u * mass)), BT_HALF_PI);
        REAL ratio = th > R(1e-6) ? sin(th) / th : R(1.0);
        if (a < ratio) break;
    }
    REAL phi = BT_TWO_PI * bt_uniform(smp, d1);
    REAL st = sin(th);
    return bt_v3(st * cos(phi), st * sin(phi), cos(th));
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

/* ------------------------------------------------------ directions */

/* Direction from (theta, phi); 0 when below the surface (opaque material). */
BT_INLINE int il_direction(REAL theta, REAL phi, bt_vec3* v)
{
    if (theta > BT_HALF_PI) return 0;
    REAL st = sin(theta);
    *v = bt_v3(st * cos(phi), st * sin(phi), fmax(cos(theta), IL_MIN_COS));
    return 1;
}

/* ------------------------------------------------------ body integral (eq. 12) */

/* One sample of
 *   B(i, o) = int T(i,m) T(o,m) D(m) G(i,o,m) |i.m||o.m| / (|i.n||o.n|) dw_m,
 * the integral of eq. 12 without its prefactor.
 *  visible: m ~ D_v from v, the one of i, o with the larger cosine (w is the
 *    other); pdf G1s(v) (v.m) D / v.z, weight T T G / G1s(v) |w.m| / w.z.
 *    Bounded: G <= G1(w) ~ w.z (Smith) or 2 w.z m.z / (w.m) (TS).
 *  distribution: m ~ D|m.n|, weight T T G |i.m||o.m| / (|i.n||o.n| m.z). */
BT_INLINE REAL il_body_sample(il_surface* s, int sampling, bt_vec3 i, bt_vec3 o, REAL ni,
                              const bt_sampler* smp)
{
    bt_vec3 m;
    if (il_uses_visible(s, sampling)) {
        int swap = o.z > i.z;
        bt_vec3 v = swap ? o : i, w = swap ? i : o;
        m = bt_mf_sample_visible(&s->mf, v, bt_uniform(smp, 0u), bt_uniform(smp, 1u));
        REAL vm = bt_v3_dot(v, m), wm = bt_v3_dot(w, m);
        if (!(vm > R(0.0)) || !(wm > R(0.0)) || !(m.z > R(0.0))) return R(0.0);
        REAL gs = bt_mf_g1_smith_nochi(&s->mf, v);
        if (!(gs > R(0.0))) return R(0.0);
        REAL g = il_g(s, i, o, m);
        return il_t(vm, ni) * il_t(wm, ni) * g / gs * wm / w.z;
    }
    m = il_sample_distribution(s, smp);
    REAL im = bt_v3_dot(i, m), om = bt_v3_dot(o, m);
    if (!(im > R(0.0)) || !(om > R(0.0)) || !(m.z > R(0.0))) return R(0.0);
    REAL g = il_g(s, i, o, m);
    return il_t(im, ni) * il_t(om, ni) * g * im * om / (i.z * o.z * m.z);
}

/* ------------------------------------------------------ specular term (eq. 3) */

/* f_s = F(i,h) D(h) G(i,o,h) / (4 |i.n||o.n|), h = normalize(i + o); eq. 3
 * as printed has 4|i.h||o.h| in the denominator (see header). */
BT_INLINE REAL il_specular(il_surface* s, bt_vec3 i, bt_vec3 o, REAL ni)
{
    bt_vec3 h = bt_v3_normalize(bt_v3_add(i, o));
    REAL F = bt_fresnel_dielectric(bt_v3_dot(i, h), ni); /* eq. 7 */
    REAL D = il_d(s, h);
    if (!(D > R(0.0))) return R(0.0);
    return F * D * il_g(s, i, o, h) / (R(4.0) * i.z * o.z);
}

/* ------------------------------------------------------ directional albedos */

/* Microfacet normal for the albedo estimators (dims 0-1) and the part of the
 * weight that depends on how it was drawn: 1/G1s(i) for visible normals
 * (pdf G1s(i) (i.m) D / |i.n|), (i.m)/(|i.n| m.z) for m ~ D|m.n|. */
BT_INLINE bt_vec3 il_albedo_normal(il_surface* s, int sampling, bt_vec3 i, const bt_sampler* smp,
                                   REAL* base)
{
    bt_vec3 m;
    if (il_uses_visible(s, sampling)) {
        m = bt_mf_sample_visible(&s->mf, i, bt_uniform(smp, 0u), bt_uniform(smp, 1u));
        REAL gs = bt_mf_g1_smith_nochi(&s->mf, i);
        *base = gs > R(0.0) ? R(1.0) / gs : R(0.0);
    } else {
        m = il_sample_distribution(s, smp);
        *base = m.z > R(0.0) ? bt_v3_dot(i, m) / (i.z * m.z) : R(0.0);
    }
    return m;
}

/* Body: E_b(i) = P int int T_i T_o D G (i.m)(o.m)/|i.n| dw_m dw_o, with P the
 * prefactor of eq. 12; m as in il_body_sample (from i), o ~ (o.m)/pi
 * (cosine about m, dims 2-3), weight P pi T_i T_o G / G1s(i) (visible) or
 * P pi T_i T_o G (i.m) / (|i.n| m.z) (distribution). */
BT_INLINE REAL il_albedo_body_sample(il_surface* s, int sampling, bt_vec3 i, REAL ni, REAL kd,
                                     const bt_sampler* smp)
{
    REAL base;
    bt_vec3 m = il_albedo_normal(s, sampling, i, smp, &base);
    REAL im = bt_v3_dot(i, m);
    if (!(im > R(0.0)) || !(m.z > R(0.0)) || !(base > R(0.0))) return R(0.0);
    /* cosine-weighted o about m */
    REAL r = sqrt(bt_uniform(smp, 2u)), ph = BT_TWO_PI * bt_uniform(smp, 3u);
    bt_vec3 t1 = fabs(m.z) < R(0.999) ? bt_v3_normalize(bt_v3_cross(bt_v3(R(0.0), R(0.0), R(1.0)), m))
                                      : bt_v3(R(1.0), R(0.0), R(0.0));
    bt_vec3 t2 = bt_v3_cross(m, t1);
    REAL ct = bt_safe_sqrt(R(1.0) - r * r);
    bt_vec3 o = bt_v3_add(bt_v3_add(bt_v3_scale(t1, r * cos(ph)), bt_v3_scale(t2, r * sin(ph))),
                          bt_v3_scale(m, ct));
    if (!(o.z > R(0.0))) return R(0.0);
    REAL g = il_g(s, i, o, m);
    return il_body_prefactor(kd, ni) * BT_PI * il_t(im, ni) * il_t(ct, ni) * g * base;
}

/* Specular: E_s(i) = int F(i,m) D G(i, o(m), m) (i.m)/|i.n| dw_m with
 * o = reflect(i, m) (dw_o = 4 (o.m) dw_m); weight F G / G1s(i) (visible) or
 * F G (i.m)/(|i.n| m.z) (distribution). */
BT_INLINE REAL il_albedo_specular_sample(il_surface* s, int sampling, bt_vec3 i, REAL ni,
                                         const bt_sampler* smp)
{
    REAL base;
    bt_vec3 m = il_albedo_normal(s, sampling, i, smp, &base);
    REAL im = bt_v3_dot(i, m);
    if (!(im > R(0.0)) || !(m.z > R(0.0)) || !(base > R(0.0))) return R(0.0);
    bt_vec3 o = bt_reflect(i, m);
    if (!(o.z > R(0.0))) return R(0.0);
    return bt_fresnel_dielectric(im, ni) * il_g(s, i, o, m) * base;
}

#include "interfaced_lambertian_vcavity.h"

/* ------------------------------------------------------ sample function */

BT_INLINE REAL interfaced_lambertian_sample(const REAL* p, const int* o, int quantity,
                                            const bt_sampler* smp)
{
    REAL ni = p[IL_PARAM_NI], kd = p[IL_PARAM_KD];
    if (quantity == IL_Q_RE || quantity == IL_Q_RS) return il_re(ni);
    if (quantity == IL_Q_RI) return il_ri(ni);
    if (quantity == IL_Q_RE_INTEGRAL) return il_re_quadrature(ni, smp->batch == 0u ? 32 : 16);
    if (quantity == IL_Q_RI_INTEGRAL) return il_ri_quadrature(ni, smp->batch == 0u ? 32 : 16);
    if (quantity == IL_Q_RB) {
        /* R_b = (1 - r_e)^2 Kd / (ni^2 (1 - Kd r_i)) (§4.1) */
        REAL re = il_re(ni);
        return bt_sqr(R(1.0) - re) * kd / (ni * ni * (R(1.0) - kd * il_ri(ni)));
    }
    il_surface s = il_make_surface(p, o);
    bt_vec3 vi, vo;
    if (!il_direction(p[0], p[1], &vi)) return R(0.0);
    if (quantity == IL_Q_ALBEDO_BODY) return il_albedo_body_sample(&s, o[IL_OPT_SAMPLING], vi, ni, kd, smp);
    if (quantity == IL_Q_ALBEDO_SPECULAR) return il_albedo_specular_sample(&s, o[IL_OPT_SAMPLING], vi, ni, smp);
    if (!il_direction(p[2], p[3], &vo)) return R(0.0);
    if (quantity == IL_Q_BODY) return il_body_sample(&s, o[IL_OPT_SAMPLING], vi, vo, ni, smp);
    if (quantity == IL_Q_SPECULAR) return il_specular(&s, vi, vo, ni);
    if (quantity == IL_Q_BRDF)
        return il_body_prefactor(kd, ni) * il_body_sample(&s, o[IL_OPT_SAMPLING], vi, vo, ni, smp) +
               il_specular(&s, vi, vo, ni); /* eq. 11 */
    if (quantity == IL_Q_VCAVITY)
        return il_vcavity_sample(&s, o[IL_OPT_SAMPLING], o[IL_OPT_INTERREFLECTION], vi, vo, ni, kd, (int)floor(p[IL_PARAM_ORDER] + R(0.5)), smp);
    return R(0.0);
}

#endif /* BRDFTAB_INTERFACED_LAMBERTIAN_H */

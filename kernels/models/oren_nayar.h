/*
 * oren_nayar.h — Oren–Nayar V-cavity body reflection: the exact facet
 * integral (eq. 25) with the two-bounce interreflection term, the
 * single-slope surfaces, and the paper's approximations.
 *
 * M. Oren, S. K. Nayar, "Generalization of Lambert's Reflectance Model",
 * Proc. SIGGRAPH '94, pp. 239-246, 1994.  doi:10.1145/192161.192213
 * Equation numbers are the paper's; the equations as implemented, with every
 * correction, are in docs/models/oren-nayar.md.
 *
 * Point p[] (kernels/common/estimator.h layout):
 *   p[0] theta_i, p[1] phi_i, p[2] theta_o, p[3] phi_o   radians
 *        (theta > pi/2, below the surface: every BRDF quantity is 0)
 *   p[4] sigma    std. deviation of the facet slope theta_a (radians), eq. 26
 *   p[5] rho      facet albedo (brdf, uni_slope, functional, qualitative,
 *                 approx_error, albedo, albedo_avg)
 *   p[6] theta_a  facet slope of the single-slope surfaces (radians)
 *   p[7] phi_a    cavity orientation of the uni-directional surface (radians)
 *   p[8] nodes    Gauss-Legendre nodes per sub-interval (quadrature method)
 * Options o[]:
 *   o[0] qualitative_a   0: A = 1 - 0.5 s2/(s2 + 0.33) (eq. 30),
 *                        1: 0.57 instead of 0.33 (footnote 7)
 *   o[1] approximation   approx_error: 0 functional (eqs. 27-29),
 *                        1 qualitative (eq. 30 with o[0]), 2 lambert (rho/pi)
 *   o[2] error           approx_error: 0 relative, 1 absolute
 * Quantities: see the ON_Q_* list below.
 *
 * Notation.  s = i (toward the light), v = o (toward the viewer), n = +z,
 * facet normal a = (theta_a, phi_a), the opposite facet of its cavity
 * a' = (theta_a, phi_a + pi).  All BRDF quantities are L_r / (E0 cos theta_i).
 * Per facet a (Table 1, eqs. 10-11; eqs. 15-20), divided by E0 cos theta_i:
 *   direct  F1(a) = <s,a><v,a> GAF / (pi <a,n><v,n><s,n>)   (per unit rho)
 *           if <s,a> > 0 and <v,a> > 0, else 0;
 *           GAF = max(0, min(1, X, Y)), X = 2<s,n><a,n>/<s,a>,
 *           Y = 2<v,n><a,n>/<v,a>.
 *     DEPARTURE (typo fix): eqs. 11/38 as printed read Min[1, Max[0, X, Y]];
 *     the visible-and-lit fraction is min(1 - m_s/w, 1 - m_v/w) (eq. 33),
 *     i.e. the smaller of X and Y (docs/models/oren-nayar.md).
 *     F1 is evaluated as min(<s,a><v,a>/<a,n>, 2<s,n><v,a>, 2<v,n><s,a>)
 *     / (pi <v,n><s,n>), the three Table 1 rows, which stays finite as
 *     <a,n> -> 0.
 *   two-bounce  F2(a) = <a',s><a,v> IF / (pi^2 <a,n><v,n><s,n>)  (per rho^2)
 *           if <v,a> > 0 and <a',s> > 0; IF of eqs. 19-20 with
 *           m_v/w = clamp(-<a',v>/<a,v>, 0, 1) (eq. 15),
 *           m_s/w = clamp(-<a,s>/<a',s>, 0, 1) (eq. 16).
 * Gaussian surface (eqs. 25-26):
 *   f = int_0^{pi/2} p(theta_a) (1/2pi) int_0^{2pi} (rho F1 + rho^2 F2)
 *       dphi_a dtheta_a,   p = exp(-theta_a^2 / 2 sigma^2) sin theta_a / Z.
 *
 * Estimators (the same quantity id serves both; s->method picks):
 *   quadrature (BT_METHOD_QUADRATURE): tensor Gauss-Legendre.  phi_a is split
 *     at every analytically known kink, for the current theta_a: the zeros of
 *     <s,a>, <v,a> (facet turns away), <s,a'>, <v,a'> (start of shadowing /
 *     masking; also where X or Y crosses 1) and the X = Y line
 *     <a, <s,n> v - <v,n> s> = 0 (a fixed azimuth, since that vector is
 *     horizontal).  m_v, m_s reach 1 only where <v,a>, <s,a'> vanish, so IF
 *     adds no further kink.  theta_a in [0, T], T = min(pi/2, 8 sigma)
 *     (the truncated mass is < 1e-13), split at 3 sigma and at the slopes
 *     pi/2 - theta_i, pi/2 - theta_o where the phi_a kinks are born; the
 *     phi_a-integral grows there like (theta_a - theta_c)^{3/2}, so those
 *     sub-intervals use theta = theta_c + L t^2, which makes the leading
 *     singular term polynomial in t; also split where those kinks cross the
 *     X = Y azimuth (see on_gauss_quadrature).  The two-bounce term's thin
 *     boundary layers at grazing get a geometric phi_a mesh (on_add_graded).
 *     The normalisation Z is summed on the same theta_a nodes
 *     (self-normalised rule: exact for sigma -> 0).
 *     Batch 0 uses p[8] nodes per sub-interval, batch 1 half of them; the
 *     engine reports the difference as the error.
 *   rqmc / mc: theta_a from the Rayleigh density sigma^-2 theta
 *     exp(-theta^2/2sigma^2) truncated to [0, pi/2] (inverse CDF, dim 0),
 *     phi_a uniform (dim 1), weight (sin theta/theta) Z_R / Z with Z_R, Z in
 *     closed form (on_norm_ratio: Z by the sine series and regularised lower
 *     incomplete gamma functions of integer order).
 *   albedo* (dims 0-3) and albedo_avg* (dims 0-4): facet as above, outgoing
 *     direction cosine-weighted (dims 2, 3), theta_i with pdf 2 mu dmu (dim 4).
 *
 * Grazing.  cos theta of i and o is floored at ON_MIN_COS: the BRDF itself
 * grows like 1/cos when both directions graze (the backscatter ridge), so at
 * exactly 90 deg it returns the large-but-finite value at the floor.
 */
#ifndef BRDFTAB_OREN_NAYAR_H
#define BRDFTAB_OREN_NAYAR_H

#include "../common/compat.h"
#include "../common/bt_math.h"
#include "../common/gauss_legendre.h"
#include "../common/sampler.h"
#include "../common/vec3.h"

/* Quantity ids (the registry's `id`). */
#define ON_Q_BRDF 0          /* rho F1 + rho^2 F2 integrated, eq. 25 */
#define ON_Q_BRDF_DIRECT 1   /* per unit rho */
#define ON_Q_BRDF_INTER 2    /* per unit rho^2 */
#define ON_Q_UNI_SLOPE 3     /* eq. 22 at rho, theta_a, phi_a (closed) */
#define ON_Q_SS_DIRECT 4     /* eq. 23 numerically, per unit rho */
#define ON_Q_SS_INTER 5      /* eq. 46 numerically, per unit rho^2 */
#define ON_Q_SS_DIRECT_CF 6  /* eq. 45 (eqs. 39-44), per unit rho */
#define ON_Q_SS_INTER_CF 7   /* eq. 49, per unit rho^2 */
#define ON_Q_FUNCTIONAL 8    /* eqs. 27-29 at rho */
#define ON_Q_QUALITATIVE 9   /* eq. 30 at rho */
#define ON_Q_APPROX_ERROR 10 /* approximation vs eq. 25 at rho */
#define ON_Q_ALBEDO 11       /* int f cos theta_o dw_o at rho */
#define ON_Q_ALBEDO_AVG 12   /* 2 int E(mu) mu dmu at rho */
#define ON_Q_ALBEDO_DIRECT 13     /* albedo of brdf_direct (per unit rho) */
#define ON_Q_ALBEDO_INTER 14      /* albedo of brdf_interreflection (per rho^2) */
#define ON_Q_ALBEDO_AVG_DIRECT 15 /* albedo_avg of brdf_direct */
#define ON_Q_ALBEDO_AVG_INTER 16  /* albedo_avg of brdf_interreflection */

/* The model contract: slots of the point p[] and of the options o[] and the
 * number of quantities (ids ON_Q_* above).  host/models/oren_nayar.cpp registers
 * the model by these names; p[0..3] are the directions (estimator.h). */
#define ON_PARAM_SIGMA 4
#define ON_PARAM_RHO 5
#define ON_PARAM_THETA_A 6
#define ON_PARAM_PHI_A 7
#define ON_PARAM_NODES 8
#define ON_PARAM_COUNT 5
#define ON_OPT_QUALITATIVE_A 0
#define ON_OPT_APPROXIMATION 1
#define ON_OPT_ERROR 2
#define ON_OPT_COUNT 3
#define ON_Q_COUNT 17

#define ON_WANT_DIRECT 1
#define ON_WANT_INTER 2

/* Floor on cos(theta) of s and v (bt_direction) and in tan theta.  Unlike
 * the microfacet models (finite grazing limit, floor 1e-9), this BRDF grows
 * like 1/cos when both directions graze (header comment), so the floor sets
 * the value returned at exactly 90 deg; 1e-6 keeps tan theta <= 1e6 in
 * on_make_geom and on_tan_clamped. */
#define ON_MIN_COS R(1e-6)
#define ON_MAX_NODES 64
#define ON_GRADE_LEVELS 5
#define ON_MAX_BREAKS (10 + 4 * 2 * ON_GRADE_LEVELS)

/* ------------------------------------------------------------ geometry */

typedef struct {
    bt_vec3 s, v;        /* unit directions, z floored at ON_MIN_COS */
    REAL phi_s, phi_v;   /* azimuths */
    REAL tan_s, tan_v;   /* tan theta (horizontal length / z) */
    REAL phi_x;          /* azimuth of the X = Y line's normal; valid if has_x */
    int has_x;
} on_geom;

BT_INLINE on_geom on_make_geom(const REAL* p)
{
    on_geom g;
    /* callers reject directions below the surface first */
    bt_direction(p[0], p[1], ON_MIN_COS, BT_DIR_CLAMP_COS, &g.s);
    bt_direction(p[2], p[3], ON_MIN_COS, BT_DIR_CLAMP_COS, &g.v);
    g.phi_s = p[1];
    g.phi_v = p[3];
    g.tan_s = sqrt(g.s.x * g.s.x + g.s.y * g.s.y) / g.s.z;
    g.tan_v = sqrt(g.v.x * g.v.x + g.v.y * g.v.y) / g.v.z;
    /* X = Y  <=>  <a, w> = 0 with w = <s,n> v - <v,n> s (horizontal). */
    REAL wx = g.s.z * g.v.x - g.v.z * g.s.x;
    REAL wy = g.s.z * g.v.y - g.v.z * g.s.y;
    g.has_x = wx * wx + wy * wy > R(1e-20);
    g.phi_x = g.has_x ? bt_atan2(wy, wx) + BT_HALF_PI : R(0.0);
    return g;
}

BT_INLINE bt_vec3 on_facet_normal(REAL theta_a, REAL phi_a)
{
    REAL st = bt_sin(theta_a);
    return bt_v3(st * bt_cos(phi_a), st * bt_sin(phi_a), bt_cos(theta_a));
}

/* d(x, y) of eq. 20 with c2 = cos 2 theta_a. */
BT_INLINE REAL on_d(REAL x, REAL y, REAL c2)
{
    return bt_safe_sqrt(x * x + R(2.0) * x * y * c2 + y * y);
}

/* Interreflection factor, eq. 19: int_{mv}^1 int_{ms}^1 K'(t, r) dr dt,
 * with d(1, m_v), d(1, m_s) and d(1, 1) given (on_facet computes d(1, m_s)
 * apart, and d(1, 1) depends on theta_a alone). */
BT_INLINE REAL on_if_split(REAL d_v, REAL d_s, REAL mv, REAL ms, REAL c2, REAL d_11)
{
    REAL r = BT_HALF_PI * (d_v + d_s - on_d(ms, mv, c2) - d_11);
    return fmax(r, R(0.0)); /* rounding only: the integrand K' is >= 0 */
}

BT_INLINE REAL on_if(REAL mv, REAL ms, REAL c2)
{
    return on_if_split(on_d(R(1.0), mv, c2), on_d(R(1.0), ms, c2), mv, ms, c2,
                       on_d(R(1.0), R(1.0), c2));
}

/* cos 2 theta_a from a_z = cos theta_a. */
BT_INLINE REAL on_cos2(REAL az) { return R(2.0) * az * az - R(1.0); }

/* Per-facet BRDF contributions F1 (per unit rho) and F2 (per unit rho^2), see
 * the header comment.  `want` selects which are computed.  have_d11 != 0
 * (a constant at every call): d(1, 1) of eq. 20 at this theta_a is d11,
 * computed once per theta_a node by the quadrature (the same value). */
BT_INLINE void on_facet_d11(const on_geom* g, bt_vec3 a, int want, int have_d11, REAL d11,
                            REAL* f1, REAL* f2)
{
    *f1 = R(0.0);
    *f2 = R(0.0);
    REAL az = a.z;
    if (!(az > R(0.0))) return; /* theta_a = pi/2 in float rounding */
    REAL sa = bt_v3_dot(g->s, a), va = bt_v3_dot(g->v, a);
    REAL sz = g->s.z, vz = g->v.z;
    if ((want & ON_WANT_DIRECT) && sa > R(0.0) && va > R(0.0)) {
        /* Table 1: GAF = 1, masking (Y), shadowing (X) rows, smallest wins. */
        REAL t = fmin(sa * va / az, fmin(R(2.0) * sz * va, R(2.0) * vz * sa));
        *f1 = t * BT_INV_PI / (sz * vz);
    }
    if (want & ON_WANT_INTER) {
        /* a' = (-a.x, -a.y, a.z):  <a',d> = 2 a_z d_z - <a,d>. */
        REAL sa2 = R(2.0) * az * sz - sa, va2 = R(2.0) * az * vz - va;
        if (va > R(0.0) && sa2 > R(0.0)) {
            REAL mv = bt_clamp(-va2 / va, R(0.0), R(1.0));  /* eq. 15 */
            REAL c2 = on_cos2(az);                           /* cos 2 theta_a */
            /* eq. 16: m_s/w = 0 while <a,s> >= 0, and then d(1, m_s) = 1
             * exactly (also for the -0 the clamp may give), so the branch
             * changes no value.  It keeps m_s and d(1, m_s) in a block of
             * their own: side by side with m_v's, clang's SLP vectoriser
             * packed the pair into <2 x double>, which stopped the
             * vectorisation of the node-parallel kernel's work-item loop. */
            REAL ms = R(0.0), d_s = R(1.0);
            if (sa < R(0.0)) {
                ms = bt_clamp(-sa / sa2, R(0.0), R(1.0));
                d_s = on_d(R(1.0), ms, c2);
            }
            REAL itf = on_if_split(on_d(R(1.0), mv, c2), d_s, mv, ms, c2,
                                   have_d11 ? d11 : on_d(R(1.0), R(1.0), c2)); /* eq. 19 */
            *f2 = sa2 * va * itf * (BT_INV_PI * BT_INV_PI) / (az * vz * sz); /* eq. 18 */
        }
    }
}

BT_INLINE void on_facet(const on_geom* g, bt_vec3 a, int want, REAL* f1, REAL* f2)
{
    on_facet_d11(g, a, want, 0, R(0.0), f1, f2);
}

/* d(1, 1) of eq. 20 at slope cos theta_a = cos_a (on_facet_d11). */
BT_INLINE REAL on_d11(REAL cos_a) { return on_d(R(1.0), R(1.0), on_cos2(cos_a)); }

/* --------------------------------------------------------- quadrature */

BT_INLINE REAL on_wrap(REAL phi)
{
    return phi - BT_TWO_PI * floor(phi / BT_TWO_PI);
}

/* Kinks in phi_a of direction d (azimuth phi_d, tan theta_d) at slope
 * tan theta_a: <d,a'> = 0 at cos(phi_a - phi_d) = 1/(ta td) and <d,a> = 0
 * at cos(phi_a - phi_d) = -1/(ta td) (eq. 39's critical angle phi_c).
 *
 * Boundary layers of the two-bounce term (`layer` != 0).  Next to <s,a> = 0
 * the shadowed width m_s/w = -<a,s>/<a',s> climbs from 0 towards 1 within
 * |<a,s>| ~ <a,n><s,n>, and next to <v,a'> = 0 the masked width m_v/w does
 * the same within <a,v> - 2<a,n><v,n> ~ <a,n><v,n>.  In phi_a both layers
 * are h = 2/sqrt(k^2 - 1) wide, k = tan theta_a tan theta_d: thin when d
 * grazes.  IF is analytic there but only in a strip of width ~h, so
 * Gauss-Legendre on the whole sub-interval converges slowly; a geometric
 * mesh (breakpoints at h, 4h, 16h, ... on both sides) restores fast
 * convergence. */
BT_INLINE int on_add_graded(REAL b0, REAL h, REAL* b, int nb)
{
    for (int j = 0; j < ON_GRADE_LEVELS && h < R(0.4); ++j, h *= R(4.0)) {
        b[nb++] = on_wrap(b0 + h);
        b[nb++] = on_wrap(b0 - h);
    }
    return nb;
}

BT_INLINE int on_add_dir_breaks(REAL phi_d, REAL td, REAL ta, int is_source, int layer, REAL* b,
                                int nb)
{
    REAL k = ta * td;
    if (!(k > R(1.0))) return nb;
    REAL c = bt_acos(R(1.0) / k);
    b[nb++] = on_wrap(phi_d + c);
    b[nb++] = on_wrap(phi_d - c);
    b[nb++] = on_wrap(phi_d + BT_PI + c);
    b[nb++] = on_wrap(phi_d + BT_PI - c);
    if (layer) {
        REAL h = R(2.0) / sqrt((k - R(1.0)) * (k + R(1.0)));
        /* source: layers at <s,a> = 0; viewer: at <v,a'> = 0 */
        REAL base = is_source ? phi_d + BT_PI : phi_d;
        nb = on_add_graded(base + c, h, b, nb);
        nb = on_add_graded(base - c, h, b, nb);
    }
    return nb;
}

/* The phi_a breakpoints at slope theta_a, sorted, b[nb] = b[0] + 2pi;
 * returns nb (>= 1). */
BT_INLINE int on_phi_breaks(const on_geom* g, REAL theta_a, int want, REAL* b)
{
    int nb = 0;
    REAL ta = bt_tan(theta_a);
    int layer = (want & ON_WANT_INTER) != 0;
    nb = on_add_dir_breaks(g->phi_s, g->tan_s, ta, 1, layer, b, nb);
    nb = on_add_dir_breaks(g->phi_v, g->tan_v, ta, 0, layer, b, nb);
    if (g->has_x) {
        b[nb++] = on_wrap(g->phi_x);
        b[nb++] = on_wrap(g->phi_x + BT_PI);
    }
    if (nb == 0) b[nb++] = R(0.0);
    /* insertion sort */
    for (int i = 1; i < nb; ++i) {
        REAL key = b[i];
        int j = i - 1;
        while (j >= 0 && b[j] > key) {
            b[j + 1] = b[j];
            --j;
        }
        b[j + 1] = key;
    }
    b[nb] = b[0] + BT_TWO_PI;
    return nb;
}

/* The phi_a sub-intervals of on_phi_integral for nb breakpoints: a lone
 * interval covering the whole period is split in two so the rule sees half
 * a period (the integrand is then a low-order trig polynomial). */
BT_INLINE int on_phi_parts(int nb) { return nb == 1 ? 2 : 1; }

/* Half-length and midpoint of part q of sub-interval [b[k], b[k+1]].
 * parts is 1 or 2: the product by 1 or 1/2 is the quotient by parts, bit
 * for bit (both are exact scalings), without a division. */
BT_INLINE void on_phi_interval(REAL lo, REAL hi, int parts, int q, REAL* hl, REAL* mid)
{
    REAL step = (hi - lo) * (parts == 2 ? R(0.5) : R(1.0));
    REAL l = lo + step * (REAL)q;
    *hl = R(0.5) * step;
    *mid = l + *hl;
}

/* F1, F2 at the phi_a node phi at slope theta_a (sin, cos of it given):
 * the integrand of on_phi_integral, shared with the node-parallel kernel
 * (oren_nayar_node_term). */
BT_INLINE void on_phi_node_at(const on_geom* g, REAL sin_a, REAL cos_a, REAL d11, REAL phi,
                              int want, REAL* f1, REAL* f2)
{
#if BT_DEVICE && defined(BT_REAL_IS_FLOAT) && BT_REAL_IS_FLOAT
    REAL cos_phi = bt_cos(phi), sin_phi = bt_sin(phi);
#else
    /* bt_sincos: bt_sin's and bt_cos's values (one argument reduction, the
     * same polynomials, exact sign changes) at less cost; the float
     * device's builtins are not known to agree, so they stay apart. */
    REAL cos_phi;
    REAL sin_phi = bt_sincos(phi, &cos_phi);
#endif
    on_facet_d11(g, bt_v3(sin_a * cos_phi, sin_a * sin_phi, cos_a), want, 1, d11, f1, f2);
}

/* The phi_a node at GL abscissa x of a sub-interval (mid, hl): one
 * expression, evaluated alike (same contraction) wherever it is used. */
BT_INLINE REAL on_phi_at(REAL mid, REAL hl, REAL x) { return mid + hl * x; }

/* F1, F2 at the GL node x of a sub-interval (mid, hl). */
BT_INLINE void on_phi_node(const on_geom* g, REAL sin_a, REAL cos_a, REAL d11, REAL mid, REAL hl,
                           REAL x, int want, REAL* f1, REAL* f2)
{
    on_phi_node_at(g, sin_a, cos_a, d11, on_phi_at(mid, hl, x), want, f1, f2);
}

/* The inner sum's step (one phi_a node of weight w on half-length hl). */
BT_INLINE void on_phi_add(REAL w, REAL hl, REAL f1, REAL f2, REAL* s1, REAL* s2)
{
    *s1 += w * hl * f1;
    *s2 += w * hl * f2;
}

/* (1/2pi) int_0^{2pi} F1, F2 dphi_a at slope theta_a, GL rule (x, w, n) on
 * every sub-interval between kinks. */
BT_INLINE void on_phi_integral(const on_geom* g, REAL theta_a, int want, int n, const REAL* gx,
                               const REAL* gw, REAL* d1, REAL* d2)
{
    REAL b[ON_MAX_BREAKS + 1];
    int nb = on_phi_breaks(g, theta_a, want, b);
    REAL sin_a = bt_sin(theta_a), cos_a = bt_cos(theta_a);
    REAL d11 = on_d11(cos_a);
    REAL s1 = R(0.0), s2 = R(0.0);
    int parts = on_phi_parts(nb);
    for (int k = 0; k < nb; ++k) {
        for (int q = 0; q < parts; ++q) {
            REAL hl, mid;
            on_phi_interval(b[k], b[k + 1], parts, q, &hl, &mid);
            if (!(hl > R(0.0))) continue;
            for (int j = 0; j < n; ++j) {
                REAL f1, f2;
                on_phi_node(g, sin_a, cos_a, d11, mid, hl, gx[j], want, &f1, &f2);
                on_phi_add(gw[j], hl, f1, f2, &s1, &s2);
            }
        }
    }
    *d1 = s1 / BT_TWO_PI;
    *d2 = s2 / BT_TWO_PI;
}

/* theta_a breakpoints of the Gaussian slope integral: 0, 3 sigma (the
 * Gaussian's bulk), the critical slopes pi/2 - theta_d where the phi_a kinks
 * of d appear (substituted, see header), and the slopes where those kinks
 * cross the fixed X = Y azimuth phi_x: cos(phi_x - phi_d) =
 * +-1/(tan theta_a tan theta_d).  There three branches of the min() in F1
 * meet and the phi_a-integral has a weak (second-derivative) singularity.
 * Returns the number of sub-intervals ne; e[0..ne], kind[0..ne-1] (1: left
 * end is a critical slope, t^2 substitution). */
BT_INLINE int on_theta_breaks(const on_geom* g, REAL sigma, REAL* e, int* kind)
{
    REAL T = fmin(BT_HALF_PI, R(8.0) * sigma);
    int ne = 0;
    e[ne] = R(0.0);
    kind[ne++] = 0;
    REAL cand[5];
    int ckind[5];
    int nc = 0;
    cand[nc] = R(3.0) * sigma;
    ckind[nc++] = 0;
    cand[nc] = BT_HALF_PI - bt_atan(g->tan_s);
    ckind[nc++] = 1;
    cand[nc] = BT_HALF_PI - bt_atan(g->tan_v);
    ckind[nc++] = 1;
    if (g->has_x) {
        REAL cs = fabs(bt_cos(g->phi_x - g->phi_s)) * g->tan_s;
        REAL cv = fabs(bt_cos(g->phi_x - g->phi_v)) * g->tan_v;
        if (cs > R(1e-12)) {
            cand[nc] = bt_atan(R(1.0) / cs);
            ckind[nc++] = 0;
        }
        if (cv > R(1e-12)) {
            cand[nc] = bt_atan(R(1.0) / cv);
            ckind[nc++] = 0;
        }
    }
    for (int c = 0; c < nc; ++c) {
        if (!(cand[c] > R(0.0) && cand[c] < T)) continue;
        int j = ne - 1;
        while (j >= 0 && e[j] > cand[c]) {
            e[j + 1] = e[j];
            kind[j + 1] = kind[j];
            --j;
        }
        e[j + 1] = cand[c];
        kind[j + 1] = ckind[c];
        ++ne;
    }
    e[ne] = T;
    return ne;
}

/* The theta_a node of GL node x on sub-interval [lo, lo + L] (t^2
 * substitution where kind != 0). */
BT_INLINE REAL on_theta_node_angle(REAL lo, REAL L, int kind, REAL x)
{
    REAL t = R(0.5) * (x + R(1.0));
    return kind ? lo + L * t * t : lo + L * t;
}

/* The theta_a node of GL node (x, w) on sub-interval [lo, lo + L] and its
 * weight wp = w' jac p(theta_a) Z (eq. 26 before the normalisation). */
BT_INLINE void on_theta_node(REAL lo, REAL L, int kind, REAL x, REAL w, REAL inv2s2, REAL* theta,
                             REAL* wp)
{
    REAL t = R(0.5) * (x + R(1.0)), wt = R(0.5) * w;
    REAL th = on_theta_node_angle(lo, L, kind, x);
    REAL jac = kind ? R(2.0) * L * t : L;
    *theta = th;
    *wp = wt * jac * bt_exp(-th * th * inv2s2) * bt_sin(th);
}

/* The outer sum's step: z, s1, s2 in acc[0..2]. */
BT_INLINE void on_theta_add(REAL wp, REAL d1, REAL d2, REAL* acc)
{
    acc[0] += wp;
    acc[1] += wp * d1;
    acc[2] += wp * d2;
}

BT_INLINE void on_theta_finish(const REAL* acc, REAL* r1, REAL* r2)
{
    REAL z = acc[0];
    *r1 = z > R(0.0) ? acc[1] / z : R(0.0);
    *r2 = z > R(0.0) ? acc[2] / z : R(0.0);
}

/* Gaussian slope integral (eq. 25 with eq. 26) by the tensor rule. */
BT_INLINE void on_gauss_quadrature(const on_geom* g, REAL sigma, int want, int n, REAL* r1,
                                   REAL* r2)
{
    REAL gx[ON_MAX_NODES], gw[ON_MAX_NODES];
    bt_gauss_legendre_rule(n, gx, gw);
    REAL e[8];
    int kind[8];
    int ne = on_theta_breaks(g, sigma, e, kind);
    REAL inv2s2 = R(0.5) / (sigma * sigma);
    REAL acc[3] = {R(0.0), R(0.0), R(0.0)};
    for (int k = 0; k < ne; ++k) {
        REAL lo = e[k], L = e[k + 1] - lo;
        if (!(L > R(0.0))) continue;
        for (int j = 0; j < n; ++j) {
            REAL th, wp;
            on_theta_node(lo, L, kind[k], gx[j], gw[j], inv2s2, &th, &wp);
            REAL d1, d2;
            on_phi_integral(g, th, want, n, gx, gw, &d1, &d2);
            on_theta_add(wp, d1, d2, acc);
        }
    }
    on_theta_finish(acc, r1, r2);
}

/* ------------------------------------------------------------ sampling */

/* Z_R / Z with Z_R = int_0^{pi/2} theta e^{-theta^2/2s^2} dtheta
 * = s^2 (1 - e^{-X}), X = (pi/2)^2 / 2s^2, and
 * Z = int_0^{pi/2} sin(theta) e^{-theta^2/2s^2} dtheta
 *   = s^2 sum_k (-1)^k (2s^2)^k k!/(2k+1)! P(k+1, X)
 * (sine series; P = regularised lower incomplete gamma, integer order:
 * P(k+1, X) = 1 - e^{-X} sum_{j<=k} X^j/j!).  The terms fall like
 * (pi/2)^{2k}/(2k+1)!, so 12 terms reach double precision. */
BT_INLINE REAL on_norm_ratio(REAL sigma)
{
    REAL s2 = sigma * sigma;
    REAL X = BT_HALF_PI * BT_HALF_PI / (R(2.0) * s2);
    REAL ex = bt_exp(-X);
    REAL zr = R(1.0) - ex;
    REAL sum = R(0.0);
    REAL coef = R(1.0);   /* (2s^2)^k k! / (2k+1)! with sign */
    REAL part = R(1.0);   /* sum_{j<=k} X^j/j! */
    REAL term = R(1.0);   /* X^k / k! */
    /* For X > 60, P(k+1, X) = 1 to double precision for k < 14; skipping the
     * partial sums also keeps X^k/k! from overflowing in float (sigma < 2 deg). */
    int full = X > R(60.0);
    for (int k = 0; k < 14; ++k) {
        if (k > 0) {
            if (!full) {
                term *= X / (REAL)k;
                part += term;
            }
            coef *= -R(2.0) * s2 * (REAL)k / ((R(2.0) * k) * (R(2.0) * k + R(1.0)));
        }
        sum += coef * (full ? R(1.0) : R(1.0) - ex * part);
    }
    return sum > R(0.0) ? zr / sum : R(1.0);
}

/* One facet sample: slope by the truncated Rayleigh inverse CDF from u0,
 * azimuth from u1.  Returns the weight (sin th / th) Z_R/Z; *a the normal. */
BT_INLINE REAL on_sample_facet(REAL sigma, REAL ratio, REAL u0, REAL u1, bt_vec3* a)
{
    REAL s2 = sigma * sigma;
    REAL X = BT_HALF_PI * BT_HALF_PI / (R(2.0) * s2);
    REAL q = R(1.0) - u0 * (R(1.0) - bt_exp(-X));
    REAL th = fmin(sigma * sqrt(fmax(-R(2.0) * bt_log(q), R(0.0))), BT_HALF_PI);
    *a = on_facet_normal(th, BT_TWO_PI * u1);
    REAL sinc = th > R(1e-4) ? bt_sin(th) / th : R(1.0) - th * th / R(6.0);
    return sinc * ratio;
}

/* ------------------------------------------------------------ closed forms */

/* Critical angle, eq. 39. */
BT_INLINE REAL on_phi_c(REAL ta, REAL td)
{
    REAL k = ta * td;
    return k > R(1.0) ? bt_acos(R(1.0) / k) : R(0.0);
}

BT_INLINE REAL on_tan_clamped(REAL theta)
{
    return bt_sin(theta) / fmax(bt_cos(theta), ON_MIN_COS);
}

/* Isotropic single-slope direct term, eq. 45 (with eqs. 39-44), per unit
 * rho, divided by E0 cos theta_i. */
BT_INLINE REAL on_single_slope_direct_cf(REAL ti, REAL tr, REAL phi, REAL theta_a)
{
    REAL ta = bt_tan(theta_a);
    REAL tan_i = on_tan_clamped(ti), tan_r = on_tan_clamped(tr);
    REAL pci = on_phi_c(ta, tan_i), pcr = on_phi_c(ta, tan_r);
    int i_is_alpha = ti >= tr;
    REAL tan_a = i_is_alpha ? tan_i : tan_r, tan_b = i_is_alpha ? tan_r : tan_i;
    REAL pca = i_is_alpha ? pci : pcr, pcb = i_is_alpha ? pcr : pci;
    REAL cphi = bt_cos(phi);
    REAL A1 = ta * R(2.0) * bt_sin(pca) * BT_INV_PI +
              R(0.5) * ta * ta * tan_a * (R(1.0) - (R(2.0) * pca + bt_sin(R(2.0) * pca)) * BT_INV_PI);
    REAL A2 = cphi < R(0.0) ? R(2.0) * pcb * BT_INV_PI - ta * tan_b * R(2.0) * bt_sin(pcb) * BT_INV_PI
                            : R(0.0);
    REAL A3 = R(0.0);
    if (pci + pcr > BT_HALF_PI)
        A3 = R(0.5) - (pci + pcr) * BT_INV_PI + bt_safe_sqrt(tan_r * tan_r * ta * ta - R(1.0)) * BT_INV_PI +
             bt_safe_sqrt(tan_i * tan_i * ta * ta - R(1.0)) * BT_INV_PI -
             ta * sqrt(tan_i * tan_i + tan_r * tan_r) * BT_INV_PI;
    return BT_INV_PI * bt_cos(theta_a) *
           (R(1.0) + cphi * (A1 * tan_b + A2) + (R(1.0) - fabs(cphi)) * A3);
}

/* Isotropic single-slope interreflection, eq. 49 (built on the IF
 * approximation eq. 48), per unit rho^2, divided by E0 cos theta_i. */
BT_INLINE REAL on_single_slope_inter_cf(REAL ti, REAL tr, REAL phi, REAL theta_a)
{
    REAL ta = bt_tan(theta_a), ca = bt_cos(theta_a);
    REAL tan_i = on_tan_clamped(ti), tan_r = on_tan_clamped(tr);
    int i_is_alpha = ti >= tr;
    REAL tan_a = i_is_alpha ? tan_i : tan_r, tan_b = i_is_alpha ? tan_r : tan_i;
    REAL pca = on_phi_c(ta, tan_a), pcb = on_phi_c(ta, tan_b);
    REAL br = R(2.0) * pcb * BT_INV_PI + R(2.0) * ta * tan_b * (bt_sin(pca) - bt_sin(pcb)) * BT_INV_PI +
              R(0.5) * ta * ta * tan_a * tan_b *
                  (R(1.0) - (R(2.0) * pca + bt_sin(R(2.0) * pca)) * BT_INV_PI);
    return BT_INV_PI * ca * (R(1.0) - ca) * (R(1.0) - bt_cos(phi) * br);
}

/* Functional approximation, eqs. 27-29, as a BRDF at rho. */
BT_INLINE REAL on_functional(REAL ti, REAL tr, REAL phi, REAL sigma, REAL rho)
{
    REAL s2 = sigma * sigma;
    REAL al = fmax(ti, tr), be = fmin(ti, tr);
    REAL cphi = bt_cos(phi);
    REAL C1 = R(1.0) - R(0.5) * s2 / (s2 + R(0.33));
    REAL k2 = R(0.45) * s2 / (s2 + R(0.09));
    REAL tb = R(2.0) * be * BT_INV_PI;
    REAL C2 = cphi >= R(0.0) ? k2 * bt_sin(al) : k2 * (bt_sin(al) - tb * tb * tb);
    REAL q = R(4.0) * al * be * BT_INV_PI * BT_INV_PI;
    REAL C3 = R(0.125) * (s2 / (s2 + R(0.09))) * q * q;
    REAL L1 = C1 + cphi * C2 * on_tan_clamped(be) +
              (R(1.0) - fabs(cphi)) * C3 * on_tan_clamped(R(0.5) * (al + be));  /* eq. 27 */
    REAL L2 = R(0.17) * s2 / (s2 + R(0.13)) * (R(1.0) - cphi * tb * tb);   /* eq. 28 */
    return rho * BT_INV_PI * L1 + rho * rho * BT_INV_PI * L2;                /* eq. 29 */
}

/* Qualitative model, eq. 30 (a_const = 0.33, or 0.57 per footnote 7). */
BT_INLINE REAL on_qualitative(REAL ti, REAL tr, REAL phi, REAL sigma, REAL rho, int variant)
{
    REAL s2 = sigma * sigma;
    REAL al = fmax(ti, tr), be = fmin(ti, tr);
    REAL A = R(1.0) - R(0.5) * s2 / (s2 + (variant ? R(0.57) : R(0.33)));
    REAL B = R(0.45) * s2 / (s2 + R(0.09));
    return rho * BT_INV_PI * (A + B * fmax(R(0.0), bt_cos(phi)) * bt_sin(al) * on_tan_clamped(be));
}

/* --------------------------------------------------------- quantities */

BT_INLINE int on_quad_nodes(const REAL* p, const bt_sampler* s)
{
    int n = (int)(p[ON_PARAM_NODES] + R(0.5));
    n = n < 2 ? 2 : (n > ON_MAX_NODES ? ON_MAX_NODES : n);
    if (s->batch != 0u) n = (n + 1) / 2; /* the coarse rule */
    return n;
}

/* Exact Gaussian-surface integral (eq. 25): direct (per rho) and two-bounce
 * (per rho^2) parts; one quadrature evaluation, or one sample. */
BT_INLINE void on_gaussian(const REAL* p, const bt_sampler* s, int want, REAL* r1, REAL* r2)
{
    on_geom g = on_make_geom(p);
    REAL sigma = p[ON_PARAM_SIGMA];
    if (!(sigma > R(1e-6))) {
        /* sigma -> 0: every facet is the macro surface (a = n). */
        on_facet(&g, bt_v3(R(0.0), R(0.0), R(1.0)), want, r1, r2);
        return;
    }
    if (s->method == BT_METHOD_QUADRATURE) {
        on_gauss_quadrature(&g, sigma, want, on_quad_nodes(p, s), r1, r2);
        return;
    }
    bt_vec3 a;
    REAL w = on_sample_facet(sigma, on_norm_ratio(sigma), bt_uniform(s, 0u), bt_uniform(s, 1u), &a);
    on_facet(&g, a, want, r1, r2);
    *r1 *= w;
    *r2 *= w;
}

/* Isotropic single slope theta_a (eqs. 23, 46): quadrature or one sample. */
BT_INLINE void on_single_slope(const REAL* p, const bt_sampler* s, int want, REAL* r1, REAL* r2)
{
    on_geom g = on_make_geom(p);
    REAL theta_a = p[ON_PARAM_THETA_A];
    if (s->method == BT_METHOD_QUADRATURE) {
        REAL gx[ON_MAX_NODES], gw[ON_MAX_NODES];
        int n = on_quad_nodes(p, s);
        bt_gauss_legendre_rule(n, gx, gw);
        on_phi_integral(&g, theta_a, want, n, gx, gw, r1, r2);
        return;
    }
    on_facet(&g, on_facet_normal(theta_a, BT_TWO_PI * bt_uniform(s, 0u)), want, r1, r2);
}

/* The approximation chosen by option o[1]. */
BT_INLINE REAL on_approximation(const REAL* p, const int* o)
{
    REAL phi = p[3] - p[1];
    if (o[ON_OPT_APPROXIMATION] == 0) return on_functional(p[0], p[2], phi, p[ON_PARAM_SIGMA], p[ON_PARAM_RHO]);
    if (o[ON_OPT_APPROXIMATION] == 1) return on_qualitative(p[0], p[2], phi, p[ON_PARAM_SIGMA], p[ON_PARAM_RHO], o[ON_OPT_QUALITATIVE_A]);
    return p[ON_PARAM_RHO] * BT_INV_PI;
}

/* Directional albedo sample at light direction (theta_i, phi_i = 0):
 * c1 * E_direct + c2 * E_interreflection, one sample. */
BT_INLINE REAL on_albedo_sample(REAL theta_i, REAL sigma, REAL c1, REAL c2, const bt_sampler* s)
{
    REAL pt[4];
    REAL mu = sqrt(bt_uniform(s, 2u)); /* cos theta_o, pdf mu / pi */
    pt[0] = theta_i;
    pt[1] = R(0.0);
    pt[2] = bt_acos(fmin(mu, R(1.0)));
    pt[3] = BT_TWO_PI * bt_uniform(s, 3u);
    on_geom g = on_make_geom(pt);
    REAL f1, f2, w = R(1.0);
    bt_vec3 a = bt_v3(R(0.0), R(0.0), R(1.0));
    if (sigma > R(1e-6))
        w = on_sample_facet(sigma, on_norm_ratio(sigma), bt_uniform(s, 0u), bt_uniform(s, 1u), &a);
    int want = (c1 != R(0.0) ? ON_WANT_DIRECT : 0) | (c2 != R(0.0) ? ON_WANT_INTER : 0);
    on_facet(&g, a, want, &f1, &f2);
    /* f cos / (cos / pi) */
    return BT_PI * w * (c1 * f1 + c2 * f2);
}

/* theta_i with pdf 2 mu dmu (dim 4), for the hemispherical averages. */
BT_INLINE REAL on_avg_theta(const bt_sampler* s)
{
    REAL mu = sqrt(bt_uniform(s, 4u));
    return bt_acos(fmin(mu, R(1.0)));
}

/* The parts of eq. 25 that quantities brdf, brdf_direct,
 * brdf_interreflection and approx_error need. */
BT_INLINE int on_want(int quantity)
{
    if (quantity == ON_Q_BRDF_DIRECT) return ON_WANT_DIRECT;
    if (quantity == ON_Q_BRDF_INTER) return ON_WANT_INTER;
    return ON_WANT_DIRECT | ON_WANT_INTER;
}

/* The value of those quantities from eq. 25's direct (r1, per rho) and
 * two-bounce (r2, per rho^2) parts, directions above the surface. */
BT_INLINE REAL on_gaussian_result(const REAL* p, const int* o, int quantity, const bt_sampler* s,
                                  REAL r1, REAL r2)
{
    REAL rho = p[ON_PARAM_RHO];
    if (quantity == ON_Q_BRDF_DIRECT) return r1;
    if (quantity == ON_Q_BRDF_INTER) return r2;
    REAL exact = rho * r1 + rho * rho * r2;
    if (quantity != ON_Q_APPROX_ERROR) return exact;
    REAL approx = on_approximation(p, o);
    if (o[ON_OPT_ERROR] == 1) return approx - exact;
    /* Relative error.  Under quadrature `exact` is the rule's value; under
     * sampling methods the ratio would be biased, so the estimator is
     * linearised around the approximation: (approx - exact)/approx
     * (documented in docs/models/oren-nayar.md). */
    if (s->method == BT_METHOD_QUADRATURE)
        return exact > R(0.0) ? approx / exact - R(1.0) : R(0.0);
    return approx > R(0.0) ? (approx - exact) / approx : R(0.0);
}

/* The model's sample function (estimator.h signature). */
BT_INLINE REAL oren_nayar_sample(const REAL* p, const int* o, int quantity, const bt_sampler* s)
{
    int below = p[0] > BT_HALF_PI || p[2] > BT_HALF_PI;
    REAL rho = p[ON_PARAM_RHO];
    REAL r1 = R(0.0), r2 = R(0.0);
    REAL phi = p[3] - p[1];
    switch (quantity) {
    case ON_Q_BRDF:
    case ON_Q_BRDF_DIRECT:
    case ON_Q_BRDF_INTER:
    case ON_Q_APPROX_ERROR:
        if (below) return R(0.0);
        on_gaussian(p, s, on_want(quantity), &r1, &r2);
        return on_gaussian_result(p, o, quantity, s, r1, r2);
    case ON_Q_UNI_SLOPE: {
        /* eq. 22: mean of the two facet types of the aligned cavities */
        if (below) return R(0.0);
        on_geom g = on_make_geom(p);
        REAL a1, a2, b1, b2;
        on_facet(&g, on_facet_normal(p[ON_PARAM_THETA_A], p[ON_PARAM_PHI_A]), ON_WANT_DIRECT | ON_WANT_INTER, &a1, &a2);
        on_facet(&g, on_facet_normal(p[ON_PARAM_THETA_A], p[ON_PARAM_PHI_A] + BT_PI), ON_WANT_DIRECT | ON_WANT_INTER, &b1, &b2);
        return R(0.5) * (rho * (a1 + b1) + rho * rho * (a2 + b2));
    }
    case ON_Q_SS_DIRECT:
        if (below) return R(0.0);
        on_single_slope(p, s, ON_WANT_DIRECT, &r1, &r2);
        return r1;
    case ON_Q_SS_INTER:
        if (below) return R(0.0);
        on_single_slope(p, s, ON_WANT_INTER, &r1, &r2);
        return r2;
    case ON_Q_SS_DIRECT_CF:
        if (below) return R(0.0);
        return on_single_slope_direct_cf(p[0], p[2], phi, p[ON_PARAM_THETA_A]);
    case ON_Q_SS_INTER_CF:
        if (below) return R(0.0);
        return on_single_slope_inter_cf(p[0], p[2], phi, p[ON_PARAM_THETA_A]);
    case ON_Q_FUNCTIONAL:
        if (below) return R(0.0);
        return on_functional(p[0], p[2], phi, p[ON_PARAM_SIGMA], rho);
    case ON_Q_QUALITATIVE:
        if (below) return R(0.0);
        return on_qualitative(p[0], p[2], phi, p[ON_PARAM_SIGMA], rho, o[ON_OPT_QUALITATIVE_A]);
    case ON_Q_ALBEDO:
        if (p[0] > BT_HALF_PI) return R(0.0);
        return on_albedo_sample(p[0], p[ON_PARAM_SIGMA], rho, rho * rho, s);
    case ON_Q_ALBEDO_DIRECT:
        if (p[0] > BT_HALF_PI) return R(0.0);
        return on_albedo_sample(p[0], p[ON_PARAM_SIGMA], R(1.0), R(0.0), s);
    case ON_Q_ALBEDO_INTER:
        if (p[0] > BT_HALF_PI) return R(0.0);
        return on_albedo_sample(p[0], p[ON_PARAM_SIGMA], R(0.0), R(1.0), s);
    case ON_Q_ALBEDO_AVG:
        return on_albedo_sample(on_avg_theta(s), p[ON_PARAM_SIGMA], rho, rho * rho, s);
    case ON_Q_ALBEDO_AVG_DIRECT:
        return on_albedo_sample(on_avg_theta(s), p[ON_PARAM_SIGMA], R(1.0), R(0.0), s);
    case ON_Q_ALBEDO_AVG_INTER:
        return on_albedo_sample(on_avg_theta(s), p[ON_PARAM_SIGMA], R(0.0), R(1.0), s);
    default:
        return R(0.0);
    }
}

/* ------------------------------------------------ node-parallel quadrature */
/* The node functions of the Gaussian-surface quadrature (quantities brdf,
 * brdf_direct, brdf_interreflection, approx_error under
 * BT_METHOD_QUADRATURE) for the engine's nested node-parallel path
 * (kernels/common/node_parallel.h, nested_node_parallel.cl;
 * registered in host/models/oren_nayar.cpp).  A work item's groups are the
 * theta_a nodes of on_gauss_quadrature (in its order), a group's nodes the
 * phi_a nodes of its on_phi_integral (n per part of a sub-interval, in
 * order, zero-length parts included); a node's terms are F1 and F2.  The
 * group's reduction adds them with the very steps of on_phi_integral
 * (on_phi_add, then / 2 pi), its addition is the theta_a step
 * (on_theta_add), so the result is oren_nayar_sample's bit for bit.
 * Item state (ON_NODE_ITEM_STATE): the geometry, n, the non-empty theta_a
 * sub-intervals (lo, L, kind) and the GL rule, copied from the table the
 * device computes once per program (oren_nayar_node_table: the rule of
 * every n, as on_gauss_quadrature computes it).  Group state
 * (ON_NODE_GROUP_STATE): theta_a, wp, sin and cos theta_a, nb, d(1, 1),
 * b[0..nb]. */
#define ON_NODE_GEOM 12
#define ON_NODE_I_N (ON_NODE_GEOM)
#define ON_NODE_I_INV2S2 (ON_NODE_GEOM + 1)
#define ON_NODE_I_INV_N (ON_NODE_GEOM + 2)
#define ON_NODE_I_LO (ON_NODE_GEOM + 3)
#define ON_NODE_I_L (ON_NODE_I_LO + 7)
#define ON_NODE_I_KIND (ON_NODE_I_L + 7)
#define ON_NODE_I_GX (ON_NODE_I_KIND + 7)
#define ON_NODE_I_GW (ON_NODE_I_GX + ON_MAX_NODES)
#define ON_NODE_ITEM_STATE (ON_NODE_I_GW + ON_MAX_NODES)
#define ON_NODE_G_THETA 0
#define ON_NODE_G_WP 1
#define ON_NODE_G_SIN 2
#define ON_NODE_G_COS 3
#define ON_NODE_G_NB 4
#define ON_NODE_G_D11 5
#define ON_NODE_G_B 6
#define ON_NODE_GROUP_STATE (ON_NODE_G_B + ON_MAX_BREAKS + 1)
#define ON_NODE_TERMS 2
#define ON_NODE_PARTIALS 2
#define ON_NODE_ACC 3
/* Groups of one work item at most: 6 theta_a sub-intervals of n nodes. */
#define ON_NODE_MAX_GROUPS (6 * ON_MAX_NODES)

BT_INLINE on_geom on_node_load_geom(BT_GLOBAL const REAL* st)
{
    on_geom g;
    g.s = bt_v3(st[0], st[1], st[2]);
    g.v = bt_v3(st[3], st[4], st[5]);
    g.phi_s = st[6];
    g.phi_v = st[7];
    g.tan_s = st[8];
    g.tan_v = st[9];
    g.phi_x = st[10];
    g.has_x = st[11] != R(0.0);
    return g;
}

/* Whether the work item sums nodes at all: quadrature of a rough surface
 * above the horizon (otherwise oren_nayar_sample's value is cheap). */
BT_INLINE int on_node_nested(const REAL* p, int quantity, const bt_sampler* s)
{
    if (quantity != ON_Q_BRDF && quantity != ON_Q_BRDF_DIRECT && quantity != ON_Q_BRDF_INTER &&
        quantity != ON_Q_APPROX_ERROR)
        return 0;
    if (p[0] > BT_HALF_PI || p[2] > BT_HALF_PI) return 0;
    if (!(p[ON_PARAM_SIGMA] > R(1e-6))) return 0;
    return s->method == BT_METHOD_QUADRATURE;
}

/* Groups: n theta_a nodes per non-empty sub-interval; 0 where the sample
 * function computes the value itself. */
BT_INLINE int oren_nayar_node_count(const REAL* p, const int* o, int quantity, const bt_sampler* s)
{
    (void)o;
    if (!on_node_nested(p, quantity, s)) return 0;
    on_geom g = on_make_geom(p);
    REAL e[8];
    int kind[8];
    int ne = on_theta_breaks(&g, p[ON_PARAM_SIGMA], e, kind);
    int m = 0;
    for (int k = 0; k < ne; ++k) {
        REAL lo = e[k], L = e[k + 1] - lo;
        if (L > R(0.0)) ++m;
    }
    return m * on_quad_nodes(p, s);
}

/* The table's entries: the n-point rule for n = 0..ON_MAX_NODES (nodes,
 * then weights, ON_MAX_NODES each; zeros past n and for n = 0, which
 * on_quad_nodes never returns; n = 1 is the coarse rule of nodes = 2). */
#define ON_NODE_TABLE_SIZE (2 * ON_MAX_NODES)
#define ON_NODE_TABLE_ENTRIES (ON_MAX_NODES + 1)
BT_INLINE void oren_nayar_node_table(int n, REAL* rule)
{
    for (int i = 0; i < ON_NODE_TABLE_SIZE; ++i) rule[i] = R(0.0);
    if (n >= 1 && n <= ON_MAX_NODES) bt_gauss_legendre_rule(n, rule, rule + ON_MAX_NODES);
}

BT_INLINE void oren_nayar_node_prepare(const REAL* p, const int* o, int quantity,
                                       const bt_sampler* s, BT_GLOBAL const REAL* table,
                                       REAL* st)
{
    (void)o;
    for (int i = 0; i < ON_NODE_ITEM_STATE; ++i) st[i] = R(0.0);
    if (!on_node_nested(p, quantity, s)) return;
    on_geom g = on_make_geom(p);
    st[0] = g.s.x;
    st[1] = g.s.y;
    st[2] = g.s.z;
    st[3] = g.v.x;
    st[4] = g.v.y;
    st[5] = g.v.z;
    st[6] = g.phi_s;
    st[7] = g.phi_v;
    st[8] = g.tan_s;
    st[9] = g.tan_v;
    st[10] = g.phi_x;
    st[11] = g.has_x ? R(1.0) : R(0.0);
    REAL sigma = p[ON_PARAM_SIGMA];
    int n = on_quad_nodes(p, s);
    st[ON_NODE_I_N] = (REAL)n;
    st[ON_NODE_I_INV2S2] = R(0.5) / (sigma * sigma);
    st[ON_NODE_I_INV_N] = R(1.0) / (REAL)n;
    REAL e[8];
    int kind[8];
    int ne = on_theta_breaks(&g, sigma, e, kind);
    int m = 0;
    for (int k = 0; k < ne; ++k) {
        REAL lo = e[k], L = e[k + 1] - lo;
        if (!(L > R(0.0))) continue;
        st[ON_NODE_I_LO + m] = lo;
        st[ON_NODE_I_L + m] = L;
        st[ON_NODE_I_KIND + m] = kind[k] ? R(1.0) : R(0.0);
        ++m;
    }
    BT_GLOBAL const REAL* rule = table + (size_t)n * ON_NODE_TABLE_SIZE;
    for (int j = 0; j < n; ++j) {
        st[ON_NODE_I_GX + j] = rule[j];
        st[ON_NODE_I_GW + j] = rule[ON_MAX_NODES + j];
    }
}

/* Group g of a work item: theta_a node j of non-empty sub-interval g / n;
 * returns its node count (on_phi_integral's n per part of a sub-interval). */
BT_INLINE int oren_nayar_node_group(BT_GLOBAL const REAL* item, const int* o, int quantity, int g,
                                    BT_GLOBAL REAL* gs)
{
    (void)o;
    on_geom geo = on_node_load_geom(item);
    int n = (int)item[ON_NODE_I_N];
    if (n < 1) { /* a work item the device does not sum (count 0) */
        for (int i = 0; i < ON_NODE_GROUP_STATE; ++i) gs[i] = R(0.0);
        return 0;
    }
    int k = g / n, j = g - k * n;
    k = k < 6 ? k : 5; /* a group the host counted beyond the device's */
    REAL th, wp;
    on_theta_node(item[ON_NODE_I_LO + k], item[ON_NODE_I_L + k], item[ON_NODE_I_KIND + k] != R(0.0),
                  item[ON_NODE_I_GX + j], item[ON_NODE_I_GW + j], item[ON_NODE_I_INV2S2], &th, &wp);
    REAL b[ON_MAX_BREAKS + 1];
    int nb = on_phi_breaks(&geo, th, on_want(quantity), b);
    gs[ON_NODE_G_THETA] = th;
    gs[ON_NODE_G_WP] = wp;
    gs[ON_NODE_G_SIN] = bt_sin(th);
    gs[ON_NODE_G_COS] = bt_cos(th);
    gs[ON_NODE_G_NB] = (REAL)nb;
    gs[ON_NODE_G_D11] = on_d11(gs[ON_NODE_G_COS]);
    /* b[0..nb] only: the chunk, reduce and sum kernels read no further. */
    for (int i = 0; i <= nb; ++i) gs[ON_NODE_G_B + i] = b[i];
    return nb * on_phi_parts(nb) * n;
}

/* A group's phi_a nodes, in its node order (phi_a node j of part q of
 * sub-interval k is node (k parts + q) n + j; zero-length parts included):
 * written once per group by the chunk kernel, so the node kernel reads its
 * phi_a with one contiguous load instead of gathering the breakpoints, n
 * and the rule's node (9 gathers per node instead of 17). */
BT_INLINE void oren_nayar_node_term_setup(BT_GLOBAL const REAL* item, BT_GLOBAL const REAL* gs,
                                          BT_GLOBAL REAL* phi)
{
    int n = (int)item[ON_NODE_I_N];
    int nb = (int)gs[ON_NODE_G_NB];
    int parts = on_phi_parts(nb);
    for (int k = 0; k < nb; ++k) {
        for (int q = 0; q < parts; ++q) {
            REAL hl, mid;
            on_phi_interval(gs[ON_NODE_G_B + k], gs[ON_NODE_G_B + k + 1], parts, q, &hl, &mid);
            BT_GLOBAL REAL* out = phi + (k * parts + q) * n;
            for (int j = 0; j < n; ++j) out[j] = on_phi_at(mid, hl, item[ON_NODE_I_GX + j]);
        }
    }
}

/* A node of a group: F1 and F2 at its phi_a (from
 * oren_nayar_node_term_setup), as on_phi_integral computes them; a
 * zero-length part's nodes are computed too, and the group's reduction
 * skips them. */
BT_INLINE void oren_nayar_node_term(BT_GLOBAL const REAL* item, BT_GLOBAL const REAL* gs,
                                    const int* o, int quantity, REAL phi, REAL* out)
{
    (void)o;
    on_geom geo = on_node_load_geom(item);
    REAL f1, f2;
    on_phi_node_at(&geo, gs[ON_NODE_G_SIN], gs[ON_NODE_G_COS], gs[ON_NODE_G_D11], phi,
                   on_want(quantity), &f1, &f2);
    out[0] = f1;
    out[1] = f2;
}

/* A group's phi_a integral (its partial sums, ON_NODE_PARTIALS): its phi_a
 * nodes' terms added as on_phi_integral adds them, divided by 2 pi as
 * there. */
BT_INLINE void oren_nayar_node_group_reduce(BT_GLOBAL const REAL* item, BT_GLOBAL const REAL* gs,
                                            const int* o, int quantity,
                                            BT_GLOBAL const REAL* terms, REAL* partial)
{
    (void)o;
    (void)quantity;
    int n = (int)item[ON_NODE_I_N];
    int nb = (int)gs[ON_NODE_G_NB];
    int parts = on_phi_parts(nb);
    REAL s1 = R(0.0), s2 = R(0.0);
    for (int k = 0; k < nb; ++k) {
        for (int q = 0; q < parts; ++q) {
            REAL hl, mid;
            on_phi_interval(gs[ON_NODE_G_B + k], gs[ON_NODE_G_B + k + 1], parts, q, &hl, &mid);
            if (!(hl > R(0.0))) continue;
            BT_GLOBAL const REAL* t = terms + (size_t)ON_NODE_TERMS * (size_t)((k * parts + q) * n);
            for (int j = 0; j < n; ++j)
                on_phi_add(item[ON_NODE_I_GW + j], hl, t[ON_NODE_TERMS * j],
                           t[ON_NODE_TERMS * j + 1], &s1, &s2);
        }
    }
    partial[0] = s1 / BT_TWO_PI;
    partial[1] = s2 / BT_TWO_PI;
}

/* A group's share of the theta_a sum: the theta_a step with its phi_a
 * integral. */
BT_INLINE void oren_nayar_node_group_add(BT_GLOBAL const REAL* item, BT_GLOBAL const REAL* gs,
                                         const int* o, int quantity,
                                         BT_GLOBAL const REAL* partial, REAL* acc)
{
    (void)item;
    (void)o;
    (void)quantity;
    on_theta_add(gs[ON_NODE_G_WP], partial[0], partial[1], acc);
}

BT_INLINE REAL oren_nayar_node_finish(const REAL* p, const int* o, int quantity, const bt_sampler* s,
                                      const REAL* acc)
{
    REAL r1, r2;
    on_theta_finish(acc, &r1, &r2);
    return on_gaussian_result(p, o, quantity, s, r1, r2);
}

#endif /* BRDFTAB_OREN_NAYAR_H */

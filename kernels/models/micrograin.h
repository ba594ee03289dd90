/*
 * micrograin.h — fully-correlated anisotropic micrograin BSDF.
 *
 * S. Lucas, M. Ribardiere, R. Pacanowski, P. Barla, "A Fully-correlated
 * Anisotropic Micrograin BSDF Model", ACM Transactions on Graphics 43(4),
 * article 111, 2024.  doi:10.1145/3658224
 * Equation and appendix numbers are the paper's; the equations as
 * implemented, with every correction, are in docs/models/micrograin.md.
 *
 * Microstructure: a Boolean (Poisson) model of identical opaque half-
 * ellipsoid grains on a base plane z = 0; a grain is the unit half-sphere
 * stretched laterally by 1/beta_x, 1/beta_y (Fig. 2c), so its surface is
 * (beta_x x)^2 + (beta_y y)^2 + z^2 = 1, z >= 0.  tau0 is the fraction of the
 * base plane covered (eq. 8); the grain density is eq. 9 with r_s = 1.
 *
 * Working space.  Every projected area is computed for the unit sphere in the
 * space scaled by E = diag(beta_x, beta_y, 1) (§4.2 "Anisotropic GAF"):
 * i' = E i / |E i|, m' = E^-1 m / |E^-1 m|.  Heights are not scaled, so the
 * height of the point of normal m is h = n.m' on the ellipsoid as on the
 * sphere, and the user parameter `h` is that common height.
 *
 * Point p[] (kernels/common/estimator.h layout):
 *   p[0..3]  theta_i, phi_i, theta_o, phi_o  (radians)
 *   p[4]  tau0          filling factor, 0 < tau0 < 1 (eq. 8)
 *   p[5]  beta_x        lateral stretch factors (grain semi-axes 1/beta)
 *   p[6]  beta_y
 *   p[7]  h             height in [0, 1] (shadow/overlap/GAF quantities)
 *   p[8]  kd            grain diffuse albedo (eq. 21)
 *   p[9]  eta           grain index (dielectric) or real part (conductor)
 *   p[10] k             grain extinction coefficient (conductor)
 *   p[11] base_albedo   Lambertian base albedo
 *   p[12] base_alpha    GGX width of the rough-conductor base
 *   p[13] base_eta      rough-conductor base index, real part
 *   p[14] base_k        rough-conductor base extinction
 * Options o[]:
 *   o[0] grain        0 diffuse (F = 0), 1 dielectric (F from eta, plus the
 *                     kd lobe weighted by T = (1-F)(1-F)), 2 conductor
 *                     (F from eta + i k; kd lobe also weighted by T)
 *   o[1] base         0 absorbing, 1 lambertian, 2 rough conductor (GGX,
 *                     height-correlated Smith, kernels/common/microfacet.h),
 *                     3 rough dielectric (same GGX surface, dielectric
 *                     Fresnel with relative index base_eta; its reflection
 *                     only: light refracted into the bulk is not returned)
 *   o[2] correlation  0 direction-correlated G_dist (eqs. 18-19),
 *                     1 uncorrelated product (eq. 17)
 *   o[3] weighting    0 this paper, f = tau0 f^S + Vp f^B (eqs. 20, 23)
 *                     1 Lucas 2023 weights, f = w+ f^S + (1 - w+) f^B with
 *                       1 - w+ = (1 - tau0) G1(i,0) G1(o,0) (eqs. 1, 4, 25);
 *                       only the weights are swapped, f^S is still eq. 22.
 * Quantities: see the MG_Q_* list below.  Directions with theta > 90 deg
 * (below the surface) give 0 for the reflection quantities: the model is a
 * BRDF (no transmission into the base is modelled here).
 *
 * Departures from the paper (all flagged where they occur):
 *  - sigma_cap (Appendix B) is computed by an equivalent exact decomposition:
 *    each shadow is star-shaped about the grain axis, so the overlap is the
 *    polar integral of (min(R_i, R_o)^2 - rho^2)/2 over the common angular
 *    arc, split where the two ellipse boundaries cross (on the paper's line
 *    L_h) and evaluated per piece with Green's theorem on the ellipse.  The
 *    paper's three cases appear as: empty common arc (case 1), one ellipse
 *    inner over the whole arc (case 2), a split at p_+ (case 3).
 *  - eq. 28 prints sqrt(tau0 / ln(1 - tau0)), whose argument is negative;
 *    we use sqrt(-tau0 / ln(1 - tau0)), the value that matches D(n) with a
 *    GGX of that width (the evident intent).
 *  - eq. 21 is estimated by sampling m from a defensive mixture (NDF sampling
 *    eqs. 14-15 with probability MG_P_NDF, uniform hemisphere otherwise)
 *    instead of the NDF alone: the integrand carries 1/(m.n) against the
 *    pdf D(m)(m.n), whose variance diverges logarithmically at the grain
 *    equator; the mixture keeps the weights bounded.  Same integral.
 *  - explicit simulator: grains are generated on the fly on an infinite plane
 *    (hashed uniform grid, one Philox stream per cell and realization)
 *    instead of a stored periodic tile: no periodicity artefacts, no memory.
 */
#ifndef BRDFTAB_MICROGRAIN_H
#define BRDFTAB_MICROGRAIN_H

#include "../common/compat.h"
#include "../common/bt_math.h"
#include "../common/fresnel.h"
#include "../common/microfacet.h"
#include "../common/sampler.h"
#include "../common/vec3.h"
#include "micrograin_explicit.h"
#include "micrograin_materials.h"

#define MG_Q_NDF 0
#define MG_Q_ALPHA_X 1
#define MG_Q_ALPHA_Y 2
#define MG_Q_SHADOW_AREA 3
#define MG_Q_OVERLAP_AREA 4
#define MG_Q_G1_DIST 5
#define MG_Q_G_DIST 6
#define MG_Q_PORE_VISIBILITY 7
#define MG_Q_BRDF 8
#define MG_Q_ALBEDO 9
#define MG_Q_EXPLICIT_G1 10
#define MG_Q_EXPLICIT_G 11
#define MG_Q_EXPLICIT_BRDF 12
#define MG_Q_P_BULK 13
#define MG_Q_P_DIFFUSE 14
#define MG_Q_COVERAGE 15
#define MG_Q_COUNT 16
/* Parameter and option slots: micrograin_materials.h. */

#define MG_CORR_DIRECTION 0
#define MG_CORR_NONE 1

/* Floor on |cos theta| of i and o (bt_direction) and of the cosines in the
 * shadow areas: theta = 90 deg gives the finite grazing limit (G_dist -> 0)
 * instead of 0/0.  The limit is finite, so the floor only has to keep the
 * quotients defined; 1e-9 is within 1e-9 rad of the horizon. */
#define MG_MIN_COS R(1e-9)
/* Probability of NDF sampling in the defensive mixture (header comment). */
#define MG_P_NDF R(0.75)

/* ------------------------------------------------------------ helpers */

/* i' = E i / |E i| (§4.2). */
BT_INLINE bt_vec3 mg_to_sphere_dir(bt_vec3 v, REAL bx, REAL by)
{
    return bt_v3_normalize(bt_v3(bx * v.x, BT_SLP_SPLIT(by * v.y), v.z)); /* compat.h */
}

/* h' = n.m', m' = E^-1 m / |E^-1 m| (§4.2). */
BT_INLINE REAL mg_height_of_normal(bt_vec3 m, REAL bx, REAL by)
{
    bt_vec3 mp = bt_v3_normalize(bt_v3(m.x / bx, m.y / by, m.z));
    return bt_clamp(mp.z, R(0.0), R(1.0));
}

/* ------------------------------------------------------- NDF, eqs. 10-15 */

/* t(m)^2 = tan^2 theta_m (cos^2 phi_m / bx^2 + sin^2 phi_m / by^2), written
 * with the components of m (eq. 10 and the anisotropic t below eq. 11). */
BT_INLINE REAL mg_t2(bt_vec3 m, REAL bx, REAL by)
{
    REAL sx = m.x / bx, sy = m.y / by;
    return (sx * sx + sy * sy) / (m.z * m.z);
}

/* D(m), eqs. 10-12: -ln(1-tau0) (1-tau0)^(t^2/(1+t^2)) / tau0 * D_ggx^aniso,
 * D_ggx^aniso = 1 / (pi bx by cos^4 theta_m (1 + t^2)^2).  m.z <= 0 gives 0.
 * -ln(1-tau0)/tau0 uses log1p so tau0 -> 0 tends to 1 without cancellation. */
BT_INLINE REAL mg_ndf(bt_vec3 m, REAL tau0, REAL bx, REAL by)
{
    if (!(m.z > R(0.0))) return R(0.0);
    REAL L = mg_log1m(tau0);
    REAL t2 = mg_t2(m, bx, by);
    REAL s = t2 / (R(1.0) + t2);
    REAL c2 = m.z * m.z;
    REAL ggx_den = c2 * (R(1.0) + t2); /* cos^2 (1 + t^2), finite at grazing */
    REAL dggx = R(1.0) / (BT_PI * bx * by * ggx_den * ggx_den);  /* eq. 12 */
    return -L / tau0 * bt_exp(s * L) * dggx;                       /* eqs. 11-12 */
}

/* m with pdf D(m) m.z: eqs. 13-15.  Inverting eq. 13 for s = t^2/(1+t^2):
 * (1-tau0)^s = 1 - u0 tau0, so s = ln(1 - u0 tau0) / ln(1 - tau0) and
 * t^2 = s/(1-s) (eq. 14).  The azimuth of eq. 15 is taken with its quadrant
 * (atan2), which is the same as drawing the stretched slope
 * (bx t cos 2 pi u1, by t sin 2 pi u1): tan theta_m = t / sqrt(g(phi_m)). */
BT_INLINE bt_vec3 mg_sample_ndf(REAL u0, REAL u1, REAL tau0, REAL bx, REAL by)
{
    REAL L = mg_log1m(tau0);
    REAL s = bt_log1p(-u0 * tau0) / L;                   /* eq. 14 */
    s = bt_clamp(s, R(0.0), R(1.0) - R(1e-7));
    REAL t = sqrt(s / (R(1.0) - s));
    REAL ph = BT_TWO_PI * u1;                          /* eq. 15 via slopes */
    REAL sx = bx * t * bt_cos(ph), sy = by * t * bt_sin(ph);
    REAL inv = R(1.0) / sqrt(R(1.0) + sx * sx + sy * sy);
    return bt_v3(sx * inv, sy * inv, inv);
}

/* Defensive mixture used by the Monte Carlo estimators (header comment):
 * pdf = MG_P_NDF D(m) m.z + (1 - MG_P_NDF) / (2 pi). */
BT_INLINE bt_vec3 mg_sample_m(REAL u0, REAL u1, REAL tau0, REAL bx, REAL by, REAL* pdf)
{
    bt_vec3 m;
    if (u0 < MG_P_NDF) {
        m = mg_sample_ndf(u0 / MG_P_NDF, u1, tau0, bx, by);
    } else {
        REAL z = (u0 - MG_P_NDF) / (R(1.0) - MG_P_NDF);
        REAL r = bt_safe_sqrt(R(1.0) - z * z), ph = BT_TWO_PI * u1;
        m = bt_v3(r * bt_cos(ph), r * bt_sin(ph), fmax(z, R(1e-12)));
    }
    *pdf = MG_P_NDF * mg_ndf(m, tau0, bx, by) * m.z + (R(1.0) - MG_P_NDF) * R(0.5) * BT_INV_PI;
    return m;
}

/* Equivalent GGX width, eq. 28 (sign corrected, header comment):
 * alpha = beta sqrt(-tau0 / ln(1 - tau0)). */
BT_INLINE REAL mg_alpha_equivalent(REAL beta, REAL tau0)
{
    return beta * sqrt(-tau0 / mg_log1m(tau0));
}

/* ------------------------------------------- shadow area, Appendix A */

/* Area of the part u < u0 of the unit disc: acos(-u0) + u0 sqrt(1 - u0^2). */
BT_INLINE REAL mg_disc_left(REAL u0)
{
    u0 = bt_clamp(u0, R(-1.0), R(1.0));
    return bt_safe_acos(-u0) + u0 * bt_safe_sqrt(R(1.0) - u0 * u0);
}

/* sigma_s(v, h) for the unit sphere, v a unit direction with v.z > 0.
 * Appendix A: sigma_s = sigma_e - sigma_c - sigma_t.  With the chord through
 * the tangent points q_+- (x = q_x in the frame where v lies in the xz plane)
 * this is [ellipse segment x < q_x] - [circle segment x < q_x]; the ellipse
 * segment is sigma_e minus the triangle (e, q+, q-) and the circle segment is
 * sigma_c minus the triangle (0, q+, q-), whose difference is sigma_t.
 * In the unit-circle coordinates of the ellipse, u0 = (q_x - e_x) cos theta_v
 * simplifies exactly to -h / sin theta_v (no cancellation at grazing), and
 * the circle chord sits at cos phi_q = -1/(tan theta_m tan theta_v).
 * No shadow when cos theta_m = h >= sin theta_v (Appendix A). */
BT_INLINE REAL mg_shadow_area_sphere(bt_vec3 v, REAL h)
{
    REAL ct = fmax(v.z, MG_MIN_COS);
    REAL st = sqrt(v.x * v.x + BT_SLP_SPLIT(v.y * v.y)); /* splits: compat.h */
    if (!(h < st) || !(h < R(1.0))) return R(0.0);
    REAL rho = sqrt(fmax(R(1.0) - h * h, R(0.0)));
    REAL ell = mg_disc_left(-h / st) / ct;               /* sigma_e - |e_x q_y| - ... */
    REAL cphi = -(h / rho) * BT_SLP_SPLIT(BT_SLP_SPLIT(ct / st)); /* cos phi_q */
    REAL circ = rho * rho * mg_disc_left(cphi);          /* sigma_c - triangle */
    return fmax(ell - circ, R(0.0));
}

/* ----------------------------------------- overlap area, Appendix B */

/* Distance from the grain axis (origin of the plane H at height h) to the
 * boundary of the ellipse E_h(v) along the horizontal unit direction
 * (ux, uy): the positive root r of |p|^2 - (p.v)^2 = 1, p = (r u, h). */
BT_INLINE REAL mg_ellipse_radius(bt_vec3 v, REAL h, REAL ux, REAL uy)
{
    REAL a = ux * v.x + uy * v.y;
    REAL A = fmax(R(1.0) - a * a, R(1e-30));
    REAL B = -R(2.0) * a * h * v.z;
    REAL C = h * h * (R(1.0) - v.z * v.z) - R(1.0); /* < 0 for h < 1 */
    REAL D = bt_safe_sqrt(B * B - R(4.0) * A * C);
    if (B <= R(0.0)) return (-B + D) / (R(2.0) * A);
    return R(2.0) * (-C) / (B + D);
}

/* Area swept from the origin to the boundary of E_h(v) between the polar
 * angles psa < psb (psb - psa <= pi), by Green's theorem on the ellipse
 * p(t) = e + M (cos t, sin t): (1/2) int p x dp = det M dt / 2
 * + (e x p(tb) - e x p(ta)) / 2, with e = h (v.x, v.y) / v.z the centre,
 * det M = 1 / v.z (semi-axes 1/v.z along v's azimuth, 1 across). */
BT_INLINE REAL mg_ellipse_sweep(bt_vec3 v, REAL h, REAL psa, REAL psb)
{
    if (!(psb > psa)) return R(0.0);
    REAL ct = fmax(v.z, MG_MIN_COS);
    REAL st = sqrt(v.x * v.x + v.y * v.y);
    REAL cx = st > R(0.0) ? v.x / st : R(1.0), cy = st > R(0.0) ? v.y / st : R(0.0);
    REAL ex = h * v.x / ct, ey = h * v.y / ct;
    REAL ua_x = bt_cos(psa), ua_y = bt_sin(psa), ub_x = bt_cos(psb), ub_y = bt_sin(psb);
    REAL ra = mg_ellipse_radius(v, h, ua_x, ua_y), rb = mg_ellipse_radius(v, h, ub_x, ub_y);
    REAL pax = ra * ua_x, pay = ra * ua_y, pbx = rb * ub_x, pby = rb * ub_y;
    /* Parameters t: unit-circle coordinates of p - e. */
    REAL a1 = ((pax - ex) * cx + (pay - ey) * cy) * ct, b1 = -(pax - ex) * cy + (pay - ey) * cx;
    REAL a2 = ((pbx - ex) * cx + (pby - ey) * cy) * ct, b2 = -(pbx - ex) * cy + (pby - ey) * cx;
    REAL dt = bt_atan2(a1 * b2 - b1 * a2, a1 * a2 + b1 * b2);
    /* t increases with psi (the origin is inside the convex ellipse); a
     * rounding-negative dt for a tiny arc must not become 2 pi. */
    if (dt < R(0.0)) dt = (psb - psa < R(1e-3)) ? R(0.0) : dt + BT_TWO_PI;
    return R(0.5) * (dt / ct + (ex * pby - ey * pbx) - (ex * pay - ey * pax));
}

/* a in (-3 pi, 3 pi) (every caller passes a difference of two atan2 results
 * shifted by pi, so |a| < 2 pi) into (-pi, pi]: one conditional step each
 * way, written as selects so the work-item loop stays vectorisable (the
 * same arithmetic as while loops, which would never run twice). */
BT_INLINE REAL mg_wrap_pi(REAL a)
{
    a = a > BT_PI ? a - BT_TWO_PI : a;
    a = a <= -BT_PI ? a + BT_TWO_PI : a;
    return a;
}

/* Where the overlap area runs as one straight path (below): in the device's
 * closed-form kernels, whose work-item loop PoCL vectorises.  Elsewhere (the
 * host, and the Monte Carlo kernels, whose work item loops over its samples
 * and so stays scalar) it returns as soon as the value is known: the same
 * values, less work (the straight path in micrograin's brdf kernel took it
 * from 4.4-4.6x to 3.4-3.8x the serial host). */
#if BT_DEVICE && defined(BT_SPEC_METHOD) && BT_SPEC_METHOD == BT_METHOD_CLOSED
#define MG_STRAIGHT_PATH 1
#else
#define MG_STRAIGHT_PATH 0
#endif

/* One piece [a, b] of the common arc (angles relative to cen_i): the sweep of
 * whichever ellipse is inner at the piece's middle (case 2 when one wins the
 * whole arc), less the circle sector of radius rho.  An empty piece (b <= a)
 * adds exactly +0. */
BT_INLINE REAL mg_overlap_piece(bt_vec3 vi, bt_vec3 vo, REAL h, REAL rho, REAL cen_i, REAL a,
                                REAL b)
{
    if (!MG_STRAIGHT_PATH && !(b > a)) return R(0.0); /* skip the empty piece */
    REAL mid = cen_i + R(0.5) * (a + b);
    REAL ri = mg_ellipse_radius(vi, h, bt_cos(mid), bt_sin(mid));
    REAL ro = mg_ellipse_radius(vo, h, bt_cos(mid), bt_sin(mid));
    bt_vec3 inner = ri <= ro ? vi : vo;
    REAL piece = mg_ellipse_sweep(inner, h, cen_i + a, cen_i + b) - R(0.5) * rho * rho * (b - a);
    return b > a ? piece : R(0.0);
}

/* sigma_cap(i, o, h) for the unit sphere (Appendix B; see the header comment
 * for the decomposition).  The shadow of v at height h occupies, in polar
 * coordinates about the axis, the arc of half-width w = pi - phi_q centred on
 * phi_v + pi and radii rho < r < R_v(psi) (the chord of Appendix A never
 * crosses the crescent, so each ray from the axis is all shadow or none).
 *
 * Written as one straight path, so that PoCL's work-item loop vectorises
 * (docs/contributing.md, "What keeps PoCL's work-item loop scalar"): the
 * common arc [lo, hi] is cut at the (at most two) split angles that fall
 * inside it, a missing cut is placed at hi, where it sorts last and leaves an
 * empty piece, and the three pieces are summed in order; the early returns
 * are selects at the end.  The arithmetic of every term is that of a loop
 * over the pieces, so the value is the same bit for bit (area starts at +0 and so never is -0, and adding an empty piece's +0
 * leaves it unchanged).  Outside the device's closed-form
 * kernels it still returns as soon as the value is known
 * (`!MG_STRAIGHT_PATH && ...`, above: the same results, less work).  The BT_SLP_SPLIT calls
 * (compat.h) keep the x/y and i/o pairs of the geometry apart. */
BT_INLINE REAL mg_overlap_area_sphere(bt_vec3 vi, bt_vec3 vo, REAL h)
{
    REAL ci_ = fmax(vi.z, MG_MIN_COS), co_ = fmax(vo.z, MG_MIN_COS);
    REAL si = sqrt(vi.x * vi.x + BT_SLP_SPLIT(vi.y * vi.y));
    REAL so = BT_SLP_SPLIT(sqrt(vo.x * vo.x + BT_SLP_SPLIT(vo.y * vo.y)));
    int absent = !(h < si) || !(h < so) || !(h < R(1.0)); /* case 1: a shadow absent */
    if (!MG_STRAIGHT_PATH && absent) return R(0.0);
    REAL rho = sqrt(fmax(R(1.0) - h * h, R(0.0)));
    /* Two splits: with one, SLP still pairs the divisions through the
     * product's other operand (it also tries an operand's operands). */
    REAL wi = bt_safe_acos((h / rho) * BT_SLP_SPLIT(BT_SLP_SPLIT(ci_ / si))); /* pi - phi_q */
    REAL wo = bt_safe_acos((h / rho) * BT_SLP_SPLIT(BT_SLP_SPLIT(co_ / so)));
    REAL cen_i = bt_atan2(vi.y, vi.x) + BT_PI;
    REAL d = mg_wrap_pi(BT_SLP_SPLIT(bt_atan2(vo.y, vo.x)) + BT_PI - cen_i);
    REAL lo = fmax(-wi, d - wo), hi = fmin(wi, d + wo);
    int disjoint = !(hi > lo); /* case 1: disjoint arcs, no overlap */
    if (!MG_STRAIGHT_PATH && disjoint) return R(0.0);
    /* Split angles: where L_h = {p : p.(i - o) = 0} meets E_h(i) (on L_h
     * both ellipses have the same radius).  Line: g . p_xy = c. */
    REAL gx = vi.x - vo.x, gy = BT_SLP_SPLIT(vi.y - vo.y), g2 = gx * gx + BT_SLP_SPLIT(gy * gy);
    REAL c = -h * (vi.z - vo.z);
    REAL px = gx * c / g2, py = BT_SLP_SPLIT(gy * c / g2); /* foot of the line */
    REAL dx = -gy / sqrt(g2), dy = BT_SLP_SPLIT(gx / sqrt(g2));
    /* |p|^2 - (p.vi)^2 = 1 with p = (px + s dx, py + s dy, h). */
    REAL pv = px * vi.x + BT_SLP_SPLIT(py * vi.y) + h * vi.z;
    REAL dv = dx * vi.x + BT_SLP_SPLIT(dy * vi.y);
    REAL qa = R(1.0) - dv * dv;
    REAL qb = R(2.0) * ((px * dx + BT_SLP_SPLIT(py * dy)) - pv * dv);
    REAL qc = px * px + BT_SLP_SPLIT(py * py) + h * h - pv * pv - R(1.0);
    REAL disc = qb * qb - R(4.0) * qa * qc;
    int roots = g2 > R(1e-24) && disc > R(0.0) && qa > R(1e-30);
    REAL sq = sqrt(disc);
    REAL s0 = (-qb + -sq) / (R(2.0) * qa), s1 = (-qb + sq) / (R(2.0) * qa);
    REAL ang0 = hi, ang1 = hi;
    if (MG_STRAIGHT_PATH || roots) {
        ang0 = mg_wrap_pi(bt_atan2(py + s0 * dy, px + s0 * dx) - cen_i);
        ang1 = mg_wrap_pi(BT_SLP_SPLIT(bt_atan2(py + s1 * dy, px + s1 * dx)) - cen_i);
    }
    /* Cuts inside (lo, hi), in increasing order; a missing one is hi. */
    REAL m0 = roots && ang0 > lo && ang0 < hi ? ang0 : hi;
    REAL m1 = roots && ang1 > lo && ang1 < hi ? ang1 : hi;
    int swap = m1 < m0;
    REAL c0 = swap ? m1 : m0, c1 = swap ? m0 : m1;
    REAL area = R(0.0);
    area += mg_overlap_piece(vi, vo, h, rho, cen_i, lo, c0);
    area += mg_overlap_piece(vi, vo, h, rho, cen_i, c0, c1);
    area += mg_overlap_piece(vi, vo, h, rho, cen_i, c1, hi);
    /* The overlap never exceeds either shadow.  The clamp only bites within
     * ~1e-6 rad of grazing, where the ellipses are ~1/cos long and the sweep
     * loses all digits to cancellation; it keeps G_dist <= min(G1(i), G1(o))
     * there (-> 0, the correct limit) instead of returning noise. */
    REAL cap = fmin(mg_shadow_area_sphere(vi, h), BT_SLP_SPLIT(mg_shadow_area_sphere(vo, h)));
    REAL overlap = bt_clamp(area, R(0.0), cap);
    return absent || disjoint ? R(0.0) : overlap;
}

/* -------------------------------------------- GAF terms, eqs. 16-19, 23 */

/* Physical (unscaled-space) areas: sphere areas times det E^-1 (§4.2). */
BT_INLINE REAL mg_shadow_area(bt_vec3 i, REAL h, REAL bx, REAL by)
{
    return mg_shadow_area_sphere(mg_to_sphere_dir(i, bx, by), h) / (bx * by);
}

BT_INLINE REAL mg_overlap_area(bt_vec3 i, bt_vec3 o, REAL h, REAL bx, REAL by)
{
    return mg_overlap_area_sphere(mg_to_sphere_dir(i, bx, by), mg_to_sphere_dir(o, bx, by), h) /
           (bx * by);
}

/* G1_dist(i, h) = exp(ln(1-tau0)/pi sigma_s(i', h))  (eq. 16 with eq. 9). */
BT_INLINE REAL mg_g1_dist(bt_vec3 i, REAL h, REAL tau0, REAL bx, REAL by)
{
    REAL ss = mg_shadow_area_sphere(mg_to_sphere_dir(i, bx, by), h);
    return bt_exp(mg_log1m(tau0) * BT_INV_PI * ss);
}

/* G_dist(i, o, h): eq. 19 (direction-correlated) or eq. 17 (product). */
BT_INLINE REAL mg_g_dist(bt_vec3 i, bt_vec3 o, REAL h, REAL tau0, REAL bx, REAL by, int corr)
{
    bt_vec3 ip = mg_to_sphere_dir(i, bx, by), op = mg_to_sphere_dir(o, bx, by);
    REAL a = mg_shadow_area_sphere(ip, h) + BT_SLP_SPLIT(mg_shadow_area_sphere(op, h));
    if (corr == MG_CORR_DIRECTION) a -= mg_overlap_area_sphere(ip, op, h); /* eq. 18 */
    return bt_exp(mg_log1m(tau0) * BT_INV_PI * fmax(a, R(0.0)));
}

/* V_p(i, o) = (1 - tau0) G_dist(i, o, 0), eq. 23. */
BT_INLINE REAL mg_pore_visibility(bt_vec3 i, bt_vec3 o, REAL tau0, REAL bx, REAL by, int corr)
{
    return (R(1.0) - tau0) * mg_g_dist(i, o, R(0.0), tau0, bx, by, corr);
}

/* ---------------------------------------------------------- BSDF terms */

/* Specular micrograin term of eq. 22: D(h) G(i,o,h) F(i.h) / (4 i.n o.n),
 * G = chi+(i.h) chi+(o.h) G_dist(i, o, h'(h)). */
BT_INLINE REAL mg_f_specular(bt_vec3 i, bt_vec3 o, const REAL* p, const int* opt)
{
    if (opt[MG_OPT_GRAIN] == MG_GRAIN_DIFFUSE) return R(0.0);
    bt_vec3 m = bt_v3_normalize(bt_v3_add(i, o));
    REAL im = bt_v3_dot(i, m), om = bt_v3_dot(o, m);
    if (!(im > R(0.0)) || !(om > R(0.0)) || !(m.z > R(0.0))) return R(0.0);
    REAL tau0 = p[MG_PARAM_TAU0], bx = p[MG_PARAM_BETA_X], by = p[MG_PARAM_BETA_Y];
    REAL D = mg_ndf(m, tau0, bx, by);
    REAL G = mg_g_dist(i, o, mg_height_of_normal(m, bx, by), tau0, bx, by, opt[MG_OPT_CORRELATION]);
    REAL F = mg_grain_fresnel(im, p, opt[MG_OPT_GRAIN]);
    return D * G * F / (R(4.0) * i.z * o.z);
}

/* Integrand of eq. 21 at m, divided by the sampling pdf:
 * kd/pi |i.m||o.m| / (|i.n||o.n|) D(m) G(i,o,m) T(i,o,m), with
 * T = (1 - F(i.m))(1 - F(o.m)). */
BT_INLINE REAL mg_f_diffuse_sample(bt_vec3 i, bt_vec3 o, const REAL* p, const int* opt, REAL u0,
                                   REAL u1)
{
    REAL kd = p[MG_PARAM_KD];
    if (!(kd > R(0.0))) return R(0.0);
    REAL tau0 = p[MG_PARAM_TAU0], bx = p[MG_PARAM_BETA_X], by = p[MG_PARAM_BETA_Y];
    REAL pdf;
    bt_vec3 m = mg_sample_m(u0, u1, tau0, bx, by, &pdf);
    REAL im = bt_v3_dot(i, m), om = bt_v3_dot(o, m);
    if (!(im > R(0.0)) || !(om > R(0.0)) || !(pdf > R(0.0))) return R(0.0); /* G_local */
    REAL D = mg_ndf(m, tau0, bx, by);
    REAL G = mg_g_dist(i, o, mg_height_of_normal(m, bx, by), tau0, bx, by, opt[MG_OPT_CORRELATION]);
    REAL T = (R(1.0) - mg_grain_fresnel(im, p, opt[MG_OPT_GRAIN])) * (R(1.0) - mg_grain_fresnel(om, p, opt[MG_OPT_GRAIN]));
    return kd * BT_INV_PI * im * om / (i.z * o.z) * D * G * T / pdf;
}

/* Weights of f^S and f^B: eqs. 20, 23 or eqs. 1, 25 (option weighting). */
BT_INLINE void mg_weights(bt_vec3 i, bt_vec3 o, const REAL* p, const int* opt, REAL* ws, REAL* wb)
{
    REAL tau0 = p[MG_PARAM_TAU0], bx = p[MG_PARAM_BETA_X], by = p[MG_PARAM_BETA_Y];
    if (opt[MG_OPT_WEIGHTING] == 1) {
        REAL b = (R(1.0) - tau0) * mg_g1_dist(i, R(0.0), tau0, bx, by) *
                 mg_g1_dist(o, R(0.0), tau0, bx, by);            /* eq. 25 */
        *wb = b;
        *ws = R(1.0) - b;                                        /* eq. 1 */
    } else {
        *ws = tau0;                                              /* eq. 20 */
        *wb = mg_pore_visibility(i, o, tau0, bx, by, opt[2]);    /* eq. 23 */
    }
}

/* One sample of f(i, o), eqs. 20-22 (the diffuse part eq. 21 is the only
 * random one: dims 0, 1). */
BT_INLINE REAL mg_brdf_sample(bt_vec3 i, bt_vec3 o, const REAL* p, const int* opt, REAL u0,
                              REAL u1)
{
    REAL ws, wb;
    mg_weights(i, o, p, opt, &ws, &wb);
    REAL fs = mg_f_specular(i, o, p, opt) + mg_f_diffuse_sample(i, o, p, opt, u0, u1);
    REAL fb = opt[MG_OPT_BASE] == MG_BASE_ABSORBING ? R(0.0) : mg_f_base(i, o, p, opt);
    return ws * fs + wb * fb;
}

/* One sample of the directional albedo int f(i,o) o.n do: the specular term
 * by sampling m (dims 0, 1) and reflecting i; the rest (eq. 21 part and
 * base) by cosine sampling o (dims 2, 3) with the eq. 21 sample on dims 4, 5.
 * The sum of two unbiased estimators of the two parts. */
BT_INLINE REAL mg_albedo_sample(bt_vec3 i, const REAL* p, const int* opt, const bt_sampler* s)
{
    REAL tau0 = p[MG_PARAM_TAU0], bx = p[MG_PARAM_BETA_X], by = p[MG_PARAM_BETA_Y];
    REAL total = R(0.0);
    if (opt[MG_OPT_GRAIN] != MG_GRAIN_DIFFUSE) {
        REAL pdf_m;
        bt_vec3 m = mg_sample_m(bt_uniform(s, 0), bt_uniform(s, 1), tau0, bx, by, &pdf_m);
        REAL im = bt_v3_dot(i, m);
        if (im > R(0.0) && pdf_m > R(0.0)) {
            bt_vec3 o = bt_reflect(i, m);
            if (o.z > MG_MIN_COS) {
                REAL ws, wb;
                mg_weights(i, o, p, opt, &ws, &wb);
                REAL pdf_o = pdf_m / (R(4.0) * im); /* reflection Jacobian */
                total += ws * mg_f_specular(i, o, p, opt) * o.z / pdf_o;
            }
        }
    }
    REAL u2 = bt_uniform(s, 2), u3 = bt_uniform(s, 3);
    REAL r = sqrt(u2), ph = BT_TWO_PI * u3;
    bt_vec3 o = bt_v3(r * bt_cos(ph), r * bt_sin(ph), fmax(sqrt(fmax(R(1.0) - u2, R(0.0))), MG_MIN_COS));
    REAL ws, wb;
    mg_weights(i, o, p, opt, &ws, &wb);
    REAL fd = mg_f_diffuse_sample(i, o, p, opt, bt_uniform(s, 4), bt_uniform(s, 5));
    REAL fb = opt[MG_OPT_BASE] == MG_BASE_ABSORBING ? R(0.0) : mg_f_base(i, o, p, opt);
    total += (ws * fd + wb * fb) * BT_PI; /* f o.z / (o.z / pi) */
    return total;
}

/* Sampling probabilities, eqs. 26-27. */
BT_INLINE REAL mg_p_bulk(bt_vec3 i, REAL tau0, REAL bx, REAL by)
{
    REAL v = (R(1.0) - tau0) * mg_g1_dist(i, R(0.0), tau0, bx, by);
    return v / (tau0 + v);                                     /* eq. 26 */
}

BT_INLINE REAL mg_p_diffuse(bt_vec3 i, const REAL* p, const int* opt)
{
    REAL kd = p[MG_PARAM_KD];
    REAL F = mg_grain_fresnel(i.z, p, opt[MG_OPT_GRAIN]); /* F(i.n, n), eq. 27 */
    return kd + F > R(0.0) ? kd / (kd + F) : R(0.0);
}

/* ------------------------------------------------------ sample function */

BT_INLINE REAL micrograin_sample(const REAL* p, const int* o, int quantity, const bt_sampler* s)
{
    bt_vec3 vi, vo; /* only read when ok_i, ok_o */
    /* The splits (compat.h) keep PoCL's SLP vectoriser from packing the
     * argument reductions of theta and phi and the x, y of each direction
     * (g_dist).  Here, not in bt_from_spherical: there they made SLP pack
     * rough-dielectric's bsdf kernel instead (21-24 M/s against 35-38). */
    int ok_i = bt_direction(p[0], BT_SLP_SPLIT(p[1]), MG_MIN_COS, BT_DIR_SIGNED_COS, &vi);
    int ok_o = bt_direction(p[2], BT_SLP_SPLIT(p[3]), MG_MIN_COS, BT_DIR_SIGNED_COS, &vo);
    vi.y = BT_SLP_SPLIT(vi.y);
    vo.y = BT_SLP_SPLIT(vo.y);
    REAL tau0 = p[MG_PARAM_TAU0], bx = p[MG_PARAM_BETA_X], by = p[MG_PARAM_BETA_Y], h = p[MG_PARAM_H];
    switch (quantity) {
    case MG_Q_NDF:
        /* m is the direction (theta_i, phi_i); D(m) = 0 below the horizon. */
        return ok_i ? mg_ndf(bt_from_spherical(p[0], p[1]), tau0, bx, by) : R(0.0);
    case MG_Q_ALPHA_X: return mg_alpha_equivalent(bx, tau0);
    case MG_Q_ALPHA_Y: return mg_alpha_equivalent(by, tau0);
    case MG_Q_SHADOW_AREA: return ok_i ? mg_shadow_area(vi, h, bx, by) : R(0.0);
    case MG_Q_OVERLAP_AREA: return ok_i && ok_o ? mg_overlap_area(vi, vo, h, bx, by) : R(0.0);
    case MG_Q_G1_DIST: return ok_i ? mg_g1_dist(vi, h, tau0, bx, by) : R(0.0);
    case MG_Q_G_DIST: return ok_i && ok_o ? mg_g_dist(vi, vo, h, tau0, bx, by, o[MG_OPT_CORRELATION]) : R(0.0);
    case MG_Q_PORE_VISIBILITY:
        return ok_i && ok_o ? mg_pore_visibility(vi, vo, tau0, bx, by, o[MG_OPT_CORRELATION]) : R(0.0);
    case MG_Q_BRDF:
        return ok_i && ok_o ? mg_brdf_sample(vi, vo, p, o, bt_uniform(s, 0), bt_uniform(s, 1))
                            : R(0.0);
    case MG_Q_ALBEDO: return ok_i ? mg_albedo_sample(vi, p, o, s) : R(0.0);
    case MG_Q_EXPLICIT_G1: return ok_i ? mgx_g_sample(vi, vi, 1, p, s) : R(0.0);
    case MG_Q_EXPLICIT_G: return ok_i && ok_o ? mgx_g_sample(vi, vo, 0, p, s) : R(0.0);
    case MG_Q_EXPLICIT_BRDF: return ok_i && ok_o ? mgx_brdf_sample(vi, vo, p, o, s) : R(0.0);
    case MG_Q_P_BULK: return ok_i ? mg_p_bulk(vi, tau0, bx, by) : R(0.0);
    case MG_Q_P_DIFFUSE: return ok_i ? mg_p_diffuse(vi, p, o) : R(0.0);
    case MG_Q_COVERAGE: return mgx_coverage_sample(p, s);
    default: return R(0.0);
    }
}

#endif /* BRDFTAB_MICROGRAIN_H */

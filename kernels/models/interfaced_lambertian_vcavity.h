/*
 * interfaced_lambertian_vcavity.h — multiple reflections between interfaced
 * Lambertian microfacets inside V-cavities (Meneveaux et al. §3.3,
 * eqs. 22-23), tallied per bounce order: the `vcavity` quantity of
 * interfaced_lambertian.h, on the surface of interfaced_lambertian_surface.h
 * (il_surface, il_t, il_ri, ...).  Equations as implemented:
 * docs/models/interfaced-lambertian.md.
 *
 * Geometry (Torrance-Sparrow / Oren-Nayar V-cavities, "much longer than
 * wide"): a facet of normal m forms a symmetric groove with its mirror
 * m' = (-m.x, -m.y, m.z).  Work in the cross-section plane spanned by
 * h = (m.x, m.y, 0)/|.| and z (coordinates u, z; the groove axis t does not
 * affect visibility).  Facet m runs from the groove bottom (0, 0) to
 * (-cos a, sin a), facet m' from (0, 0) to (cos a, sin a), a = theta_m,
 * facet width 1; a point is located by s in [0, 1] from the bottom.  After
 * each crossing the frame is mirrored (u -> -u) so the current facet is
 * always "facet m" with normal e = (sin a, 0, cos a).
 *
 * Seen from direction v (v.e > 0), the top part s >= 1 - g(v) of the facet
 * is unshadowed, g(v) = min(1, 2 v.z cos a / (v.e)) (the two branches of
 * eq. 14); so G_TS = min(g(i), g(o)).
 *
 * Estimator (a point version of eq. 22).  Let E0 be the irradiance normal to
 * i.  The macro BRDF is
 *   f(i,o) = 1/(|i.n||o.n|) int D(m) (o.m_e) <V_o L(x,o)>_facet / E0 dw_m
 * summed over the facets e the radiance leaves from; since D(m) = D(m'),
 * the paths may be grouped by the facet the light FIRST hits (m), which is
 * what we simulate.  Light flux E0 (i.m) g(i) (per unit facet width) lands
 * uniformly on the lit part s in [1 - g(i), 1].  At every facet hit j
 * (incident direction d_j, facet normal e_j, point s_j) the body radiance
 * toward o is (eq. 8) T(d_j.e_j) T(o.e_j) A/pi times the incident flux
 * density, A = Kd/(ni^2 (1 - Kd ri)); it is connected to o with the exact
 * visibility [s_j >= 1 - g(o)] and the factor (o.e_j).  The path then
 * continues: interreflection = full: with probability F(d_j.e_j) a
 * specular reflection (throughput unchanged), else the body scatters a
 * cosine-distributed direction (throughput x T(d'.e_j) A); interreflection
 * = body: always the body (throughput x T_in T_out A).  Body directions are
 * drawn only among those that reach the other facet, with the facet-to-facet
 * view factor as weight (see the loop); this is exact for the groove's
 * strip-to-strip form factor cos cos / (2 r) (the kernel of Oren-Nayar
 * eq. 14) and keeps every body continuation alive.  A specular continuation
 * may leave the groove, which ends the path.
 * With m ~ D|m.n| (pdf) the sample is (i.m) g(i) sum_j c_j / (|i.n||o.n| m.z);
 * with m ~ visible normals from i, g(i) sum_j c_j / (G1s(i) |o.n|).
 * interreflection = full adds, at every body event, the path body ->
 * specular reflection on the opposite facet -> o, connected analytically
 * (see the loop).
 * Order k = number of facet interactions of the path up to and including
 * the event seen from o (the connected body event, or the specular
 * reflection of that second connection).  Not part of this quantity: light
 * that leaves the groove right after specular reflections (a Dirac in o for
 * a fixed facet; the single specular bounce is the `specular` quantity) and
 * body -> two or more specular reflections -> o.
 * With ni = 1 (F = 0, A = Kd) order k is exactly Kd^k times its Kd = 1 value.
 */
#ifndef BRDFTAB_INTERFACED_LAMBERTIAN_VCAVITY_H
#define BRDFTAB_INTERFACED_LAMBERTIAN_VCAVITY_H

#include "../common/compat.h"
#include "../common/bt_math.h"
#include "../common/fresnel.h"
#include "../common/microfacet.h"
#include "../common/sampler.h"
#include "../common/vec3.h"
#include "interfaced_lambertian_surface.h"

/* Option o[2]: which facet events continue a path (header comment). */
#define IL_INTERREFLECTION_FULL 0
#define IL_INTERREFLECTION_BODY 1

/* Bounce cut-off of the V-cavity walk (order = 0). */
#ifndef IL_MAX_BOUNCES
#define IL_MAX_BOUNCES 128
#endif
/* Paths whose throughput falls below IL_ROULETTE continue with probability
 * tau / IL_ROULETTE (Philox dimensions IL_DIM_ROULETTE + bounce). */
#define IL_ROULETTE R(0.05)
#define IL_DIM_ROULETTE 700u

/* Where the ray from point pos of facet m (frame of the file comment) along
 * direction d meets the other facet: returns sigma in [0, 1], or -1 when the
 * ray leaves the groove.  2-D cross products in the (u, z) plane. */
BT_INLINE REAL il_vcavity_hit(REAL pos, REAL c, REAL sn, bt_vec3 d)
{
    REAL pu = -pos * c, pz = pos * sn;
    REAL den = c * d.z - sn * d.x;
    if (den == R(0.0)) return -R(1.0);
    REAL sig = (pu * d.z - pz * d.x) / den;
    REAL tt = (pu * sn - pz * c) / den;
    if (!(tt > R(0.0)) || !(sig >= R(-1e-6)) || !(sig <= R(1.0) + R(1e-6))) return -R(1.0);
    return bt_clamp(sig, R(0.0), R(1.0));
}

/* A sample is two stages: the facet it starts from (il_vcavity_facet,
 * dimensions 0-1; no loop but the Beckmann visible-normal search) and the
 * walk in its groove (il_vcavity_walk, dimensions 2 and up; a bounce loop
 * of data-dependent length).  The staged sample-parallel launch
 * (kernels/common/staged_samples.cl) runs them as two kernels so
 * that the first vectorises across samples; il_vcavity_sample runs them in
 * a row.  The stage: st[0..2] = m, st[3] = its weight wm (file comment). */
#define IL_VCAVITY_STAGE 4
BT_INLINE void il_vcavity_facet(il_surface* s, int sampling, bt_vec3 i, bt_vec3 o,
                                const bt_sampler* smp, REAL* st)
{
    bt_vec3 m;
    REAL wm;
    if (il_uses_visible(s, sampling)) {
        m = bt_mf_sample_visible(&s->mf, i, bt_uniform(smp, 0u), bt_uniform(smp, 1u));
        REAL gs = bt_mf_g1_smith_nochi(&s->mf, i);
        wm = gs > R(0.0) ? R(1.0) / (gs * o.z) : R(0.0);
    } else {
        m = il_sample_distribution(s, smp);
        wm = m.z > R(0.0) ? bt_v3_dot(i, m) / (i.z * o.z * m.z) : R(0.0);
    }
    st[0] = m.x;
    st[1] = m.y;
    st[2] = m.z;
    st[3] = wm;
}

BT_INLINE REAL il_vcavity_walk(int mode, bt_vec3 i, bt_vec3 o, REAL ni, REAL kd, int order,
                               const bt_sampler* smp, const REAL* st)
{
    if (order < 0) return R(0.0);
    REAL A = kd / (ni * ni * (R(1.0) - kd * il_ri(ni)));
    bt_vec3 m = bt_v3(st[0], st[1], st[2]);
    REAL wm = st[3];
    REAL im = bt_v3_dot(i, m);
    if (!(im > R(0.0)) || !(m.z > R(0.0)) || !(wm > R(0.0))) return R(0.0);
    REAL sn = sqrt(m.x * m.x + m.y * m.y), c = m.z;
    if (!(sn > R(1e-12))) {
        /* Flat facet: no groove, only the first bounce. */
        if (order > 1) return R(0.0);
        return wm * il_t(im, ni) * il_t(o.z, ni) * o.z * A * BT_INV_PI;
    }
    REAL hx = m.x / sn, hy = m.y / sn;
    /* Directions in the groove frame (u along h, t along z x h, z). */
    bt_vec3 di = bt_v3(i.x * hx + i.y * hy, -i.x * hy + i.y * hx, i.z);
    REAL ou = o.x * hx + o.y * hy, ot = -o.x * hy + o.y * hx;
    bt_vec3 e = bt_v3(sn, R(0.0), c);
    bt_vec3 b1 = bt_v3(c, R(0.0), -sn); /* in-plane tangent of the facet */
    REAL gi = fmin(R(1.0), R(2.0) * i.z * c / im);
    REAL pos = R(1.0) - gi * bt_uniform(smp, 2u); /* uniform on the lit part */
    bt_vec3 din = di;
    int side = 0;
    /* Throughput = tau * amp: amp collects the Kd-dependent factors A, tau
     * the geometric and Fresnel ones (roulette acts on tau only, so the
     * sampled paths, and hence ni = 1 order k ~ Kd^k, do not depend on Kd). */
    REAL tau = R(1.0), amp = R(1.0), acc = R(0.0);
    /* order k needs walk vertices up to k - 1 (direct) or k - 2 (mirror). */
    int last = order == 0 ? IL_MAX_BOUNCES : order;
    for (int j = 0; j < last; ++j) {
        REAL de = bt_v3_dot(din, e);
        if (!(de > R(0.0))) break;
        REAL tin = il_t(de, ni);
        if (order == 0 || order == j + 1) {
            bt_vec3 of = bt_v3(side ? -ou : ou, ot, o.z);
            REAL oe = bt_v3_dot(of, e);
            if (oe > R(0.0)) {
                REAL go = fmin(R(1.0), R(2.0) * o.z * c / oe);
                if (pos >= R(1.0) - go) acc += tau * amp * tin * il_t(oe, ni) * oe * A * BT_INV_PI;
            }
        }
        /* Body -> specular reflection on the other facet -> o (full mode):
         * the only direction that does it is dm = -reflect(o, e'); the
         * parallel beam along dm maps facet widths as dy (o.e') = dx (dm.e),
         * so the term is tau T_in T(dm.e) A/pi F(o.e') (dm.e) [dm reaches
         * the other facet at y] [o sees y].  Order j + 2. */
        if (mode == IL_INTERREFLECTION_FULL && (order == 0 || order == j + 2) &&
            j + 2 <= IL_MAX_BOUNCES) {
            bt_vec3 of = bt_v3(side ? -ou : ou, ot, o.z);
            bt_vec3 e2 = bt_v3(-sn, R(0.0), c);
            REAL oe2 = bt_v3_dot(of, e2);
            if (oe2 > R(0.0)) {
                bt_vec3 dm = bt_v3_sub(of, bt_v3_scale(e2, R(2.0) * oe2));
                REAL dme = bt_v3_dot(dm, e);
                REAL y = dme > R(0.0) ? il_vcavity_hit(pos, c, sn, dm) : -R(1.0);
                REAL go2 = fmin(R(1.0), R(2.0) * o.z * c / oe2);
                if (y >= R(0.0) && y >= R(1.0) - go2)
                    acc += tau * amp * tin * il_t(dme, ni) * A * BT_INV_PI *
                           bt_fresnel_dielectric(oe2, ni) * dme;
            }
        }
        if (j + 1 >= last) break;
        uint d = 3u + 4u * (uint)j; /* event, sin psi, radius, azimuth */
        bt_vec3 dout;
        int specular = mode == IL_INTERREFLECTION_FULL && bt_uniform(smp, d) < R(1.0) - tin;
        if (specular) {
            dout = bt_reflect(din, e);
        } else {
            /* Body: cosine-distributed direction, restricted to the ones that
             * reach the other facet (the rest leaves the groove and is never
             * connected again).  In the groove's cross-section the in-plane
             * angle psi (from e toward b1) of a cosine-distributed direction
             * has density cos(psi)/2 and is independent of its out-of-plane
             * component (density of the elevation g prop. to cos^2 g).  From
             * point pos the other facet spans psi in [psi_Q, pi/2] (Q = its
             * top edge, the bottom vertex lies on our own facet's line), a
             * view factor Fv = (1 - sin psi_Q)/2: draw sin psi uniformly in
             * [sin psi_Q, 1], keep the out-of-plane part of a standard cosine
             * sample, and weight by Fv. */
            REAL qe = R(2.0) * c * sn;                                          /* (Q - p).e  */
            REAL qb = (R(1.0) + pos) * c * c - (R(1.0) - pos) * sn * sn;        /* (Q - p).b1 */
            REAL sq = qb / sqrt(qe * qe + qb * qb);                             /* sin psi_Q */
            REAL fv = R(0.5) * (R(1.0) - sq);
            REAL spsi = fmin(sq + bt_uniform(smp, d + 1u) * (R(1.0) - sq), R(1.0));
            REAL cpsi = bt_safe_sqrt(R(1.0) - spsi * spsi);
            REAL r = sqrt(bt_uniform(smp, d + 2u));
            REAL sg = r * bt_sin(BT_TWO_PI * bt_uniform(smp, d + 3u)); /* out-of-plane part */
            REAL cg = bt_safe_sqrt(R(1.0) - sg * sg);
            dout = bt_v3_add(bt_v3_add(bt_v3_scale(e, cg * cpsi), bt_v3_scale(b1, cg * spsi)),
                             bt_v3(R(0.0), sg, R(0.0)));
            tau *= fv * il_t(cg * cpsi, ni);
            amp *= A;
            if (mode != IL_INTERREFLECTION_FULL) tau *= tin;
        }
        if (!(tau > R(0.0)) || !(amp > R(0.0))) break;
        /* Russian roulette on weak paths (unbiased: survivors carry tau/q). */
        if (tau < IL_ROULETTE) {
            REAL q = tau / IL_ROULETTE;
            if (bt_uniform(smp, IL_DIM_ROULETTE + (uint)j) >= q) break;
            tau = IL_ROULETTE;
        }
        REAL sig = il_vcavity_hit(pos, c, sn, dout);
        if (sig < R(0.0)) break; /* left the groove */
        pos = sig;
        side ^= 1;
        din = bt_v3(dout.x, -dout.y, -dout.z); /* -dout, mirrored u -> -u */
    }
    return wm * gi * acc;
}

BT_INLINE REAL il_vcavity_sample(il_surface* s, int sampling, int mode, bt_vec3 i, bt_vec3 o,
                                 REAL ni, REAL kd, int order, const bt_sampler* smp)
{
    if (order < 0) return R(0.0);
    REAL st[IL_VCAVITY_STAGE];
    il_vcavity_facet(s, sampling, i, o, smp, st);
    return il_vcavity_walk(mode, i, o, ni, kd, order, smp, st);
}

#endif /* BRDFTAB_INTERFACED_LAMBERTIAN_VCAVITY_H */

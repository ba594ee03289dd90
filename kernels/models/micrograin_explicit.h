/*
 * micrograin_explicit.h — reference simulator for the micrograin model
 * (Lucas et al. 2024, §5.1): ray tracing of an explicit random Boolean
 * distribution of half-ellipsoid grains: the explicit_* and coverage
 * quantities of micrograin.h, with the grain and base materials of
 * micrograin_materials.h.  Runs on the device (OpenCL) and on the host alike.
 *
 * Grain field.  Centres form a Poisson process on the base plane of density
 * rho = -ln(1 - tau0) beta_x beta_y / pi (eq. 9, r_s = 1); grain surface
 * (beta_x (x - cx))^2 + (beta_y (y - cy))^2 + z^2 = 1, z >= 0.  The plane is
 * cut into a uniform grid of cells of size (1/beta_x) x (1/beta_y) (the grain
 * semi-axes), so a grain touches only the 3x3 cells around its own.  Each
 * cell's grains are regenerated on demand from a Philox stream keyed by
 * (realisation seed, cell index): count ~ Poisson(rho * cell area =
 * -ln(1 - tau0)/pi), positions uniform in the cell.  Every sample of the
 * estimators uses a fresh realisation (the seed comes from the sampler), so
 * the estimators average over the ensemble, which is what the model predicts.
 * Departure from the issue text: an infinite, procedurally generated plane
 * instead of a stored periodic tile (no periodicity, no memory).
 *
 * Traversal: 2-D DDA (Amanatides & Woo) over the cells the ray's horizontal
 * projection crosses, testing the grains of the 3x3 neighbourhood of each.
 * Upward rays stop at z = 1 (no grain is higher).  At most MGX_MAX_CELLS
 * cells are visited; a longer ray is counted as blocked (only reachable
 * within ~0.1 deg of grazing, where the visibility is ~0 anyway).
 *
 * Estimators (quantities of micrograin.h):
 *  explicit_g1  sample = 1 if a uniformly drawn pore point at height h (a
 *               point of the plane z = h outside every grain; drawn by
 *               rejection) sees direction i unobstructed, else 0: mean =
 *               G1_dist(i, h) by its definition in §4.2 (relative area of pores
 *               at height h visible from i).
 *  explicit_g   same with both i and o visible: G_dist(i, o, h).
 *  explicit_brdf  single scattering as in §5.1: a ray enters along -i at a
 *               uniform position, its first hit P (grain of normal m, or the
 *               base) scatters toward o with the local BRDF; the sample is
 *               f_local(P; i, o) (o.m)+ V(P, o) / (o.n), whose mean is the
 *               macroscopic BRDF.  Only the non-Dirac lobes are simulated:
 *               the grain diffuse lobe kd/pi (times T = (1-F)(1-F) for
 *               dielectric/conductor grains) and the base BRDF.  The specular
 *               grain lobe is a Dirac per grain point and is not included.
 *  coverage     1 if a uniform point of the plane z = h is inside a grain:
 *               mean = 1 - (1 - tau0)^(1 - h^2) for the Boolean model.
 */
#ifndef BRDFTAB_MICROGRAIN_EXPLICIT_H
#define BRDFTAB_MICROGRAIN_EXPLICIT_H

#include "../common/compat.h"
#include "../common/bt_math.h"
#include "../common/philox.h"
#include "../common/sampler.h"
#include "../common/vec3.h"
#include "micrograin_materials.h"

#define MGX_MAX_PER_CELL 40
#define MGX_MAX_CELLS 20000
#define MGX_MAX_TRIES 4096
#define MGX_EPS R(1e-7)

typedef struct {
    uint k0, k1;     /* realisation seed */
    REAL ax, ay;     /* cell size = grain semi-axes 1/beta */
    REAL bx, by;     /* beta_x, beta_y */
    REAL lambda;     /* mean grains per cell */
} mgx_field;

/* Realisation `attempt` of this sample (rejection draws a new realisation
 * with every new point: see mgx_g_sample). */
BT_INLINE mgx_field mgx_make(const REAL* p, const bt_sampler* s, uint attempt)
{
    mgx_field f;
    f.k0 = bt_philox_u32(s, 20u);
    f.k1 = bt_philox_u32(s, 21u) + attempt * 0x9E3779B9u;
    f.bx = p[MG_PARAM_BETA_X];
    f.by = p[MG_PARAM_BETA_Y];
    f.ax = R(1.0) / p[MG_PARAM_BETA_X];
    f.ay = R(1.0) / p[MG_PARAM_BETA_Y];
    f.lambda = -mg_log1m(p[MG_PARAM_TAU0]) * BT_INV_PI; /* rho * ax * ay, eq. 9 */
    return f;
}

/* Number of grains in cell (cx, cy): Poisson(lambda) by inversion. */
BT_INLINE int mgx_cell_count(const mgx_field* f, int cx, int cy)
{
    uint w[4];
    bt_philox4x32_10((uint)cx, (uint)cy, 0u, 0x6D67u, f->k0, f->k1, w);
    REAL u = bt_u32_to_unit(w[0]);
    REAL pk = bt_exp(-f->lambda), F = pk;
    int n = 0;
    while (u >= F && n < MGX_MAX_PER_CELL) {
        ++n;
        pk *= f->lambda / (REAL)n;
        F += pk;
    }
    return n;
}

/* Centre of grain j of cell (cx, cy).  (Absolute coordinates: float builds
 * lose ~1e-7 relative precision on long grazing rays; the references are
 * meant to be run in double.) */
BT_INLINE void mgx_grain(const mgx_field* f, int cx, int cy, int j, REAL* gx, REAL* gy)
{
    uint w[4];
    bt_philox4x32_10((uint)cx, (uint)cy, (uint)(j + 1), 0x6D67u, f->k0, f->k1, w);
    *gx = ((REAL)cx + bt_u32_to_unit(w[0])) * f->ax;
    *gy = ((REAL)cy + bt_u32_to_unit(w[1])) * f->ay;
}

/* Is (x, y, z) strictly inside some grain? */
BT_INLINE int mgx_inside(const mgx_field* f, REAL x, REAL y, REAL z)
{
    int cx = (int)floor(x / f->ax), cy = (int)floor(y / f->ay);
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            int n = mgx_cell_count(f, cx + dx, cy + dy);
            for (int j = 0; j < n; ++j) {
                REAL gx, gy;
                mgx_grain(f, cx + dx, cy + dy, j, &gx, &gy);
                REAL X = (x - gx) * f->bx, Y = (y - gy) * f->by;
                if (X * X + Y * Y + z * z < R(1.0)) return 1;
            }
        }
    return 0;
}

/* Ray org + t d against the grains of the 3x3 cells around (cx, cy).
 * any_hit: return at the first grain hit with t in (eps, tmax).
 * Otherwise track the nearest entry t1 in (-eps, *tbest) and its grain. */
BT_INLINE int mgx_test_cells(const mgx_field* f, int cx, int cy, bt_vec3 org, bt_vec3 d,
                             REAL tmax, int any_hit, REAL* tbest, REAL* hgx, REAL* hgy)
{
    int found = 0;
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            int n = mgx_cell_count(f, cx + dx, cy + dy);
            for (int j = 0; j < n; ++j) {
                REAL gx, gy;
                mgx_grain(f, cx + dx, cy + dy, j, &gx, &gy);
                REAL X = (org.x - gx) * f->bx, Y = (org.y - gy) * f->by, Z = org.z;
                REAL DX = d.x * f->bx, DY = d.y * f->by, DZ = d.z;
                REAL a = DX * DX + DY * DY + DZ * DZ;
                REAL b = X * DX + Y * DY + Z * DZ;
                REAL c = X * X + Y * Y + Z * Z - R(1.0);
                REAL disc = b * b - a * c;
                if (!(disc > R(0.0))) continue;
                REAL sq = sqrt(disc);
                REAL t1 = (-b - sq) / a, t2 = (-b + sq) / a;
                if (any_hit) {
                    if (t2 > MGX_EPS && t1 < tmax) return 1;
                } else if (t2 > MGX_EPS && t1 > -MGX_EPS && t1 < *tbest) {
                    *tbest = t1;
                    *hgx = gx;
                    *hgy = gy;
                    found = 1;
                }
            }
        }
    return found;
}

/* DDA over the cells crossed by org + t d, t in [0, tmax].  any_hit: returns
 * 1 if blocked.  Otherwise returns 1 if a grain is hit before tmax, with the
 * nearest entry in *thit and the grain centre in (*hgx, *hgy). */
BT_INLINE int mgx_trace(const mgx_field* f, bt_vec3 org, bt_vec3 d, REAL tmax, int any_hit,
                        REAL* thit, REAL* hgx, REAL* hgy)
{
    REAL X0 = org.x / f->ax, Y0 = org.y / f->ay;
    REAL DX = d.x / f->ax, DY = d.y / f->ay;
    int cx = (int)floor(X0), cy = (int)floor(Y0);
    int sx = DX > R(0.0) ? 1 : -1, sy = DY > R(0.0) ? 1 : -1;
    REAL big = R(1e30);
    REAL tdx = fabs(DX) > R(0.0) ? R(1.0) / fabs(DX) : big;
    REAL tdy = fabs(DY) > R(0.0) ? R(1.0) / fabs(DY) : big;
    REAL tmx = fabs(DX) > R(0.0) ? (DX > R(0.0) ? ((REAL)cx + R(1.0) - X0) : (X0 - (REAL)cx)) * tdx : big;
    REAL tmy = fabs(DY) > R(0.0) ? (DY > R(0.0) ? ((REAL)cy + R(1.0) - Y0) : (Y0 - (REAL)cy)) * tdy : big;
    REAL tbest = tmax;
    int found = 0;
    REAL tenter = R(0.0);
    for (int k = 0; k < MGX_MAX_CELLS; ++k) {
        if (any_hit) {
            if (mgx_test_cells(f, cx, cy, org, d, tmax, 1, &tbest, hgx, hgy)) return 1;
        } else {
            /* Every grain entered before tenter has been seen already (its
             * entry point lies in an earlier cell, whose 3x3 block was
             * tested), so the nearest hit is final once tbest <= tenter. */
            if (found && tbest <= tenter) break;
            found |= mgx_test_cells(f, cx, cy, org, d, tmax, 0, &tbest, hgx, hgy);
        }
        if (tmx < tmy) {
            tenter = tmx;
            cx += sx;
            tmx += tdx;
        } else {
            tenter = tmy;
            cy += sy;
            tmy += tdy;
        }
        if (tenter > tmax) {
            if (any_hit) return 0;
            *thit = tbest;
            return found;
        }
    }
    if (any_hit) return 1; /* cell cap: counted as blocked (header comment) */
    *thit = tbest;
    return found;
}

/* Is the upward ray from org toward v (v.z > 0) blocked by a grain? */
BT_INLINE int mgx_blocked(const mgx_field* f, bt_vec3 org, bt_vec3 v)
{
    REAL t, gx, gy;
    REAL tmax = (R(1.0) - org.z) / v.z + MGX_EPS;
    return mgx_trace(f, org, v, tmax, 1, &t, &gx, &gy);
}

/* G1 (single != 0) or G (both directions) at a uniform pore point at height
 * h; see the header comment. */
BT_INLINE REAL mgx_g_sample(bt_vec3 i, bt_vec3 o, int single, const REAL* p, const bt_sampler* s)
{
    /* G1_dist is a ratio of ensemble means (visible pore area / pore area),
     * so a rejected point must be redrawn together with a new realisation:
     * redrawing only the point inside one realisation would weight every
     * realisation equally instead of by its pore area (measured: G1 biased
     * from 0.948 to 0.75 at tau0 = 0.5, theta_i = 30 deg, h = 0). */
    mgx_field f = mgx_make(p, s, 0u);
    REAL h = bt_clamp(p[MG_PARAM_H], R(0.0), R(1.0));
    REAL x = R(0.0), y = R(0.0);
    int ok = 0;
    for (int k = 0; k < MGX_MAX_TRIES && !ok; ++k) {
        uint d0 = k == 0 ? 0u : 24u + 2u * (uint)k;
        f = mgx_make(p, s, (uint)k);
        x = bt_uniform(s, d0) * f.ax;
        y = bt_uniform(s, d0 + 1u) * f.ay;
        ok = !mgx_inside(&f, x, y, h);
    }
    if (!ok) return R(0.0); /* probability < 1e-17 for tau0 <= 0.99 */
    bt_vec3 org = bt_v3(x, y, h);
    if (mgx_blocked(&f, org, i)) return R(0.0);
    if (single) return R(1.0);
    return mgx_blocked(&f, org, o) ? R(0.0) : R(1.0);
}

/* Single-scattering BRDF sample (header comment). */
BT_INLINE REAL mgx_brdf_sample(bt_vec3 i, bt_vec3 o, const REAL* p, const int* opt,
                               const bt_sampler* s)
{
    mgx_field f = mgx_make(p, s, 0u);
    bt_vec3 org = bt_v3(bt_uniform(s, 0) * f.ax, bt_uniform(s, 1) * f.ay, R(1.0));
    bt_vec3 d = bt_v3_neg(i);
    REAL tbase = R(1.0) / i.z; /* reaches z = 0 */
    REAL t = tbase, gx = R(0.0), gy = R(0.0);
    int grain = mgx_trace(&f, org, d, tbase, 0, &t, &gx, &gy);
    if (grain) {
        bt_vec3 P = bt_v3_add(org, bt_v3_scale(d, t));
        bt_vec3 m = bt_v3_normalize(
            bt_v3((P.x - gx) * f.bx * f.bx, (P.y - gy) * f.by * f.by, fmax(P.z, R(0.0))));
        REAL im = bt_v3_dot(i, m), om = bt_v3_dot(o, m);
        if (!(om > R(0.0)) || !(im > R(0.0))) return R(0.0);
        REAL kd = p[MG_PARAM_KD];
        if (!(kd > R(0.0))) return R(0.0);
        if (mgx_blocked(&f, P, o)) return R(0.0);
        REAL T = (R(1.0) - mg_grain_fresnel(im, p, opt[MG_OPT_GRAIN])) * (R(1.0) - mg_grain_fresnel(om, p, opt[MG_OPT_GRAIN]));
        return kd * BT_INV_PI * T * om / o.z;
    }
    if (opt[MG_OPT_BASE] == MG_BASE_ABSORBING) return R(0.0);
    bt_vec3 P = bt_v3(org.x + d.x * tbase, org.y + d.y * tbase, R(0.0));
    if (mgx_blocked(&f, P, o)) return R(0.0);
    return mg_f_base(i, o, p, opt); /* f_B (o.n) / (o.n) */
}

/* 1 if a uniform point of the plane z = h lies inside a grain. */
BT_INLINE REAL mgx_coverage_sample(const REAL* p, const bt_sampler* s)
{
    mgx_field f = mgx_make(p, s, 0u);
    REAL x = bt_uniform(s, 0) * f.ax, y = bt_uniform(s, 1) * f.ay;
    return mgx_inside(&f, x, y, bt_clamp(p[MG_PARAM_H], R(0.0), R(1.0))) ? R(1.0) : R(0.0);
}

#endif /* BRDFTAB_MICROGRAIN_EXPLICIT_H */

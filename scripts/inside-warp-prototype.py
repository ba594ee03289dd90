#!/usr/bin/env python3
"""inside-warp-prototype.py: how well could mu_i warps that follow alpha tabulate
rough-dielectric albedos for light from inside?  (docs/planning.md, "Light from
inside".)

The table format gives an axis at most one dependency (a `critical` mu_i axis
follows eta).  This script measures what a mu_i axis following eta AND alpha
would reach, without touching the format: it places the nodes itself,
evaluates them with `brdftab eval --points` (quadrature, --nodes), interpolates
(multilinear or Catmull-Rom in the warped coordinates, as the lookup library
does for dependent axes: t of mu_i at the query's own alpha and eta, then
interpolation between the alpha/eta nodes at that t) and compares with
`brdftab eval` at 24 quadrature nodes on random probes over eta in
[--emin, --emax], alpha in [--amin, 1]: half of them within 0.3 of the critical
cosine (log distance), a sixth near grazing, the rest uniform in mu_i.

Warps of |mu_i| per side of the kink mu_c = sqrt(1 - 1/eta^2) (the node
`--frac` of the way along sits on it, clamped as brdftab's `critical` does):
  pow2  distances s^2 from the kink (brdftab's `critical`, grading 2);
  sqrtw uniform in sqrt(d + w) - sqrt(w), w = c alpha / eta;
  log   uniform in log(1 + d / w);
  dlog  as log, and on the total-reflection side also crowded towards grazing:
        uniform in log(1 + d/w) - log(1 + (W - d)/g), g = gz alpha.

Needs numpy and a brdftab binary (--brdftab, default `brdftab` on PATH).
Results are cached under --cache (evaluations are keyed by their points).
Example: inside-warp-prototype.py --warp dlog --c 1 --gz 3 --nmu 64 --na 16 --ne 16 --espace logm1
"""
import argparse
import hashlib
import io
import os
import subprocess
import sys

import numpy as np

MU_MIN = 0.02  # the preset's grazing limit: |mu_i| >= 0.02


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--brdftab", default="brdftab")
    ap.add_argument("--cache", default="/tmp/brdftab-inside-warp")
    ap.add_argument("--nmu", type=int, default=64, help="mu_i nodes (half on each side of the kink)")
    ap.add_argument("--na", type=int, default=16, help="alpha nodes")
    ap.add_argument("--ne", type=int, default=16, help="eta nodes")
    ap.add_argument("--emin", type=float, default=1.07)
    ap.add_argument("--emax", type=float, default=3.0)
    ap.add_argument("--amin", type=float, default=0.001)
    ap.add_argument("--warp", choices=["pow2", "sqrtw", "log", "dlog"], default="dlog")
    ap.add_argument("--c", type=float, default=1.0, help="kink width factor: w = c alpha / eta")
    ap.add_argument("--gz", type=float, default=3.0, help="dlog: grazing width factor: g = gz alpha")
    ap.add_argument("--aspace", choices=["log", "quadratic", "linear", "logoff"], default="log",
                    help="alpha nodes; logoff: geometric in alpha + --aoffset")
    ap.add_argument("--aoffset", type=float, default=0.003, help="logoff: the offset added to alpha")
    ap.add_argument("--espace", choices=["log", "logm1", "linear"], default="log",
                    help="eta nodes: geometric in eta (log) or in eta - 1 (logm1)")
    ap.add_argument("--frac", type=float, default=0.5, help="where the kink node sits, fraction of the nodes")
    ap.add_argument("--quantity", default="albedo_r", choices=["albedo_r", "albedo_t"])
    ap.add_argument("--nodes", type=int, default=12, help="quadrature nodes of the tabulated values")
    ap.add_argument("--probes", type=int, default=6000)
    ap.add_argument("--cubic", action="store_true", help="Catmull-Rom instead of multilinear")
    a = ap.parse_args()
    os.makedirs(a.cache, exist_ok=True)

    def evaluate(pts, nodes):
        key = hashlib.md5(pts.tobytes() + a.quantity.encode() + str(nodes).encode()).hexdigest()
        fn = os.path.join(a.cache, key + ".npy")
        if os.path.exists(fn):
            return np.load(fn)
        csv = os.path.join(a.cache, "points.csv")
        np.savetxt(csv, pts, delimiter=",", header="mu_i,alpha,eta", comments="", fmt="%.17g")
        r = subprocess.run([a.brdftab, "eval", "rough-dielectric", a.quantity, "--points", csv,
                            "nodes=%d" % nodes, "distribution=ggx"], capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit("brdftab eval failed: " + r.stderr.strip())
        v = np.genfromtxt(io.StringIO(r.stdout), delimiter=",", names=True)["value"]
        np.save(fn, v)
        return v

    def space(kind, lo, hi, n):
        t = np.linspace(0, 1, n)
        if kind == "log":
            return lo * (hi / lo) ** t
        if kind == "quadratic":
            return lo + t * t * (hi - lo)
        if kind == "logm1":
            return 1 + (lo - 1) * ((hi - 1) / (lo - 1)) ** t
        if kind == "logoff":
            return (lo + a.aoffset) * ((hi + a.aoffset) / (lo + a.aoffset)) ** t - a.aoffset
        return lo + t * (hi - lo)

    def unspace(kind, lo, hi, x):
        if kind == "log":
            return np.log(x / lo) / np.log(hi / lo)
        if kind == "quadratic":
            return np.sqrt(np.clip((x - lo) / (hi - lo), 0, None))
        if kind == "logm1":
            return np.log((x - 1) / (lo - 1)) / np.log((hi - 1) / (lo - 1))
        if kind == "logoff":
            return np.log((x + a.aoffset) / (lo + a.aoffset)) / np.log((hi + a.aoffset) / (lo + a.aoffset))
        return (x - lo) / (hi - lo)

    # The kink must sit on a node: with tc = frac exactly, an even node count
    # (say 64) has no node at 0.5, the warp's derivative jumps there between
    # nodes, and the error stalls at O(h) (measured: 0.015 -> 0.013 with twice
    # the nodes).  So tc is the node nearest to frac.
    tc = round(a.frac * (a.nmu - 1)) / (a.nmu - 1)

    def kink(eta):  # clamped as brdftab's critical spacing (each side keeps 1/16 of its share)
        muc = np.sqrt(np.maximum(0, 1 - 1 / eta ** 2))
        return np.clip(muc, MU_MIN + tc * (1 - MU_MIN) / 16, 1 - (1 - tc) * (1 - MU_MIN) / 16)

    def side_u(d, W, w, g):  # the warped coordinate of a side, increasing in d
        if a.warp == "pow2":
            return np.sqrt(d / W)
        if a.warp == "sqrtw":
            return np.sqrt(d + w) - np.sqrt(w)
        u = np.log1p(d / w)
        if a.warp == "dlog":
            g = np.asarray(g, float)
            u = u - np.where(g > 0, np.log1p((W - d) / np.where(g > 0, g, 1)), 0)
        return u

    def side_s(d, W, w, g):  # normalised to [0, 1]
        u0, u1 = side_u(0.0, W, w, g), side_u(W, W, w, g)
        return (side_u(d, W, w, g) - u0) / (u1 - u0)

    def side_d(s, W, w, g):  # inverse of side_s, by bisection (monotone)
        s = np.broadcast_to(np.asarray(s, float), np.broadcast(s, W, w).shape)
        lo, hi = np.zeros_like(s), np.broadcast_to(W, s.shape).astype(float).copy()
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            below = side_s(mid, W, w, g) < s
            lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        return 0.5 * (lo + hi)

    def widths(alpha, eta):
        return a.c * alpha / eta, (a.gz * alpha if a.warp == "dlog" else 0 * alpha)

    def warp(t, alpha, eta):  # t in [0, 1] -> |mu_i|
        xc = kink(eta)
        w, g = widths(alpha, eta)
        s1, s2 = np.clip((tc - t) / tc, 0, 1), np.clip((t - tc) / (1 - tc), 0, 1)
        return np.where(t <= tc, xc - side_d(s1, xc - MU_MIN, w, g), xc + side_d(s2, 1 - xc, w, 0 * g))

    def unwarp(mu, alpha, eta):
        xc = kink(eta)
        w, g = widths(alpha, eta)
        W1, W2 = xc - MU_MIN, 1 - xc
        return np.where(mu <= xc, tc - tc * side_s(np.clip(xc - mu, 0, W1), W1, w, g),
                        tc + (1 - tc) * side_s(np.clip(mu - xc, 0, W2), W2, w, 0 * g))

    A = space(a.aspace, a.amin, 1.0, a.na)
    E = space(a.espace, a.emin, a.emax, a.ne)
    T = np.linspace(0, 1, a.nmu)
    pts = []
    for e in E:
        for al in A:
            mu = warp(T, np.full_like(T, al), np.full_like(T, e))
            mu[0], mu[-1] = MU_MIN, 1.0
            pts += [(-m, al, e) for m in mu]
    vals = evaluate(np.array(pts), a.nodes).reshape(a.ne, a.na, a.nmu)

    rng = np.random.default_rng(5)
    n = a.probes
    eta = np.exp(rng.uniform(np.log(a.emin), np.log(a.emax), n))
    alpha = np.exp(rng.uniform(np.log(a.amin), 0, n))
    muc = np.sqrt(1 - 1 / eta ** 2)
    pick = rng.random(n)
    d = np.exp(rng.uniform(np.log(1e-5), np.log(0.3), n)) * np.where(rng.random(n) < 0.5, -1, 1)
    mu = rng.uniform(MU_MIN, 1, n)
    mu = np.where(pick < 0.5, np.clip(muc + d, MU_MIN, 1), mu)
    mu = np.where(pick > 0.85, MU_MIN + np.exp(rng.uniform(np.log(1e-4), np.log(0.3), n)), mu)
    ref = evaluate(np.column_stack([-mu, alpha, eta]), 24)

    def cell(nodes_t, x):
        j = np.clip(np.searchsorted(nodes_t, x, side="right") - 1, 0, len(nodes_t) - 2)
        return j, np.clip((x - nodes_t[j]) / (nodes_t[j + 1] - nodes_t[j]), 0, 1)

    ja, fa = cell(np.linspace(0, 1, a.na), unspace(a.aspace, a.amin, 1.0, alpha))
    je, fe = cell(np.linspace(0, 1, a.ne), unspace(a.espace, a.emin, a.emax, eta))
    jm, fm = cell(T, unwarp(mu, alpha, eta))
    out = np.zeros(n)
    if a.cubic:
        def catmull_rom(j, f, count):
            f2, f3 = f * f, f * f * f
            w = [(-f3 + 2 * f2 - f) / 2, (3 * f3 - 5 * f2 + 2) / 2, (-3 * f3 + 4 * f2 + f) / 2, (f3 - f2) / 2]
            return [np.clip(j + k, 0, count - 1) for k in (-1, 0, 1, 2)], w
        ie, we = catmull_rom(je, fe, a.ne)
        ia, wa = catmull_rom(ja, fa, a.na)
        im, wm = catmull_rom(jm, fm, a.nmu)
        for p in range(4):
            for q in range(4):
                for r in range(4):
                    out += we[p] * wa[q] * wm[r] * vals[ie[p], ia[q], im[r]]
    else:
        rows = np.arange(n)
        for de in (0, 1):
            for da in (0, 1):
                row = vals[je + de, ja + da]
                v = row[rows, jm] * (1 - fm) + row[rows, jm + 1] * fm
                out += (fe if de else 1 - fe) * (fa if da else 1 - fa) * v
    err = np.abs(out - ref)
    print("cells %d  max %.3g  rms %.3g  p99 %.3g  probes > 1e-3: %d of %d" % (
        a.nmu * a.na * a.ne, err.max(), np.sqrt((err ** 2).mean()), np.quantile(err, 0.99), (err > 1e-3).sum(), n))
    for k in np.argsort(-err)[:6]:
        print("  error %.3g at mu_i %.5f (kink %+.2e) alpha %.4g eta %.4f, reference %.4f" % (
            err[k], -mu[k], mu[k] - muc[k], alpha[k], eta[k], ref[k]))
    edges = [0, 0.003, 0.01, 0.03, 0.1, 0.3, 1.01]
    print("max by alpha: " + "  ".join("<%g: %.1e" % (hi, err[(alpha >= lo) & (alpha < hi)].max(initial=0))
                                       for lo, hi in zip(edges, edges[1:])))


if __name__ == "__main__":
    main()

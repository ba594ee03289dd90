#!/usr/bin/env python3
"""An independent reader of brdftab's adaptive tables, written from
docs/format.md ("Adaptive tables", "Axis datasets", "Spacings with
parameters") with numpy and h5py only.

    read_adaptive.py FILE TABLE POINTS.csv

POINTS.csv has a header of axis names and one point per row; prints the
rows with a `value` column, each value with 17 significant digits.
"""
import csv
import itertools
import json
import math
import sys

import h5py
import numpy as np


def inverse_warp(ds, x, point):
    """t(x) of the axis dataset `ds` (format.md's tables), x in axis units."""
    a = ds.attrs
    spacing = a["spacing"]
    if isinstance(spacing, bytes):
        spacing = spacing.decode()
    lo, hi = float(a["min"]), float(a["max"])
    x = min(max(x, lo), hi)
    if x == lo:
        return 0.0
    if x == hi:
        return 1.0
    if spacing == "linear":
        return (x - lo) / (hi - lo)
    if spacing == "cos":
        c0, c1 = math.cos(math.radians(lo)), math.cos(math.radians(hi))
        return (math.cos(math.radians(x)) - c0) / (c1 - c0)
    if spacing == "log":
        return math.log(x / lo) / math.log(hi / lo)
    if spacing == "quadratic":
        return math.sqrt((x - lo) / (hi - lo))
    if spacing == "log-complement":
        p = float(a["pivot"])
        return math.log((p - x) / (p - lo)) / math.log((p - hi) / (p - lo))
    if spacing == "explicit":
        v = ds[...]
        k = min(max(int(np.searchsorted(v, x, side="right")) - 1, 0), len(v) - 2)
        return (k + (x - v[k]) / (v[k + 1] - v[k])) / (len(v) - 1)
    if spacing == "critical":
        count = ds.shape[0]
        tc = float(a["critical_node"]) / (count - 1)
        q = float(a["grading"])
        if "depends_on" in a:
            dep = a["depends_on"]
            eta = point[dep.decode() if isinstance(dep, bytes) else dep]
        else:
            eta = float(a["critical_eta"])
        inside = hi <= 0
        r = 1 / eta if inside else eta
        mu_c = math.sqrt(max(0.0, 1 - r * r))
        w, span = 1 / 16, hi - lo
        xc = min(max(-mu_c if inside else mu_c, lo + w * tc * span), hi - w * (1 - tc) * span)
        if x <= xc:
            return tc * (1 - ((xc - x) / (xc - lo)) ** (1 / q))
        return tc + (1 - tc) * ((x - xc) / (hi - xc)) ** (1 / q)
    raise SystemExit(f"unknown spacing {spacing!r}")


def stencil(u, n, order):
    """First stencil node and weights of patch coordinate u (format.md, step 3)."""
    if order == 2:
        i = 2 * min(int(math.floor(u / 2)), (n - 1) // 2 - 1)
        s = u - i
        return i, [0.5 * (s - 1) * (s - 2), s * (2 - s), 0.5 * s * (s - 1)]
    i = min(int(math.floor(u)), n - 2)
    return i, [1 - (u - i), u - i]


def interpolate(value, nodes, box, leaf, u, n, order):
    """Leaf `leaf`'s interpolant at patch coordinates u (step 4); the value
    indices with a nonzero weight are returned too."""
    d = len(u)
    base, weights = [], []
    for a in range(d):
        i, w = stencil(u[a], n, order)
        base.append(i)
        weights.append(w)
    total, used = 0.0, []
    for combo in itertools.product(*[range(len(w)) for w in weights]):
        w, idx = 1.0, 0
        for a in range(d):
            w *= weights[a][combo[a]]
            idx = idx * n + base[a] + combo[a]
        if w != 0:
            total += w * value[nodes[leaf, idx]]
            used.append(int(nodes[leaf, idx]))
    return total, used


def resolve_hanging(value, nodes, box, hanging_leaf, n, order):
    """Appends the hanging nodes' values to `value` (format.md, "Hanging
    nodes"), in the order of hanging_leaf."""
    stored = len(value)
    d = box.shape[1]
    flat = nodes.reshape(-1)
    ids, first = np.unique(flat, return_index=True)
    first_entry = dict(zip(ids.tolist(), first.tolist()))
    out = list(value)
    per = nodes.shape[1]
    for j, c in enumerate(hanging_leaf):
        m = stored + j
        e = first_entry[m]
        leaf, k = divmod(e, per)
        digits = []
        for _ in range(d):
            k, r = divmod(k, n)
            digits.append(r)
        digits.reverse()  # the last axis varies fastest
        u = []
        for a in range(d):
            lo, hi = box[leaf, a]
            t = lo + digits[a] * ((hi - lo) / (n - 1))
            clo, chi = box[c, a]
            x = (t - clo) * ((n - 1) / (chi - clo))
            x = round(x * 2.0**32) / 2.0**32
            u.append(min(max(x, 0.0), n - 1.0))
        v, used = interpolate(out, nodes, box, c, u, n, order)
        assert all(i < m for i in used), "a hanging node needs a later one"
        out.append(v)
    return np.array(out)


def main():
    path, table, points = sys.argv[1:4]
    with h5py.File(path, "r") as f:
        g = f[table]
        rep = g.attrs["representation"]
        assert (rep.decode() if isinstance(rep, bytes) else rep) == "adaptive"
        names = json.loads(g.attrs["axes"])
        d = len(names)
        n = int(g.attrs["patch_nodes"])
        order = int(g.attrs["patch_order"]) if "patch_order" in g.attrs else 1
        value = g["value"][...].astype(np.float64)
        tree_axis = g["tree_axis"][...]
        tree_split = g["tree_split"][...]
        tree_child = g["tree_child"][...]
        box = g["leaf_box"][...]
        nodes = g["leaf_nodes"][...]
        if "hanging_leaf" in g:
            value = resolve_hanging(value, nodes, box, g["hanging_leaf"][...].tolist(), n, order)
        axes = [g[name] for name in names]
        with open(points, newline="") as fp:
            rows = list(csv.reader(fp))
        header = rows[0]
        out = csv.writer(sys.stdout, lineterminator="\n")
        out.writerow(header + ["value"])
        for row in rows[1:]:
            point = {h: float(v) for h, v in zip(header, row)}
            # The axes a critical axis depends on are clamped first.
            for name, ds in zip(names, axes):
                point[name] = min(max(point[name], float(ds.attrs["min"])), float(ds.attrs["max"]))
            t = [min(max(inverse_warp(ds, point[name], point), 0.0), 1.0) for name, ds in zip(names, axes)]
            k = 0
            while tree_axis[k] >= 0:
                k = tree_child[k][0] if t[tree_axis[k]] < tree_split[k] else tree_child[k][1]
            leaf = tree_child[k][0]
            u = []
            for a in range(d):
                lo, hi = box[leaf, a]
                x = (min(max(t[a], lo), hi) - lo) * ((n - 1) / (hi - lo))
                u.append(min(max(x, 0.0), n - 1.0))
            total, _ = interpolate(value, nodes, box, leaf, u, n, order)
            out.writerow(row + [repr(float(total))])


if __name__ == "__main__":
    main()

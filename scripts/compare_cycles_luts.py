#!/usr/bin/env python3
"""Compare brdftab's Cycles tables (tables/renderers/cycles.toml) with the
values Cycles ships (tests/data/cycles_shader_tables.txt).

Usage:  python3 scripts/compare_cycles_luts.py CYCLES.h5 [DATA.txt]
Needs h5py and numpy.  Prints, per table: the entries compared, the largest
and the median |brdftab - Cycles|, where the largest lies (roughness r, mu,
IOR node), and how many entries differ by more than Cycles' Monte-Carlo noise
allows: 4 sigma + 5e-7 (Cycles prints six decimals), sigma = sqrt(v / N) with
N Cycles' sample count (2^23 per E entry, 2^26 per Eavg entry) and v a bound
on the variance of one sample: Cycles' E estimator is bounded in [0, 1], so
v <= E (1 - E); its Eavg estimator 2 mu E' (mu uniform, E' in [0, 1]) has
v <= 4/3 - Eavg^2.  (Sobol-Burley points converge faster than Monte Carlo, so
this sigma is an upper bound.)  The IOR node z = 0 is reported apart: there
Cycles' IOR rounds to 1.0f and its glass closure is a pass-through (E = 1),
while the model's limit IOR -> 1 is a transmission that keeps masking.
"""
import math
import os
import sys

import h5py
import numpy as np

SAMPLES = {"E": 2 ** 23, "Eavg": 2 ** 26}


def read_cycles(path):
    tables, name = {}, None
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            if line.startswith("["):
                name, first, count = line.strip("[]").split()
                tables[name] = {"first": int(first), "count": int(count), "values": []}
                continue
            tables[name]["values"].extend(float(v) for v in line.split())
    for t in tables.values():
        assert len(t["values"]) == t["count"], "truncated section"
        t["values"] = np.array(t["values"])
    return tables


def node_text(name, shape, flat):
    """(r, mu, z) node indices of a flat Cycles index, as text."""
    idx = np.unravel_index(flat, shape)
    labels = {1: ["r"], 2: ["z", "r"] if "Eavg" in name else ["mu", "r"], 3: ["z", "mu", "r"]}[len(shape)]
    return ", ".join(f"{l} node {int(i)}" for l, i in zip(labels, idx))


def main():
    h5 = sys.argv[1]
    data = sys.argv[2] if len(sys.argv) > 2 else os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "..", "tests", "data", "cycles_shader_tables.txt")
    cyc = read_cycles(data)
    f = h5py.File(h5, "r")
    for name, c in cyc.items():
        ours_full = f[name]["value"][...]
        shape = ours_full.shape
        flat = ours_full.ravel()
        sel = np.arange(c["first"], c["first"] + c["count"])
        ours, theirs = flat[sel], c["values"]
        est = f[name]["stderr"][...].ravel()[sel] if "stderr" in f[name] else np.zeros_like(ours)
        kind = "Eavg" if name.endswith("Eavg") else "E"
        n = SAMPLES[kind]
        var = ours * (1 - ours) if kind == "E" else 4.0 / 3.0 - ours ** 2
        sigma = np.sqrt(np.maximum(var, 0) / n)
        # IOR node z = 0 apart (the first axis of the glass tables).
        if len(shape) >= 2 and name.startswith("ggx_glass"):
            z = np.unravel_index(sel, shape)[0]
        else:
            z = np.ones_like(sel)
        for label, mask in (("z >= 1", z >= 1), ("z = 0", z == 0)):
            if not mask.any():
                continue
            d = np.abs(ours[mask] - theirs[mask])
            k = int(np.argmax(d))
            beyond = d > 4 * sigma[mask] + 5e-7
            where = node_text(name, shape, sel[mask][k])
            print(f"{name} [{label}]: {mask.sum()} entries, max |diff| {d.max():.3g} at {where} "
                  f"(brdftab {ours[mask][k]:.7f}, Cycles {theirs[mask][k]:.6f}, sigma bound "
                  f"{sigma[mask][k]:.2g}), median {np.median(d):.3g}, beyond 4 sigma + 5e-7: "
                  f"{int(beyond.sum())}, brdftab error estimate max {est[mask].max():.2g}")
            if beyond.any():
                worst = np.argsort(-(d - 4 * sigma[mask]))[:3]
                for w in worst:
                    if not beyond[w]:
                        break
                    print(f"    {node_text(name, shape, sel[mask][w])}: brdftab {ours[mask][w]:.7f} "
                          f"Cycles {theirs[mask][w]:.6f} diff {ours[mask][w] - theirs[mask][w]:+.3g} "
                          f"sigma {sigma[mask][w]:.2g}")


if __name__ == "__main__":
    main()

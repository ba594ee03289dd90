#!/usr/bin/env python3
"""Certify brdftab's Cycles tables in Cycles' own interpolation.

Usage:  python3 scripts/certify_cycles_luts.py CYCLES.h5 BRDFTAB [--write]
Needs h5py and numpy.  Cycles reads its tables multilinearly in its node
coordinates (node k of n at k/(n-1) in roughness r = sqrt(alpha), in mu and
in z, IOR = (1 + z^2)/(1 - z^2)), so the value a renderer sees at the centre
of a cell is the mean of the cell's corners.  For every cell of every table
this script evaluates the model directly at the cell centre (`brdftab eval`,
the table's own quantity, options and quadrature nodes) and reports the
largest and the RMS |interpolated - direct|, where the largest lies, and the
direct values' largest error estimate.  With --write the figures are stored
as attributes certificate_cycles_* on each table's group (the file is
replaced atomically).  The centre is where multilinear interpolation errs
most for a smooth function; the figures are a measured total error at those
probes, not a bound.
"""
import itertools
import json
import os
import shutil
import subprocess
import sys
import tempfile

import h5py
import numpy as np


def coordinates(name, values):
    """Cycles' coordinate of each node of a table axis, and its inverse."""
    n = len(values)
    t = np.arange(n) / (n - 1)
    if name == "alpha":
        return t, lambda c: ("alpha", c * c)
    if name == "mu_i":
        return t, lambda c: ("mu_i", c)
    if name == "theta_i":  # light from inside: theta_i = 180 - acos(mu)
        return t, lambda c: ("theta_i", 180.0 - np.degrees(np.arccos(c)))
    if name == "eta":
        return t, lambda c: ("eta", (1 + c * c) / (1 - c * c))
    raise SystemExit(f"axis {name}: not a Cycles axis")


def main():
    h5, bt = sys.argv[1], sys.argv[2]
    write = "--write" in sys.argv[3:]
    results = {}
    with h5py.File(h5, "r") as f:
        for name in f:
            g = f[name]
            axis_names = json.loads(g.attrs["axes"])  # outermost first
            values = g["value"][...]
            params = json.loads(g.attrs["parameters"])
            quantity = g.attrs["quantity"]
            if isinstance(quantity, bytes):
                quantity = quantity.decode()
            maps = [coordinates(a, g[a][...]) for a in axis_names]
            # Cell centres in Cycles' coordinates and the multilinear mean of the corners.
            shape = values.shape
            cells = list(itertools.product(*[range(n - 1) for n in shape]))
            rows, interp = [], []
            for c in cells:
                point = {}
                for d, k in enumerate(c):
                    t = maps[d][0]
                    key, v = maps[d][1](0.5 * (t[k] + t[k + 1]))
                    point[key] = v
                rows.append(point)
                corners = itertools.product(*[(k, k + 1) for k in c])
                interp.append(np.mean([values[idx] for idx in corners]))
            fixed = {k: v for k, v in params.items() if k not in rows[0]}
            with tempfile.TemporaryDirectory() as tmp:
                pts = os.path.join(tmp, "points.csv")
                keys = list(rows[0])
                with open(pts, "w") as out:
                    out.write(",".join(keys) + "\n")
                    for r in rows:
                        out.write(",".join("%.17g" % r[k] for k in keys) + "\n")
                args = [bt, "eval", "rough-dielectric", quantity, "--points", pts, "-o",
                        os.path.join(tmp, "direct.csv")]
                args += ["%s=%s" % (k, (int(v) if k == "nodes" else v)) for k, v in fixed.items()]
                subprocess.run(args, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                data = np.genfromtxt(os.path.join(tmp, "direct.csv"), delimiter=",", names=True)
            direct = np.atleast_1d(data["value"])
            est = np.atleast_1d(data["stderr"])
            err = np.abs(np.array(interp) - direct)
            k = int(np.argmax(err))
            results[name] = {"max": float(err.max()), "rms": float(np.sqrt(np.mean(err ** 2))),
                             "at": rows[k], "probes": len(rows), "direct_estimate": float(est.max())}
            where = ", ".join(f"{a} {v:.6g}" for a, v in rows[k].items())
            print(f"{name}: {len(rows)} cell centres, max |Cycles interpolation - direct| "
                  f"{err.max():.3g} at {where}, RMS {results[name]['rms']:.3g} "
                  f"(direct values' largest error estimate {est.max():.2g})")
    if write:
        tmp = h5 + ".certify.tmp"
        shutil.copyfile(h5, tmp)
        with h5py.File(tmp, "r+") as f:
            for name, r in results.items():
                g = f[name]
                g.attrs["certificate_cycles_interpolation"] = "multilinear in (r, mu, z), node k at k/(n-1)"
                g.attrs["certificate_cycles_max"] = r["max"]
                g.attrs["certificate_cycles_rms"] = r["rms"]
                g.attrs["certificate_cycles_probes"] = r["probes"]
                g.attrs["certificate_cycles_max_at"] = json.dumps(r["at"])
        os.replace(tmp, h5)


if __name__ == "__main__":
    main()

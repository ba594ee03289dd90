#!/usr/bin/python3
"""Figures and error summary for the oren-nayar model (docs/models/oren-nayar.md).

Usage:
  /usr/bin/python3 scripts/plot_oren_nayar.py figure BRDFTAB [OUT.png]
      Paper-style Fig. 12/13: radiance L_r / E0 = f cos(theta_i) at
      sigma = 30 deg, rho = 0.9, theta_i = 75 deg, (a) in the plane of
      incidence (theta_r < 0: forward side, phi_d = 180; > 0: backward side,
      phi_d = 0), (b) in the perpendicular plane (phi_d = 90).  Exact eq. 25
      (with and without interreflection) vs the functional (eqs. 27-29) and
      qualitative (eq. 30, 0.33 and 0.57) approximations.  BRDFTAB is the
      brdftab executable; values come from `brdftab eval --points`.
      Default OUT: docs/figures/oren-nayar-plane.png
  /usr/bin/python3 scripts/plot_oren_nayar.py summary APPROX.h5
      Markdown table of max |error|, RMS error and where |error| peaks, for
      every table of a file made from tables/oren-nayar-approx-error.toml.
"""
import csv
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

SIGMA, RHO, THETA_I = 30.0, 0.9, 75.0


def evaluate(brdftab, quantity, rows, extra=()):
    """rows: list of dicts of coordinate -> value; returns the values."""
    names = list(rows[0].keys())
    with tempfile.TemporaryDirectory() as d:
        pin, pout = os.path.join(d, "in.csv"), os.path.join(d, "out.csv")
        with open(pin, "w") as f:
            f.write(",".join(names) + "\n")
            for r in rows:
                f.write(",".join(repr(float(r[n])) for n in names) + "\n")
        subprocess.run([brdftab, "eval", "oren-nayar", quantity, "--points", pin, "-o", pout,
                        *extra], check=True, stdout=subprocess.DEVNULL)
        with open(pout) as f:
            return np.array([float(r["value"]) for r in csv.DictReader(f)])


def figure(brdftab, out):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tr = np.linspace(-89.0, 89.0, 357)
    plane = [{"theta_i": THETA_I, "theta_o": abs(t), "phi_d": 0.0 if t >= 0 else 180.0,
              "sigma": SIGMA, "rho": RHO} for t in tr]
    tp = np.linspace(0.0, 89.0, 179)
    perp = [{"theta_i": THETA_I, "theta_o": t, "phi_d": 90.0, "sigma": SIGMA, "rho": RHO}
            for t in tp]
    cosi = np.cos(np.radians(THETA_I))
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4))
    for ax, rows, x, title in ((axes[0], plane, tr, "(a) plane of incidence"),
                               (axes[1], perp, tp, "(b) perpendicular plane, $\\phi_d$ = 90°")):
        exact = evaluate(brdftab, "brdf", rows)
        direct = RHO * evaluate(brdftab, "brdf_direct", rows)
        func = evaluate(brdftab, "functional", rows)
        q33 = evaluate(brdftab, "qualitative", rows)
        q57 = evaluate(brdftab, "qualitative", rows, ["qualitative_a=0.57"])
        ax.plot(x, exact * cosi, "k-", lw=2.6, label="exact eq. 25 (direct + 2-bounce)")
        ax.plot(x, direct * cosi, "k:", lw=1.2, label="exact, direct only")
        ax.plot(x, func * cosi, "-", color="tab:red", lw=1.2, label="functional eqs. 27-29")
        ax.plot(x, q33 * cosi, "--", color="tab:blue", lw=1.2, label="qualitative eq. 30")
        ax.plot(x, q57 * cosi, "-.", color="tab:green", lw=1.2,
                label="qualitative, 0.57 (footnote 7)")
        ax.axhline(RHO / np.pi * cosi, color="0.6", lw=0.8, label="Lambert $\\rho/\\pi$")
        ax.set_title(title)
        ax.set_ylabel("radiance $L_r/E_0 = f\\,\\cos\\theta_i$")
        ax.grid(alpha=0.3)
    axes[0].set_xlabel("$\\theta_r$ (deg); < 0: forward ($\\phi_d$ = 180°), > 0: backward")
    axes[0].axvline(THETA_I, color="0.4", lw=0.6)
    axes[1].set_xlabel("$\\theta_r$ (deg)")
    axes[0].legend(fontsize=7.5, loc="upper left")
    fig.suptitle(f"Oren-Nayar V-cavity surface, $\\sigma$ = {SIGMA:g}°, $\\rho$ = {RHO:g}, "
                 f"$\\theta_i$ = {THETA_I:g}° (cf. paper Figs. 12, 13)")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print("wrote", out)


def summary(path):
    import h5py
    with h5py.File(path, "r") as f:
        print("| table | max abs. error | RMS | peak at (theta_i, theta_o, phi_d, sigma) |"
              " RMS for theta_i, theta_o <= 60 |")
        print("|---|---|---|---|---|")
        for name in sorted(k for k in f if isinstance(f[k], h5py.Group)):
            g = f[name]
            axes = json.loads(g.attrs["axes"])
            v = np.asarray(g["value"][...], dtype=np.float64)
            nodes = [np.asarray(g[a][...]) for a in axes]
            k = np.unravel_index(np.argmax(np.abs(v)), v.shape)
            where = ", ".join(f"{nodes[d][k[d]]:g}" for d in range(len(axes)))
            sel = [slice(None)] * v.ndim
            for d, a in enumerate(axes):
                if a in ("theta_i", "theta_o"):
                    sel[d] = nodes[d] <= 60
            inner = v[np.ix_(*[np.arange(len(n))[s] for n, s in zip(nodes, sel)])]
            print(f"| {name} | {np.max(np.abs(v)):.3g} | {np.sqrt(np.mean(v * v)):.3g} | "
                  f"({where}) | {np.sqrt(np.mean(inner * inner)):.3g} |")


def main(argv):
    if len(argv) >= 3 and argv[1] == "figure":
        out = argv[3] if len(argv) > 3 else os.path.join(
            os.path.dirname(os.path.abspath(__file__)), "..", "docs", "figures",
            "oren-nayar-plane.png")
        figure(argv[2], out)
        return 0
    if len(argv) == 3 and argv[1] == "summary":
        summary(argv[2])
        return 0
    print(__doc__.strip(), file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv))

#!/usr/bin/python3
"""Plots for the interfaced-lambertian model (Meneveaux et al.).

Usage:
  /usr/bin/python3 scripts/plot_interfaced_lambertian.py VCAVITY.h5 OUT.png [THETA_I]
      V-cavity interreflections per bounce order, like the paper's Fig. 7:
      single bounce f1, one plus two bounces f1 + f2, and all bounces, in the
      plane of incidence.  VCAVITY.h5 from
      `brdftab generate tables/interfaced-lambertian-vcavity.toml`.
  /usr/bin/python3 scripts/plot_interfaced_lambertian.py --body BODY.h5 OUT.png [THETA_I]
      The body integral of the four distribution/GAF pairs in the plane of
      incidence (log scale), like the paper's Fig. 8.  BODY.h5 from
      `brdftab generate tables/interfaced-lambertian-body.toml`.

Only h5py, numpy and matplotlib are used.
"""
import json
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def plot_body(path, out, want_ti):
    names = ["body_gaussian_ts", "body_beckmann_ts", "body_beckmann_smith", "body_ggx_smith"]
    labels = ["Gaussian + TS", "Beckmann + TS", "Beckmann + Smith", "GGX + Smith"]
    with h5py.File(path, "r") as f:
        ni_nodes = f[names[0]]["ni"][...]
        fig, axs = plt.subplots(1, len(ni_nodes), figsize=(4.2 * len(ni_nodes), 3.6),
                                squeeze=False)
        for n, ni in enumerate(ni_nodes):
            p = axs[0][n]
            for name, label, color in zip(names, labels, ["C0", "C1", "C2", "C3"]):
                g = f[name]
                axes = json.loads(g.attrs["axes"])
                assert axes[:3] == ["theta_i", "theta_o", "phi_d"] and axes[4] == "ni", axes
                rname = axes[3]
                r = g[rname][...]
                v = g["value"][...].astype(float)
                ti = int(np.argmin(np.abs(g["theta_i"][...] - want_ti)))
                to = g["theta_o"][...]
                pd = g["phi_d"][...]
                back, fwd = int(np.argmin(np.abs(pd))), int(np.argmin(np.abs(pd - 180)))
                x = np.concatenate([-to[::-1], to])
                for k, ls in zip((1, len(r) - 1), ("--", "-")):
                    y = np.concatenate([v[ti, ::-1, back, k, n], v[ti, :, fwd, k, n]])
                    sym = "\\sigma" if rname == "sigma" else "\\alpha"
                    unit = " deg" if rname == "sigma" else ""
                    p.semilogy(x, y, ls=ls, color=color,
                               label=f"{label}, ${sym}$ = {r[k]:.3g}{unit}")
            p.set_title(f"$n_i$ = {ni:g}, $\\theta_i$ = {want_ti:g} deg", fontsize=10)
            p.set_xlabel(r"$\theta_o$ in the plane of incidence (deg; < 0: light's side)")
            p.grid(alpha=0.3, which="both")
        axs[0][0].set_ylabel("body integral (eq. 12 without prefactor)")
        axs[0][-1].legend(fontsize=6.5, loc="lower left")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    return 0


def main(argv):
    if len(argv) >= 4 and argv[1] == "--body":
        return plot_body(argv[2], argv[3], float(argv[4]) if len(argv) > 4 else 60.0)
    if len(argv) < 3:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    want_ti = float(argv[3]) if len(argv) > 3 else 60.0
    with h5py.File(argv[1], "r") as f:
        g = f["vcavity"]
        axes = json.loads(g.attrs["axes"])
        assert axes == ["order", "ni", "alpha", "theta_i", "phi_d", "theta_o"], axes
        ax = {name: g[name][...] for name in axes}
        v = g["value"][...].astype(float)
        se = g["stderr"][...].astype(float) if "stderr" in g else np.zeros_like(v)
        kd = None
        try:
            kd = json.loads(g.attrs["parameters"]).get("kd")
        except Exception:  # attribute layout is informative only
            pass
    orders = list(ax["order"])
    k_all, k1, k2 = orders.index(0.0), orders.index(1.0), orders.index(2.0)
    ti = int(np.argmin(np.abs(ax["theta_i"] - want_ti)))
    back = int(np.argmin(np.abs(ax["phi_d"] - 0.0)))
    fwd = int(np.argmin(np.abs(ax["phi_d"] - 180.0)))
    to = ax["theta_o"]
    # Signed angle in the plane of incidence: negative = back-scattering side.
    x = np.concatenate([-to[::-1], to])

    def plane(k, n, a):
        return np.concatenate([v[k, n, a, ti, back, ::-1], v[k, n, a, ti, fwd, :]])

    def plane_se(k, n, a):
        return np.concatenate([se[k, n, a, ti, back, ::-1], se[k, n, a, ti, fwd, :]])

    nn, na = len(ax["ni"]), len(ax["alpha"])
    fig, axs = plt.subplots(nn, na, figsize=(4.0 * na, 3.3 * nn), sharex=True, squeeze=False)
    for n in range(nn):
        for a in range(na):
            p = axs[n][a]
            f1 = plane(k1, n, a)
            f12 = f1 + plane(k2, n, a)
            fall = plane(k_all, n, a)
            p.plot(x, f1, label="$f_1$ (1 bounce)", color="C0")
            p.plot(x, f12, label="$f_1 + f_2$ (2 bounces)", color="C1")
            p.plot(x, fall, label=r"$f_\infty$ (all bounces)", color="C3")
            p.fill_between(x, fall - 2 * plane_se(k_all, n, a), fall + 2 * plane_se(k_all, n, a),
                           color="C3", alpha=0.2, lw=0)
            p.axvline(-ax["theta_i"][ti], color="0.6", lw=0.8, ls=":")
            p.set_title(f"$n_i$ = {ax['ni'][n]:g}, $\\alpha$ = {ax['alpha'][a]:g}", fontsize=10)
            p.set_ylim(bottom=0)
            p.grid(alpha=0.3)
            if n == nn - 1:
                p.set_xlabel(r"$\theta_o$ in the plane of incidence (deg; < 0: light's side)")
            if a == 0:
                p.set_ylabel("BRDF (1/sr)")
    axs[0][0].legend(fontsize=8, loc="lower left")
    title = (f"V-cavity interreflections, Beckmann normals, $\\theta_i$ = {ax['theta_i'][ti]:g} deg"
             + (f", $K_d$ = {kd:g}" if kd is not None else ""))
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    fig.savefig(argv[2], dpi=110)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

#!/usr/bin/python3
"""BRDF slices of the micrograin model at theta_i = 86 deg, with and without
direction correlation, against the explicit ray-traced grain simulation.

Usage:
  brdftab generate tables/micrograin-slice86.toml -o micrograin-slice86.h5
  /usr/bin/python3 scripts/plot_micrograin.py micrograin-slice86.h5 \
      docs/figures/micrograin-slice86.png

Reads the tables written by tables/micrograin-slice86.toml (axes theta_o,
phi_d; phi_i = 0) with h5py only.
"""
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def load(f, name):
    g = f[name]
    err = g["stderr"][...] if "stderr" in g else None
    return g["theta_o"][...], g["phi_d"][...], g["value"][...], err


def in_plane(th, ph, v, e):
    """Incidence-plane cut: x = +theta_o on the light's side (phi_d = 0,
    retro-reflection at x = 86), x = -theta_o on the forward side (phi_d = 180)."""
    j0 = int(np.argmin(np.abs(ph - 0.0)))
    j1 = int(np.argmin(np.abs(ph - 180.0)))
    x = np.concatenate([-th[::-1], th[1:]])
    y = np.concatenate([v[::-1, j1], v[1:, j0]])
    ey = None if e is None else np.concatenate([e[::-1, j1], e[1:, j0]])
    return x, y, ey


def main(argv):
    if len(argv) < 3:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    with h5py.File(argv[1], "r") as f:
        dc = load(f, "diffuse_correlated")
        du = load(f, "diffuse_uncorrelated")
        dx = load(f, "diffuse_explicit")
        cc = load(f, "conductor_correlated")
        cu = load(f, "conductor_uncorrelated")
    th, ph = dc[0], dc[1]
    it = int(np.argmin(np.abs(th - 86.0)))

    fig, ax = plt.subplots(2, 2, figsize=(11, 8.2))
    # (a) diffuse grains, incidence plane
    a = ax[0, 0]
    for data, style, label in ((dc, "-", "model, direction-correlated (eq. 19)"),
                               (du, "--", "model, uncorrelated (eq. 17)")):
        x, y, _ = in_plane(*data)
        a.plot(x, y, style, lw=1.6, label=label)
    x, y, ey = in_plane(*dx)
    a.errorbar(x, y, yerr=2 * ey, fmt="o", ms=3, color="k", lw=0.8,
               label="explicit grains, single scattering (±2σ)")
    a.set_xlabel("θo (deg): forward side (φd = 180) < 0 < light side (φd = 0)")
    a.set_ylabel("f (1/sr)")
    a.set_title("(a) diffuse grains kd = 0.5, τ0 = 0.5, β = 1, absorbing base")
    a.legend(fontsize=8)
    # (b) diffuse grains, azimuthal cut through the retro-reflection peak
    a = ax[0, 1]
    a.plot(ph, dc[2][it], "-", lw=1.6, label="model, correlated")
    a.plot(ph, du[2][it], "--", lw=1.6, label="model, uncorrelated")
    a.errorbar(ph, dx[2][it], yerr=2 * dx[3][it], fmt="o", ms=3, color="k", lw=0.8,
               label="explicit grains (±2σ)")
    a.set_xscale("symlog", linthresh=10)
    a.set_xlabel("φd (deg)")
    a.set_ylabel("f (1/sr)")
    a.set_title(f"(b) same, θo = {th[it]:.0f}°: retro-reflection peak")
    a.legend(fontsize=8)
    # (c) conductor grains, incidence plane (log scale)
    a = ax[1, 0]
    for data, style, label in ((cc, "-", "model, correlated"), (cu, "--", "model, uncorrelated")):
        x, y, _ = in_plane(*data)
        a.semilogy(x, np.maximum(y, 1e-6), style, lw=1.6, label=label)
    a.set_xlabel("θo (deg): forward side (φd = 180) < 0 < light side (φd = 0)")
    a.set_ylabel("f (1/sr)")
    a.set_title("(c) conductor grains 1.0152 + 6.6273i, τ0 = 0.5, β = 1")
    a.legend(fontsize=8)
    # (d) conductor: ratio correlated / uncorrelated over the slice
    a = ax[1, 1]
    ratio = np.where(cu[2] > 0, cc[2] / np.maximum(cu[2], 1e-30), 1.0)
    P, T = np.meshgrid(ph, th)
    m = a.pcolormesh(P, T, ratio, shading="nearest", cmap="magma",
                     norm=matplotlib.colors.LogNorm(vmin=1, vmax=max(ratio.max(), 1.01)))
    a.set_xscale("symlog", linthresh=10)
    fig.colorbar(m, ax=a, label="f correlated / f uncorrelated")
    a.set_xlabel("φd (deg)")
    a.set_ylabel("θo (deg)")
    a.set_title("(d) conductor grains: effect of direction correlation")
    fig.suptitle("Micrograin BRDF at θi = 86° (Lucas et al. 2024, Figs. 7-8 setting)")
    fig.tight_layout()
    fig.savefig(argv[2], dpi=110)
    # Summary numbers for docs/models/micrograin.md.
    sel = dx[2] > 0.05
    z = np.abs(dc[2] - dx[2]) / np.hypot(dx[3], dc[3] if dc[3] is not None else 0)
    rel = np.abs(dc[2] - dx[2]) / np.maximum(dx[2], 1e-12)
    print(f"diffuse, correlated vs explicit: max |z| = {z.max():.2f}, "
          f"median |z| = {np.median(z):.2f}, max rel. err where f > 0.05: {rel[sel].max():.4f}")
    zu = np.abs(du[2] - dx[2]) / np.hypot(dx[3], du[3] if du[3] is not None else 0)
    print(f"diffuse, uncorrelated vs explicit: max |z| = {zu.max():.1f}, "
          f"max rel. err where f > 0.05: {(np.abs(du[2] - dx[2]) / np.maximum(dx[2], 1e-12))[sel].max():.4f}")
    print(f"retro peak theta_o = {th[it]:.0f}: correlated {dc[2][it, 0]:.4f}, uncorrelated "
          f"{du[2][it, 0]:.4f}, explicit {dx[2][it, 0]:.4f} +- {dx[3][it, 0]:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

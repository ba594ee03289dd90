#!/usr/bin/python3
"""Figures and error tables for the Lambert-sphere model (docs/models/lambert-sphere.md).

Inputs are files written by `brdftab generate`:
  --slices  tables/lambert-sphere-slices.toml  -> in-plane slices figure (like d'Eon's Fig. 5)
  --brdf    tables/lambert-sphere-brdf.toml    -> Markdown table of its error tables' max/RMS
  --modes   tables/lambert-sphere-modes.toml   -> Fourier-mode comparison (eq. 28 factor)
  --hfunc   tables/hfunction-h.toml            -> H-function figure
Any subset may be given.  Run with Debian's /usr/bin/python3 (h5py, numpy, matplotlib).
"""
import argparse
import os

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def table(f, name):
    g = f[name]
    v = g["value"][...].astype(np.float64)
    se = g["stderr"][...].astype(np.float64) if "stderr" in g else None
    labels = [d.label for d in g["value"].dims]
    axes = {lab: g[lab][...] for lab in labels}
    return v, se, labels, axes


def plot_slices(path, out):
    with h5py.File(path, "r") as f:
        mc, mc_se, labels, ax = table(f, "brdf_mc")
        assert labels == ["theta_i", "theta_o", "phi_d", "c"], labels
        curves = {k: table(f, k)[0] for k in ("brdf_analytic", "brdf_fit", "brdf_paper", "brdf_fast",
                                                "brdf_single") if k in f}
    ti, to, phid, cs = ax["theta_i"], ax["theta_o"], ax["phi_d"], ax["c"]
    back = int(np.argmin(np.abs(phid - 0)))
    fwd = int(np.argmin(np.abs(phid - 180)))
    # signed view angle: negative = light's side (phi_d = 0), positive = forward side
    x = np.concatenate([-to[::-1], to])

    def signed(a, i, k):
        return np.concatenate([a[i, ::-1, back, k], a[i, :, fwd, k]])

    fig, axs = plt.subplots(len(cs), len(ti), figsize=(3.2 * len(ti), 2.7 * len(cs)), squeeze=False)
    styles = {
        "brdf_analytic": dict(color="C0", lw=1.6, label="analytic (exact H and constants, eqs. 9-38)"),
        "brdf_fit": dict(color="C1", lw=1.3, ls="--", label="all fitted (cos φ ×2, H1 'power')"),
        "brdf_paper": dict(color="C3", lw=1.0, ls="-.", label="paper as printed (cos φ ×1)"),
        "brdf_fast": dict(color="C2", lw=1.2, ls=":", label="fast (eq. 41)"),
        "brdf_single": dict(color="0.6", lw=1.0, label="single scattering (eq. 10)"),
    }
    for k, c in enumerate(cs):
        for i, t in enumerate(ti):
            a = axs[k][i]
            for name, st in styles.items():
                if name in curves:
                    a.plot(x, signed(curves[name], i, k), **st)
            a.errorbar(x, signed(mc, i, k), yerr=2 * signed(mc_se, i, k), fmt="k.", ms=3,
                       elinewidth=0.8, label="exact (Monte Carlo, 2 s.e.)")
            a.axvline(-t, color="0.85", lw=0.8, zorder=0)
            a.set_title(f"c = {c:g}, θi = {t:g}°", fontsize=9)
            a.tick_params(labelsize=7)
            if k == len(cs) - 1:
                a.set_xlabel("θo (deg); < 0: light's side (φd = 0)", fontsize=8)
            if i == 0:
                a.set_ylabel("f (1/sr)", fontsize=8)
    handles, names = axs[0][0].get_legend_handles_labels()
    fig.legend(handles, names, loc="lower center", ncol=len(names), fontsize=8, frameon=False)
    fig.suptitle("Lambert-sphere half space: in-plane BRDF, exact vs d'Eon's analytic model", fontsize=11)
    fig.tight_layout(rect=(0, 0.035, 1, 1))
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


def error_table(path):
    """Markdown table from the file's stored error tables ([[errors]] with by = "c")."""
    import json
    with h5py.File(path, "r") as f:
        mc, mc_se, labels, ax = table(f, "brdf_mc")
        rows = []
        for name in ("error_three_term", "error_analytic", "error_analytic_fitk",
                     "error_analytic_paper", "error_fit", "error_fit_paper", "error_fast"):
            if name in f:
                cmp = json.loads(f[name].attrs["parameters"])["comparison"]
                rows.append(cmp)
    print("\nRelative error vs Monte Carlo ((f - f_mc) / f_mc), grid of", labels,
          [len(ax[lab]) for lab in labels])
    print(f"MC relative standard error: median {np.median(mc_se / mc):.2%}, max {np.max(mc_se / mc):.2%}\n")
    if not rows:
        print("(no error tables in", path, ")")
        return
    cs = [n["c"] for n in rows[0]["by_nodes"]]
    print("| variant (max / RMS) | " + " | ".join(f"c = {c:g}" for c in cs) +
          " | all | cells beyond 2σ |")
    print("|" + "---|" * (len(cs) + 3))
    for r in rows:
        cells = [f"{n['max_abs']:.1%} / {n['rms']:.1%}" for n in r["by_nodes"]]
        cells.append(f"{r['max_abs']:.1%} / {r['rms']:.1%}")
        cells.append(f"{r['beyond_2sigma'] / r['cells']:.1%}")
        print(f"| `{r['table']}` | " + " | ".join(cells) + " |")


def plot_modes(path, out):
    with h5py.File(path, "r") as f:
        ms, ms_se, labels, ax = table(f, "ms_mc")
        an = table(f, "analytic")[0] - table(f, "single")[0]
        three = table(f, "three_term")[0] - table(f, "single")[0] if "three_term" in f else None
    assert labels == ["mode", "theta_i", "theta_o", "c"], labels
    print("\nMultiple-scattering Fourier modes, MC vs analytic (exact H), ratio MC/analytic:")
    for m in range(len(ax["mode"])):
        for k, c in enumerate(ax["c"]):
            if m == 2:
                rel = np.abs(ms[m, ..., k]).max() / np.abs(ms[0, ..., k]).max()
                line = f"  mode 2, c = {c:g}: max |f^(2)_ms| / max f^(0)_ms = {rel:.3f}"
                if three is not None:
                    z = (ms[m, ..., k] - three[m, ..., k]) / ms_se[m, ..., k]
                    line += (f"; MC - exact three-term mode 2: max {np.abs(ms[m, ..., k] - three[m, ..., k]).max():.2e}"
                             f" (max |z| {np.abs(z).max():.1f}), exact three-term max |f^(2)| {np.abs(three[m, ..., k]).max():.2e}")
                print(line)
                continue
            mask = np.abs(an[m, ..., k]) > 1e-4
            r = ms[m, ..., k][mask] / an[m, ..., k][mask]
            print(f"  mode {m}, c = {c:g}: median {np.median(r):.3f}, range [{r.min():.3f}, {r.max():.3f}]")
    panels = (0, 1, 2) if three is not None else (0, 1)
    fig, axs = plt.subplots(1, len(panels), figsize=(4.5 * len(panels), 3.6))
    for m in panels:
        a = axs[m]
        # x axis: mode 0 the analytic model; mode 1 eq. 22 - eq. 28 as printed
        # (the file's analytic table applies x2); mode 2 the exact three-term one
        xs = an[0] if m == 0 else an[1] / 2 if m == 1 else three[2]
        for k, c in enumerate(ax["c"]):
            a.errorbar(xs[..., k].ravel(), ms[m, ..., k].ravel(), yerr=2 * ms_se[m, ..., k].ravel(),
                       fmt="o", ms=3, label=f"c = {c:g}")
        lim = np.array([min(xs.min(), ms[m].min()), max(xs.max(), ms[m].max())])
        if m == 2:
            a.plot(lim, lim, "k-", lw=0.8, label="MC = exact three-term")
            a.set_title("cos 2φ mode (dropped by eq. 21)", fontsize=9)
            a.set_xlabel("exact three-term multiple scattering, mode 2", fontsize=8)
        elif m == 1:
            a.plot(lim, lim, "k:", lw=0.8, label="MC = printed (x1)")
            a.plot(lim, 2 * lim, "k-", lw=0.8, label="MC = 2 x printed")
            a.set_title("cos φ mode of multiple scattering vs eq. 22 − eq. 28", fontsize=9)
            a.set_xlabel("eq. 22 − eq. 28 (exact H1)", fontsize=8)
        else:
            a.plot(lim, lim, "k-", lw=0.8, label="MC = analytic")
            a.set_title("φ-average of multiple scattering vs eq. 30 − eq. 38", fontsize=9)
            a.set_xlabel("eq. 30 − eq. 38 (exact H0)", fontsize=8)
        a.set_ylabel("Monte Carlo, orders ≥ 2 (1/sr)", fontsize=8)
        a.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


def plot_h(path, out):
    with h5py.File(path, "r") as f:
        hs = {n: table(f, n) for n in ("H0", "H1", "H2", "H_iso")}
    fig, axs = plt.subplots(1, 4, figsize=(13, 3.2))
    for a, (n, (v, _, labels, ax)) in zip(axs, hs.items()):
        mu, cs = ax["mu"], ax["c"]
        for c in (0.2, 0.5, 0.8, 0.95, 1.0):
            k = int(np.argmin(np.abs(cs - c)))
            a.plot(mu, v[:, k], label=f"c = {cs[k]:g}")
        a.set_title(n, fontsize=10)
        a.set_xlabel("μ", fontsize=8)
    axs[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    print(f"wrote {out}")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--slices")
    p.add_argument("--brdf")
    p.add_argument("--modes")
    p.add_argument("--hfunc")
    p.add_argument("--outdir", default="docs/figures")
    a = p.parse_args()
    os.makedirs(a.outdir, exist_ok=True)
    if a.slices:
        plot_slices(a.slices, os.path.join(a.outdir, "lambert-sphere-slices.png"))
    if a.brdf:
        error_table(a.brdf)
    if a.modes:
        plot_modes(a.modes, os.path.join(a.outdir, "lambert-sphere-modes.png"))
    if a.hfunc:
        plot_h(a.hfunc, os.path.join(a.outdir, "lambert-sphere-hfunctions.png"))


if __name__ == "__main__":
    main()

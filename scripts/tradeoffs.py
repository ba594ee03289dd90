#!/usr/bin/python3
"""tradeoffs.py — measure brdftab's speed/accuracy trade (issue 13, item 6).

For one table of every preset in tables/ (shrunk: same domain, fewer nodes; see
CASES) this runs `brdftab generate` for a series of settings (node counts, every
method the quantity accepts, sample budgets, kernel precision float/double,
stored type float16/float32), measures each run's time and its total error
between the nodes, and writes:

    OUT/results.csv    one row per run (settings, times, errors)
    OUT/results.json   the same plus the machine, load, references, skipped runs
    OUT/CASE.png       log-log error-vs-time figure per preset/quantity
    OUT/summary.md     "to reach E you need T seconds and N cells" (E = 1e-2..1e-4)

Time: generate's own per-table engine time (the table attribute elapsed_seconds),
plus the wall time and user+sys CPU time of the whole generate process.

Error: a fixed set of random off-grid probe points per case; the reference is the
model evaluated directly there once (`brdftab eval --points`, the most accurate
method the quantity accepts: closed form, else quadrature, else RQMC with a large
sample budget); each table is interpolated at the same points (`brdftab query
--points`, linear and Catmull-Rom).  This is what `brdftab validate` measures, with
one quiet reference shared by every run of a case instead of one reference per
table at the table's own (noisy) method.  Measures (max and RMS over the probes):
absolute |table - reference|; "norm", that divided by max |reference|; relative,
|table - reference| / max(|reference|, 1e-3 * max |reference|) (validate's floor).
Figures and the summary use absolute errors for albedos and "norm" otherwise.

Methods are not hard-coded: the `--method` choices are read from
`brdftab generate --help` and each is tried on the quantity with `brdftab eval`;
those it accepts are measured.  A sampled method (mc, rqmc) that returns a zero
standard error on non-zero values computes the quantity deterministically: it is
left out when a closed form or quadrature is accepted (it would only repeat the
same evaluation per sample), else measured at the case's smallest budget only.

Only numpy, h5py and the standard library are used; figures are drawn with a small
PNG writer below (zlib) and the project's 5x8 bitmap font, read from
host/cli/plot_png.cpp.

Usage: /usr/bin/python3 scripts/tradeoffs.py [--quick] [--out DIR] [--brdftab BIN]
           [--case NAME ...] [--list] [--keep] [--plot-only]
"""

import argparse
import csv
import datetime
import json
import math
import os
import platform
import random
import re
import resource
import shutil
import struct
import subprocess
import sys
import tempfile
import time
import tomllib
import zlib

import h5py
import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TARGETS = [1e-2, 1e-3, 1e-4]
REL_FLOOR = 1e-3
SAMPLED = ("mc", "rqmc")

# One case per preset: the table measured, how its axes are shrunk and which
# budgets are tried.  refine: axis -> node count of the coarsest level; level k
# has 1 + (c0 - 1) * 2^k nodes on the same range and spacing (an explicit axis of
# the preset becomes a linear range over its first..last value).  hold: axis ->
# fixed values (explicit axis, probes take these values; one value makes it a
# parameter).  budgets: samples per cell for mc/rqmc.  ref: samples per probe of a
# sampled reference.  ref_quadrature: parameters of a quadrature reference (more
# nodes than the tables use, so that the reference is not the tables' own rule).  probes: random probe points (default 300).  cap: seconds of generate for the case (default 30).  quick: part of --quick (then with quick_budgets, 3 levels).
# levels: refinement levels (default 4).  metric: "abs" for albedos (values in [0, 1], where absolute error is what the
# issue's targets use); otherwise max |error| / max |reference| ("norm").  Both,
# and validate's relative error |error| / max(|reference|, 1e-3 max |reference|),
# are in the CSV; the relative one is dominated by points where the value is near
# zero (albedo_r at eta = 1, a BSDF away from its peak), so it is not plotted.
CASES = [
    dict(metric="abs", name="rough-dielectric-albedo.albedo_r", preset="rough-dielectric-albedo.toml", table="albedo_r",
         refine={"mu_i": 5, "alpha": 5, "eta": 5}, budgets=[256, 4096, 65536], ref=1 << 18,
         ref_quadrature={"nodes": 48}, cap=60.0, quick=True, quick_budgets=[256, 4096]),
    dict(metric="abs", name="rough-dielectric-albedo.albedo_t_inside", preset="rough-dielectric-albedo.toml",
         table="albedo_t_inside", refine={"mu_i": 5, "alpha": 5, "eta": 5}, budgets=[256, 4096, 65536],
         ref=1 << 18, ref_quadrature={"nodes": 48}, cap=60.0),
    dict(name="rough-dielectric-bsdf.bsdf", preset="rough-dielectric-bsdf.toml", table="bsdf",
         refine={"theta_i": 3, "theta_o": 3, "phi_d": 3, "alpha": 2, "eta": 2}),
    dict(name="oren-nayar-brdf.brdf_direct", preset="oren-nayar-brdf.toml", table="brdf_direct",
         refine={"theta_i": 3, "theta_o": 3, "phi_d": 3, "sigma": 2}, budgets=[64, 1024], ref=1 << 16),
    dict(metric="abs", name="oren-nayar-albedo.albedo_direct", preset="oren-nayar-albedo.toml", table="albedo_direct",
         refine={"mu_i": 5, "sigma": 5}, levels=5, budgets=[256, 4096, 65536], ref=1 << 18),
    dict(name="oren-nayar-approx-error.functional_rel", preset="oren-nayar-approx-error.toml",
         table="functional_rel", refine={"theta_i": 3, "theta_o": 3, "phi_d": 3, "sigma": 2},
         budgets=[64, 1024], ref=1 << 16),
    dict(name="interfaced-lambertian-body.body_ggx_smith", preset="interfaced-lambertian-body.toml",
         table="body_ggx_smith", refine={"theta_i": 3, "theta_o": 3, "phi_d": 3, "alpha": 2},
         hold={"ni": [1.5]}, budgets=[64, 1024, 16384], ref=1 << 17),
    dict(name="interfaced-lambertian-anisotropic.body", preset="interfaced-lambertian-anisotropic.toml",
         table="body", refine={"theta_i": 3, "phi_i": 2, "theta_o": 3, "phi_o": 3},
         budgets=[64, 1024, 16384], ref=1 << 17),
    dict(name="interfaced-lambertian-vcavity.vcavity", preset="interfaced-lambertian-vcavity.toml",
         table="vcavity", refine={"theta_o": 5}, levels=5, hold={"order": [0.0], "ni": [1.5], "alpha": [0.3, 1.0],
                                                      "theta_i": [30.0, 60.0], "phi_d": [0.0, 180.0]},
         budgets=[256, 4096, 65536], ref=1 << 18),
    dict(name="hfunction-h.H0", preset="hfunction-h.toml", table="H0", refine={"mu": 9, "c": 9}, levels=6,
         quick=True),
    dict(metric="abs", name="lambert-sphere-albedo.kd_mc", preset="lambert-sphere-albedo.toml", table="kd_mc",
         refine={"c": 9}, levels=5, budgets=[1024, 16384, 262144], ref=1 << 20),
    dict(name="lambert-sphere-brdf.brdf_mc", preset="lambert-sphere-brdf.toml", table="brdf_mc",
         refine={"theta_o": 3, "phi_d": 3}, hold={"theta_i": [20.0, 60.0], "c": [0.9]},
         budgets=[256, 4096, 65536], ref=1 << 18),
    dict(name="lambert-sphere-conservative.brdf_mc_1000", preset="lambert-sphere-conservative.toml",
         table="brdf_mc_1000", refine={"theta_o": 3, "phi_d": 3}, hold={"theta_i": [30.0]},
         budgets=[64, 1024, 16384], ref=1 << 16, probes=100),
    dict(name="lambert-sphere-constants.C", preset="lambert-sphere-constants.toml", table="C",
         refine={"c": 9}, levels=6, quick=True),
    dict(name="lambert-sphere-modes.analytic", preset="lambert-sphere-modes.toml", table="analytic",
         refine={"theta_i": 3, "theta_o": 3}, hold={"mode": [1], "c": [0.9]},
         budgets=[256, 4096, 65536], ref=1 << 18),
    dict(name="lambert-sphere-precision.brdf_analytic", preset="lambert-sphere-precision.toml",
         table="brdf_analytic", refine={"theta_i": 3, "theta_o": 3, "phi_d": 3, "c": 3},
         budgets=[256, 4096], ref=1 << 18),
    dict(name="lambert-sphere-slices.brdf_mc", preset="lambert-sphere-slices.toml", table="brdf_mc",
         refine={"theta_o": 5}, levels=5, hold={"theta_i": [40.0], "phi_d": [0.0, 180.0], "c": [0.9]},
         budgets=[256, 4096, 65536], ref=1 << 18),
    dict(name="micrograin-brdf-conductor.brdf_beta1", preset="micrograin-brdf-conductor.toml",
         table="brdf_beta1", refine={"theta_i": 3, "theta_o": 3, "phi_d": 3}, hold={"tau0": [0.5]},
         budgets=[2], ref=1 << 14),
    dict(metric="abs", name="micrograin-brdf-diffuse.albedo", preset="micrograin-brdf-diffuse.toml", table="albedo",
         refine={"theta_i": 5, "tau0": 3}, levels=5, budgets=[256, 4096, 65536], ref=1 << 18),
    dict(name="micrograin-gaf.g1_dist", preset="micrograin-gaf.toml", table="g1_dist",
         refine={"theta_i": 5, "h": 5, "tau0": 5}, levels=5),
    dict(name="micrograin-slice86.diffuse_correlated", preset="micrograin-slice86.toml",
         table="diffuse_correlated", refine={"theta_o": 5, "phi_d": 3}, levels=5, budgets=[256, 4096, 65536],
         ref=1 << 18),
]

# (kernel precision, stored type) per line; float kernels with float16 storage
# would add nothing that the two lines do not show.
COMBOS = [("double", "float32"), ("float", "float32"), ("double", "float16")]


# ---------------------------------------------------------------- processes

def run(cmd, env=None):
    """Run cmd; return (rc, stdout, stderr, wall seconds, user+sys seconds)."""
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, text=True)
    out, err = p.communicate()
    wall = time.perf_counter() - t0
    # communicate() reaped the child; its rusage is in RUSAGE_CHILDREN, read as a
    # difference around the call by the caller when it matters (see Clock).
    return p.returncode, out, err, wall


class Clock:
    """user+sys CPU seconds of finished children (this script's subprocesses)."""

    def __init__(self):
        self.t = self.now()

    @staticmethod
    def now():
        r = resource.getrusage(resource.RUSAGE_CHILDREN)
        return r.ru_utime + r.ru_stime

    def lap(self):
        t = self.now()
        d, self.t = t - self.t, t
        return d


def fail(msg):
    print(f"tradeoffs: error: {msg}", file=sys.stderr)
    sys.exit(2)


# ---------------------------------------------------------------- specs

def toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {v!r} as TOML")


def load_case(case, presets):
    """Model, quantity, merged parameters and the preset's axes of the case's table."""
    path = os.path.join(presets, case["preset"])
    with open(path, "rb") as f:
        spec = tomllib.load(f)
    tables = {t["name"]: t for t in spec.get("tables", [])}
    if case["table"] not in tables:
        fail(f"{path}: no table '{case['table']}'")
    t = tables[case["table"]]
    params = dict(spec.get("parameters", {}))
    params.update(t.get("parameters", {}))
    axes = t.get("axes", spec.get("axes", []))
    names = [a["name"] for a in axes]
    refine, hold = case.get("refine", {}), case.get("hold", {})
    for n in names:
        if (n in refine) == (n in hold):
            fail(f"case {case['name']}: axis '{n}' must be in exactly one of refine/hold")
    for n in list(refine) + list(hold):
        if n not in names:
            fail(f"case {case['name']}: preset table has no axis '{n}' (axes: {', '.join(names)})")
    return dict(model=spec["model"], quantity=t["quantity"], params=params, axes=axes,
                preset_integration=spec.get("integration", {}))


def level_axes(info, case, level):
    """The case's axes at a refinement level: list of dicts (name, range or values, spacing)."""
    out = []
    for a in info["axes"]:
        n = a["name"]
        if n in case.get("hold", {}):
            vals = case["hold"][n]
            if len(vals) > 1:
                out.append(dict(name=n, spacing="explicit", values=list(vals)))
            continue
        c0 = case["refine"][n]
        count = 1 + (c0 - 1) * 2 ** level
        if a.get("spacing") == "explicit":
            lo, hi = min(a["values"]), max(a["values"])
            out.append(dict(name=n, range=[float(lo), float(hi)], count=count))
        else:
            ax = dict(name=n, range=[float(x) for x in a["range"]], count=count)
            # The spacing and every key that parameterises it (pivot, ...):
            # a spacing without its parameters may be refused or differ.
            for k, v in a.items():
                if k not in ("name", "range", "count", "values"):
                    ax[k] = v
            out.append(ax)
    return out


def fixed_params(info, case):
    """Parameters for generate and eval: the preset's, plus held axes with one value."""
    p = dict(info["params"])
    for n, vals in case.get("hold", {}).items():
        if len(vals) == 1:
            p[n] = vals[0]
    return p


def spec_text(info, case, table, axes, method, samples, stored):
    lines = [f"# written by scripts/tradeoffs.py from tables/{case['preset']}",
             f"model = {toml_value(info['model'])}", "", "[parameters]"]
    for k, v in fixed_params(info, case).items():
        lines.append(f"{k} = {toml_value(v)}")
    lines += ["", "[[tables]]", f"name = {toml_value(table)}", f"quantity = {toml_value(info['quantity'])}"]
    for a in axes:
        lines += ["", "[[tables.axes]]"]
        for k, v in a.items():
            lines.append(f"{k} = {toml_value(v)}")
    lines += ["", "[integration]", f"method = {toml_value(method)}", "seed = 1"]
    if method in SAMPLED:
        lines.append(f"samples = {samples}")
    lines += ["", "[output]", f"type = {toml_value(stored)}", ""]
    return "\n".join(lines)


# ---------------------------------------------------------------- probes & reference

def make_probes(info, case, count, seed):
    """Random points of the case's domain: uniform over each refined axis' range
    (user units), a random held value on held axes with several values."""
    rng = random.Random(seed)
    axes = level_axes(info, case, 0)
    cols = [a["name"] for a in axes]
    rows = []
    for _ in range(count):
        row = []
        for a in axes:
            if "values" in a:
                row.append(rng.choice(a["values"]))
            else:
                lo, hi = a["range"]
                row.append(lo + (hi - lo) * rng.random())
        rows.append(row)
    return cols, rows


def write_csv(path, cols, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for r in rows:
            w.writerow([repr(float(x)) for x in r])


def read_value_column(text, what):
    rows = list(csv.reader(text.splitlines()))
    if not rows or "value" not in rows[0]:
        raise RuntimeError(f"{what}: no 'value' column in its output")
    head = rows[0]
    iv = head.index("value")
    ie = head.index("stderr") if "stderr" in head else None
    vals = np.array([float(r[iv]) for r in rows[1:]])
    errs = np.array([float(r[ie]) for r in rows[1:]]) if ie is not None else np.zeros(len(vals))
    return vals, errs


def kv_args(params):
    return [f"{k}={v}" for k, v in params.items()]


def method_choices(bt):
    rc, out, err, _ = run([bt, "generate", "--help"])
    m = re.search(r"--method TEXT:\{([^}]*)\}", out)
    if not m:
        fail("cannot read the --method choices from `brdftab generate --help`")
    return [x for x in m.group(1).split(",") if x and x != "auto"]


def detect_methods(bt, info, case, probe_csv, choices, env):
    """Methods the quantity accepts, tried with `brdftab eval` at the probes."""
    accepted, notes, degenerate = [], {}, []
    params = fixed_params(info, case)
    for m in choices:
        cmd = [bt, "eval", info["model"], info["quantity"], *kv_args(params), "--points", probe_csv,
               "--method", m]
        if m in SAMPLED:
            cmd += ["--samples", "64"]
        rc, out, err, _ = run(cmd, env)
        if rc != 0:
            notes[m] = err.strip().splitlines()[-1] if err.strip() else f"exit {rc}"
            continue
        vals, errs = read_value_column(out, f"eval --method {m}")
        if m in SAMPLED and np.all(errs == 0) and np.any(vals != 0):
            degenerate.append(m)
            continue
        accepted.append(m)
    if degenerate and any(m not in SAMPLED for m in accepted):
        for m in degenerate:
            notes[m] = "zero standard error on non-zero values: computed deterministically, left out"
    elif degenerate:
        # No deterministic method, yet the sampled estimate has no variance (an
        # integrand that is constant per sample): measured at one budget only.
        for m in degenerate:
            notes[m] = "zero standard error on non-zero values: measured at the smallest budget only"
        accepted += degenerate
    return accepted, notes, degenerate


def reference_method(methods):
    for m in ("closed-form", "quadrature", "rqmc", "mc"):
        if m in methods:
            return m
    return methods[0]


# ---------------------------------------------------------------- measuring

def error_stats(values, ref, floor):
    d = np.abs(values - ref)
    rel = d / np.maximum(np.abs(ref), floor)
    peak = floor / REL_FLOOR
    return dict(max_abs=float(d.max()), rms_abs=float(np.sqrt(np.mean(d * d))),
                max_rel=float(rel.max()), rms_rel=float(np.sqrt(np.mean(rel * rel))),
                max_norm=float(d.max() / peak), rms_norm=float(np.sqrt(np.mean(d * d)) / peak))


def one_run(bt, work, info, case, level, method, samples, precision, stored, probe_csv, ref, floor, env,
            clock):
    axes = level_axes(info, case, level)
    spec = os.path.join(work, "run.toml")
    h5 = os.path.join(work, "run.h5")
    with open(spec, "w") as f:
        f.write(spec_text(info, case, "t", axes, method, samples, stored))
    if os.path.exists(h5):
        os.remove(h5)
    clock.lap()
    rc, out, err, wall = run([bt, "generate", spec, "-o", h5, "-q", "--precision", precision], env)
    cpu = clock.lap()
    if rc != 0:
        raise RuntimeError(f"generate failed (exit {rc}): {err.strip()}")
    with h5py.File(h5, "r") as f:
        g = f["t"]
        engine = float(g.attrs["elapsed_seconds"])
        cells = int(np.prod(g["value"].shape))
        total_samples = int(g.attrs.get("total_samples", cells))
        device = str(g.attrs.get("device", ""))
    row = dict(level=level, nodes="x".join(str(a.get("count", len(a.get("values", [])))) for a in axes),
               cells=cells, method=method, samples=samples if method in SAMPLED else 0,
               total_samples=total_samples, precision=precision, type=stored,
               engine_s=engine, wall_s=wall, cpu_s=cpu, device=device)
    for interp, flag in (("linear", []), ("cubic", ["--cubic"])):
        rc, out, err, _ = run([bt, "query", h5, "--table", "t", "--points", probe_csv, *flag], env)
        if rc != 0:
            raise RuntimeError(f"query failed (exit {rc}): {err.strip()}")
        vals, _ = read_value_column(out, "query")
        for k, v in error_stats(vals, ref, floor).items():
            row[f"{interp}_{k}"] = v
    return row


def run_case(bt, case, args, env, clock, log):
    info = load_case(case, args.presets)
    quick = args.quick
    levels = args.levels or (3 if quick else case.get("levels", 4))
    budgets = case.get("quick_budgets" if quick else "budgets", case.get("budgets", [4096]))
    if quick and "quick_budgets" not in case:
        budgets = budgets[:2]
    if args.budgets:
        budgets = args.budgets
    npoints = args.probes or (150 if quick else case.get("probes", 300))
    run_cap = 5.0 if quick else 15.0     # predicted engine seconds of one run
    if args.run_cap:
        run_cap = args.run_cap
    case_cap = 15.0 if quick else case.get("cap", 30.0)  # wall seconds of generate per case
    if args.case_cap:
        case_cap = args.case_cap
    ref_cap = 4.0 if quick else 10.0     # seconds for a sampled reference (sizes its budget)
    combos = args.combos or COMBOS
    work = tempfile.mkdtemp(prefix="tradeoffs-")
    result = dict(name=case["name"], metric=case.get("metric", "rel"), preset=case["preset"], table=case["table"], model=info["model"],
                  quantity=info["quantity"], refine=case.get("refine", {}), hold=case.get("hold", {}),
                  levels=levels, budgets=budgets, probes=npoints, runs=[], skipped=[],
                  load_at_start=os.getloadavg()[0])
    try:
        cols, rows = make_probes(info, case, npoints, seed=2026)
        probe_csv = os.path.join(work, "probes.csv")
        write_csv(probe_csv, cols, rows)
        methods, notes, degenerate = detect_methods(bt, info, case, probe_csv, args.method_choices, env)
        if not methods:
            raise RuntimeError("no method accepted: " + json.dumps(notes))
        result["methods_accepted"], result["methods_left_out"] = list(methods), notes
        rm = reference_method(methods)
        if args.methods:
            methods = [m for m in methods if m in args.methods]
        result["methods"] = methods
        ref_params = dict(fixed_params(info, case))
        if rm == "quadrature":
            ref_params.update(case.get("ref_quadrature", {}))
        cmd = [bt, "eval", info["model"], info["quantity"], *kv_args(ref_params),
               "--points", probe_csv, "--method", rm]
        if rm in SAMPLED:
            # Size the reference's budget to about ref_cap seconds from a 1024-sample
            # pilot (after detect_methods the kernel is in the PoCL cache).
            rc, _, err, pilot = run(cmd + ["--samples", "1024"], env)
            if rc != 0:
                raise RuntimeError(f"reference pilot failed: {err.strip()}")
            per = max(pilot - 0.15, 0.02) / 1024
            samples = int(min(case.get("ref", 1 << 18), max(4096, ref_cap / per)))
            samples = 1 << int(math.log2(samples))
            cmd += ["--samples", str(samples)]
        clock.lap()
        rc, out, err, wall = run(cmd, env)
        rcpu = clock.lap()
        if rc != 0:
            raise RuntimeError(f"reference eval failed: {err.strip()}")
        ref, ref_err = read_value_column(out, "reference eval")
        floor = REL_FLOOR * float(np.max(np.abs(ref)))
        result["reference"] = dict(method=rm, samples=int(cmd[-1]) if rm in SAMPLED else 0, wall_s=wall,
                                   cpu_s=rcpu, max_abs=float(np.max(np.abs(ref))), rel_floor=floor,
                                   max_stderr=float(ref_err.max()),
                                   max_rel_stderr=float(np.max(ref_err / np.maximum(np.abs(ref), floor))))
        log(f"  methods {methods}; reference {rm} ({result['reference']['samples']} samples) "
            f"{wall:.1f}s, max rel stderr {result['reference']['max_rel_stderr']:.2e}")
        # Warm-up: one small untimed run per method and precision (kernel build or
        # PoCL cache load), so the timed runs measure the steady state.
        for m in methods:
            for prec in sorted({c[0] for c in combos}):
                one_run(bt, work, info, case, 0, m, budgets[0], prec, "float32", probe_csv, ref, floor, env,
                        clock)
        spent = 0.0
        fits = {}  # (method, precision) -> list of (work units, engine seconds)
        plan = []
        for level in range(levels):
            cells = 1
            for a in level_axes(info, case, level):
                cells *= a.get("count", len(a.get("values", [])))
            for j, b in enumerate(budgets):
                for m in methods:
                    if (m not in SAMPLED or m in degenerate) and b != budgets[0]:
                        continue
                    for k, (prec, stored) in enumerate(combos):
                        plan.append((j, level, k, m, b, prec, stored))
        # Every level at the smallest budget first, then at the next budget, and
        # so on: the time caps then cut large budgets on coarse grids (where the
        # interpolation error hides the integration error) before fine grids.
        plan.sort(key=lambda p: p[:3])
        for _, level, _, m, b, prec, stored in plan:
            axes = level_axes(info, case, level)
            cells = 1
            for a in axes:
                cells *= a.get("count", len(a.get("values", [])))
            units = cells * (b if m in SAMPLED else 1)
            seen = fits.get((m, prec), [])
            pred = 0.0
            if seen:
                base = min(t for _, t in seen)
                big_u, big_t = max(seen)
                pred = base + max(big_t - base, 0.0) * units / big_u
            setting = dict(level=level, cells=cells, method=m, samples=b if m in SAMPLED else 0,
                           precision=prec, type=stored, predicted_s=pred)
            if pred > run_cap:
                result["skipped"].append(dict(setting, why=f"predicted {pred:.1f}s > {run_cap:.0f}s per run"))
                continue
            if spent + pred > case_cap:
                result["skipped"].append(dict(setting, why=f"case time cap {case_cap:.0f}s"))
                continue
            row = one_run(bt, work, info, case, level, m, b, prec, stored, probe_csv, ref, floor, env, clock)
            spent += row["wall_s"]
            fits.setdefault((m, prec), []).append((units, row["engine_s"]))
            row["case"] = case["name"]
            result["runs"].append(row)
            log(f"  L{level} {row['nodes']:>12} {m:>11} {row['samples']:>6} {prec:>6} {stored:>7}: "
                f"engine {row['engine_s']:.3f}s wall {row['wall_s']:.2f}s cpu {row['cpu_s']:.2f}s "
                f"max abs {row['linear_max_abs']:.2e} norm {row['linear_max_norm']:.2e} rel {row['linear_max_rel']:.2e}")
    finally:
        if args.keep:
            log(f"  kept {work}")
        else:
            shutil.rmtree(work, ignore_errors=True)
    return result


# ---------------------------------------------------------------- analysis

def pareto(points):
    """Points (time, error, ...) not beaten on both: sorted by time, error falling."""
    out, best = [], math.inf
    for p in sorted(points, key=lambda p: (p[0], p[1])):
        if p[1] < best:
            out.append(p)
            best = p[1]
    return out


def metric_key(res):
    return "linear_max_abs" if res.get("metric") == "abs" else "linear_max_norm"


def reach(runs, target, metric="linear_max_rel", time_key="engine_s"):
    """Time and cells to reach `target` on the case's measured Pareto front,
    interpolated log-log between the two front points that bracket it; None
    when no run reached it."""
    pts = [(r[time_key], r[metric], r) for r in runs if r[time_key] > 0 and r[metric] > 0]
    front = pareto(pts)
    for i, (t, e, r) in enumerate(front):
        if e <= target:
            if i == 0:
                return dict(seconds=t, cells=r["cells"], run=r, how="cheapest run already below")
            t0, e0, r0 = front[i - 1]
            w = (math.log(target) - math.log(e0)) / (math.log(e) - math.log(e0))
            return dict(seconds=math.exp(math.log(t0) + w * (math.log(t) - math.log(t0))),
                        cells=math.exp(math.log(r0["cells"]) + w * (math.log(r["cells"]) - math.log(r0["cells"]))),
                        run=r, how="interpolated")
    return None


def line_key(r):
    return (r["method"], r["precision"], r["type"])


# ---------------------------------------------------------------- PNG drawing

def load_font():
    """The 5x8 font of host/cli/plot_png.cpp: char -> 8x5 bool array."""
    font = {}
    path = os.path.join(REPO, "host", "cli", "plot_png.cpp")
    try:
        text = open(path).read()
    except OSError:
        return font
    for m in re.finditer(r"\{'(\\.|.)', \"([.#]{40})\"\}", text):
        c = m.group(1)[-1] if m.group(1).startswith("\\") else m.group(1)
        font[c] = np.array([ch == "#" for ch in m.group(2)]).reshape(8, 5)
    return font


FONT = None


class Canvas:
    def __init__(self, w, h):
        self.w, self.h = w, h
        self.px = np.full((h, w, 3), 255, np.uint8)

    def dot(self, x, y, c, r=0):
        x, y = int(round(x)), int(round(y))
        self.px[max(y - r, 0):max(min(y + r + 1, self.h), 0), max(x - r, 0):max(min(x + r + 1, self.w), 0)] = c

    def line(self, x0, y0, x1, y1, c, width=1, dash=0):
        n = int(max(abs(x1 - x0), abs(y1 - y0)) * 2) + 1
        r = width // 2
        for i in range(n + 1):
            s = i / n
            if dash and int(s * n / 2 / dash) % 2:
                continue
            self.dot(x0 + s * (x1 - x0), y0 + s * (y1 - y0), c, r)

    def rect(self, x0, y0, x1, y1, c, fill=False):
        if fill:
            self.px[max(y0, 0):y1, max(x0, 0):x1] = c
        else:
            for a, b, e, f in ((x0, y0, x1, y0), (x0, y1, x1, y1), (x0, y0, x0, y1), (x1, y0, x1, y1)):
                self.line(a, b, e, f, c)

    def text(self, x, y, s, c=(0, 0, 0), scale=1):
        s = s.replace(";", ",")  # the font has no ';'
        for k, ch in enumerate(s):
            g = FONT.get(ch, FONT.get("?"))
            if g is None:
                continue
            for (gy, gx) in zip(*np.nonzero(g)):
                px, py = x + (k * 6 + gx) * scale, y + gy * scale
                self.px[py:py + scale, px:px + scale] = c
        return len(s) * 6 * scale

    def text_up(self, x, y, s, c=(0, 0, 0)):
        tmp = Canvas(len(s) * 6, 9)
        tmp.text(0, 0, s, c)
        rot = np.rot90(tmp.px)  # counter-clockwise: reads bottom to top
        h, w = rot.shape[:2]
        region = self.px[y - h:y, x:x + w]
        mask = np.any(rot != 255, axis=2)
        region[mask] = rot[mask]

    def write(self, path):
        raw = b"".join(b"\x00" + self.px[y].tobytes() for y in range(self.h))

        def chunk(kind, data):
            return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
        png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", self.w, self.h, 8, 2, 0, 0, 0))
               + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
        tmp = path + ".tmp"
        with open(tmp, "wb") as f:
            f.write(png)
        os.replace(tmp, path)


COLOURS = {"closed-form": (31, 119, 180), "quadrature": (44, 160, 44), "rqmc": (214, 39, 40),
           "mc": (148, 103, 189)}
EXTRA_COLOURS = [(255, 127, 14), (140, 86, 75), (227, 119, 194), (23, 190, 207)]


def tick_label(v):
    """2e-3 style label of a 2 or 5 x 10^d tick."""
    d = math.floor(math.log10(v) + 1e-9)
    return f"{round(v / 10 ** d)}e{d}"


def decade_range(vals):
    lo, hi = min(vals), max(vals)
    a, b = math.floor(math.log10(lo)), math.ceil(math.log10(hi))
    if a == b:
        b += 1
    return a, b


def plot_case(res, path, machine_line):
    global FONT
    if FONT is None:
        FONT = load_font()
    mk = metric_key(res)
    runs = [r for r in res["runs"] if r["engine_s"] > 0 and r[mk] > 0]
    if not runs:
        return False
    W, H = 1100, 660
    L, T, R, B = 90, 70, 760, 590   # plot area
    cv = Canvas(W, H)
    xs = [r["engine_s"] for r in runs]
    ys = [r[mk] for r in runs]
    noise = 3 * res["reference"]["max_stderr"]
    if mk == "linear_max_norm":
        noise /= res["reference"]["max_abs"]
    if noise < min(ys) / 100:
        noise = 0  # far below every error: not drawn (it would squash the curves)
    if noise > 0:
        ys = ys + [noise]
    xa, xb = decade_range(xs)
    ya, yb = decade_range(ys)

    def X(v):
        return L + (math.log10(v) - xa) / (xb - xa) * (R - L)

    def Y(v):
        return B - (math.log10(v) - ya) / (yb - ya) * (B - T)
    grey, dark = (225, 225, 225), (90, 90, 90)
    for d in range(xa, xb + 1):
        for k in range(1, 10):
            v = k * 10.0 ** d
            if d == xb and k > 1:
                break
            x = X(v)
            if k == 1:
                cv.line(x, T, x, B, grey)
                cv.line(x, B, x, B + 6, dark)
                lab = f"1e{d}"
                cv.text(int(x - len(lab) * 3), B + 10, lab, dark)
            else:
                cv.line(x, B, x, B + 3, dark)
                if xb - xa <= 2 and k in (2, 5):
                    lab = tick_label(v)
                    cv.text(int(x - len(lab) * 3), B + 10, lab, (140, 140, 140))
    for d in range(ya, yb + 1):
        for k in range(1, 10):
            v = k * 10.0 ** d
            if d == yb and k > 1:
                break
            y = Y(v)
            if k == 1:
                cv.line(L, y, R, y, grey)
                cv.line(L - 6, y, L, y, dark)
                lab = f"1e{d}"
                cv.text(L - 10 - len(lab) * 6, int(y - 4), lab, dark)
            else:
                cv.line(L - 3, y, L, y, dark)
                if yb - ya <= 2 and k in (2, 5):
                    lab = tick_label(v)
                    cv.text(L - 10 - len(lab) * 6, int(y - 4), lab, (140, 140, 140))
    cv.rect(L, T, R, B, (0, 0, 0))
    cv.text(L, 14, res["name"], scale=2)
    cv.text(L, 40, res.get("subtitle", ""), dark)
    xl = "time: generate's engine seconds per table (log)"
    cv.text(int((L + R) / 2 - len(xl) * 3), B + 30, xl)
    yl = ("max absolute error between nodes (log)" if mk == "linear_max_abs"
          else "max abs. error between nodes / max |value| (log)")
    cv.text_up(22, int((T + B) / 2 + len(yl) * 3), yl)
    if res.get("run_date"):
        machine_line += f"; this case re-run {res['run_date']}, load {res.get('load_at_start', 0):.1f}"
    cv.text(10, H - 16, machine_line, dark)
    if noise > 0:
        y = Y(noise)
        cv.line(L, y, R, y, (150, 150, 150), 1, dash=4)
        cv.text(L + 6, int(y - 11), "3x reference noise", (120, 120, 120))
    lines = {}
    for r in runs:
        lines.setdefault(line_key(r), []).append(r)
    extra = iter(EXTRA_COLOURS)
    ly = T + 8
    cv.text(R + 20, ly, "method, kernel, stored", scale=1)
    ly += 16
    for key in sorted(lines, key=lambda k: (list(COLOURS).index(k[0]) if k[0] in COLOURS else 9, k[1] != "double",
                                             k[2])):
        m, prec, stored = key
        col = COLOURS.get(m) or next(extra, (0, 0, 0))
        if prec == "float":  # lighter shade for float kernels
            col = tuple(int(c + (255 - c) * 0.45) for c in col)
        pts = [(r["engine_s"], r[mk]) for r in lines[key]]
        front = pareto(pts)
        dash = 3 if stored == "float16" else 0
        for (t0, e0), (t1, e1) in zip(front, front[1:]):
            cv.line(X(t0), Y(e0), X(t1), Y(e1), col, 2, dash)
        for t, e in pts:
            x, y = X(t), Y(e)
            if stored == "float16":
                cv.rect(int(x - 3), int(y - 3), int(x + 3), int(y + 3), col)
            else:
                cv.dot(x, y, col, 2)
        cv.line(R + 20, ly + 4, R + 50, ly + 4, col, 2, dash)
        cv.dot(R + 35, ly + 4, col, 2) if stored != "float16" else cv.rect(R + 32, ly + 1, R + 38, ly + 7, col)
        cv.text(R + 58, ly, f"{m}, {prec}, {stored}")
        ly += 16
    ly += 10
    for s in ("Lines: each setting's best time for", "its error (Pareto front); dots:",
              "every run (node counts x budgets).", "Dashed, hollow: float16 storage;",
              "light: float kernels."):
        cv.text(R + 20, ly, s, dark)
        ly += 13
    cv.write(path)
    return True


# ---------------------------------------------------------------- reports

CSV_KEYS = ["case", "level", "nodes", "cells", "method", "samples", "total_samples", "precision", "type",
            "engine_s", "wall_s", "cpu_s", "linear_max_rel", "linear_rms_rel", "linear_max_abs",
            "linear_rms_abs", "linear_max_norm", "linear_rms_norm", "cubic_max_rel", "cubic_rms_rel", "cubic_max_abs", "cubic_rms_abs", "cubic_max_norm", "cubic_rms_norm"]


def fmt_setting(r):
    s = f"{r['nodes']} ({r['cells']} cells), {r['method']}"
    if r["method"] in SAMPLED:
        s += f" {r['samples']}"
    return s + f", {r['precision']}, {r['type']}"


def summary_md(results):
    out = ["| preset.table | error | E | T (s) | N (cells) | first measured run with error <= E: setting, "
           "engine s, CPU s, error |", "|---|---|---|--:|--:|---|"]
    for res in results:
        mk0 = metric_key(res)
        for mk, e in [(mk0, e) for e in TARGETS] + [(mk0.replace("_max_", "_rms_"), e) for e in TARGETS]:
            what = ("max" if "_max_" in mk else "RMS") + (" abs" if mk.endswith("_abs") else " abs / max value")
            hit = reach(res["runs"], e, metric=mk)
            if hit is None:
                best = min(res["runs"], key=lambda r: r[mk], default=None)
                b = (f"best measured {best[mk]:.2e} ({fmt_setting(best)}, {best['engine_s']:.2f} s)"
                     if best else "no runs")
                out.append(f"| {res['name']} | {what} | {e:.0e} | not reached | — | {b} |")
                continue
            r = hit["run"]
            t = f"{hit['seconds']:.3g}" if hit["how"] == "interpolated" else f"≤ {hit['seconds']:.3g}"
            n = f"{hit['cells']:.0f}" if hit["how"] == "interpolated" else f"≤ {hit['cells']}"
            out.append(f"| {res['name']} | {what} | {e:.0e} | {t} | {n} | {fmt_setting(r)}, {r['engine_s']:.3g} s, "
                       f"{r['cpu_s']:.3g} s, {r[mk]:.2e} |")
    return "\n".join(out) + "\n"


def compact_md(results):
    """One row per case: T seconds / N cells to reach each E, for the max and the RMS
    error; "—" where no measured run reached it."""
    head = " | ".join([f"max {e:.0e}" for e in TARGETS] + [f"RMS {e:.0e}" for e in TARGETS])
    out = [f"| preset.table | error | best max (engine s) | {head} |",
           "|---|---|---|" + "---|" * (2 * len(TARGETS))]
    for res in results:
        mk = metric_key(res)
        cells = []
        for key in (mk, mk.replace("_max_", "_rms_")):
            for e in TARGETS:
                hit = reach(res["runs"], e, metric=key)
                if hit is None:
                    cells.append("—")
                elif hit["how"] == "interpolated":
                    cells.append(f"{hit['seconds']:.2g} s / {hit['cells']:.0f}")
                else:
                    cells.append(f"≤ {hit['seconds']:.2g} s / ≤ {hit['cells']}")
        best = min(res["runs"], key=lambda r: r[mk])
        what = "abs" if mk.endswith("_abs") else "abs / max"
        out.append(f"| {res['name']} | {what} | {best[mk]:.1e} ({best['engine_s']:.2g}) | " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def cases_md(doc):
    """One row per case: what was measured, the reference and what the caps cut."""
    out = ["| preset.table | nodes per level | held | methods measured (not measured: refused by the quantity, or deterministic) | budgets | probes, "
           "reference (samples), its max stderr | runs (skipped) | load |", "|---|---|---|---|---|---|---|---|"]
    for res in doc["cases"]:
        if not res.get("runs"):
            out.append(f"| {res['name']} | — | — | failed: {res.get('error', '')[:120]} | | | | |")
            continue
        nodes = sorted({(r["level"], r["nodes"]) for r in res["runs"]})
        hold = ", ".join(f"{k} = {', '.join(str(x) for x in v)}" for k, v in res.get("hold", {}).items())
        left = ", ".join(m for m in res.get("methods_left_out", {}) if m not in res["methods"])
        ref = res["reference"]
        rs = f" ({ref['samples']})" if ref["samples"] else ""
        out.append(f"| {res['name']} | {' / '.join(n for _, n in nodes)} | {hold or '—'} | "
                   f"{', '.join(res['methods'])}{f' ({left})' if left else ''} | "
                   f"{', '.join(str(b) for b in res['budgets']) if any(m in SAMPLED for m in res['methods']) else '—'} | "
                   f"{res['probes']}, {ref['method']}{rs}, {ref['max_stderr']:.1e} | "
                   f"{len(res['runs'])} ({len(res['skipped'])}) | {res.get('load_at_start', 0):.1f} |")
    return "\n".join(out) + "\n"


def machine_info(bt):
    cpu = ""
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    rc, out, _, _ = run([bt, "--version"])
    return dict(cpu=cpu, cores=os.cpu_count(), system=platform.platform(), brdftab=out.strip())


# ---------------------------------------------------------------- main

def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="three small cases, 3 levels, 2 budgets (under a minute on 2 cores)")
    ap.add_argument("--out", help="output folder (default docs/figures/tradeoffs; --quick: build/tradeoffs-quick)")
    ap.add_argument("--brdftab", default=os.path.join(REPO, "build", "brdftab"), help="the brdftab binary")
    ap.add_argument("--presets", default=os.path.join(REPO, "tables"), help="folder of the preset specs")
    ap.add_argument("--case", action="append", default=[], help="run only this case (repeatable; prefix match)")
    ap.add_argument("--list", action="store_true", help="list the cases and exit")
    ap.add_argument("--keep", action="store_true", help="keep the working folders (specs, tables, probes)")
    ap.add_argument("--levels", type=int, help="refinement levels (default 4; --quick: 3)")
    ap.add_argument("--budgets", type=lambda s: [int(x) for x in s.split(",")],  # argparse: exit 2 if not ints
                    help="samples per cell for mc/rqmc, comma-separated (default: per case)")
    ap.add_argument("--probes", type=int, help="random probe points per case (default 300; --quick: 150)")
    ap.add_argument("--run-cap", type=float,
                    help="skip a run predicted to take more engine seconds than this (default 15; --quick: 5); "
                    "the prediction extrapolates earlier runs, whose times include the first kernel builds")
    ap.add_argument("--case-cap", type=float,
                    help="wall seconds of generate per case before further runs are skipped (default: the "
                    "case's cap, 30 s unless it sets one; --quick: 15 s); a busy machine needs more")
    ap.add_argument("--methods", type=lambda s: s.split(","), help="measure only these methods (comma-separated)")
    ap.add_argument("--combos", type=lambda s: [tuple(x.split(":")) for x in s.split(",")],
                    help="PRECISION:TYPE pairs, comma-separated (default double:float32,float:float32,"
                    "double:float16)")
    ap.add_argument("--merge", action="store_true",
                    help="replace (or add) the cases run now in an existing OUT/results.json, keep the others")
    ap.add_argument("--plot-only", action="store_true", help="redraw figures and summary from OUT/results.json")
    args = ap.parse_args()

    if args.levels is not None and not 1 <= args.levels <= 8:
        fail(f"--levels {args.levels}: must be in [1, 8]")
    if args.probes is not None and not 2 <= args.probes <= 100000:
        fail(f"--probes {args.probes}: must be in [2, 100000]")
    if args.run_cap is not None and not 1 <= args.run_cap <= 86400:
        fail(f"--run-cap {args.run_cap:g}: must be in [1, 86400] seconds")
    if args.case_cap is not None and not 1 <= args.case_cap <= 86400:
        fail(f"--case-cap {args.case_cap:g}: must be in [1, 86400] seconds")
    if args.budgets is not None and not all(1 <= b <= 4294967295 for b in args.budgets):
        fail(f"--budgets {args.budgets}: each must be in [1, 4294967295]")
    for c in args.combos or []:
        if len(c) != 2 or c[0] not in ("double", "float") or c[1] not in ("float16", "float32", "float64"):
            fail(f"--combos: '{':'.join(c)}' is not PRECISION:TYPE with PRECISION double|float and "
                 "TYPE float16|float32|float64")
    if args.list:
        for c in CASES:
            print(f"{c['name']:45} {'quick' if c.get('quick') else ''}")
        return 0
    out = args.out or (os.path.join(REPO, "build", "tradeoffs-quick") if args.quick
                       else os.path.join(REPO, "docs", "figures", "tradeoffs"))

    if args.plot_only:
        with open(os.path.join(out, "results.json")) as f:
            doc = json.load(f)
        finish(doc, out)
        return 0

    bt = os.path.abspath(args.brdftab)
    if not os.access(bt, os.X_OK):
        fail(f"--brdftab {bt}: not an executable (build it: cmake --build build --target brdftab)")
    env = dict(os.environ)
    env.setdefault("POCL_CACHE_DIR", os.path.join(os.path.dirname(bt), "pocl-cache"))
    cases = [c for c in CASES if (c.get("quick") or not args.quick)]
    if args.case:
        cases = [c for c in CASES if any(c["name"].startswith(p) for p in args.case)]
        if not cases:
            fail("--case matches no case (see --list)")
    args.method_choices = method_choices(bt)
    os.makedirs(out, exist_ok=True)

    def log(s):
        print(s, flush=True)
    clock = Clock()
    cpu0 = Clock.now()
    t0 = time.time()
    load0 = os.getloadavg()
    doc = dict(brdftab_tradeoffs=1, quick=args.quick,
               command=" ".join(["/usr/bin/python3", "scripts/tradeoffs.py"] + sys.argv[1:]),
               date=datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
               machine=machine_info(bt), method_choices=args.method_choices, load_before=list(load0),
               cases=[])
    for c in cases:
        log(f"{c['name']}")
        try:
            res = run_case(bt, c, args, env, clock, log)
        except RuntimeError as e:
            log(f"  failed: {e}")
            res = dict(name=c["name"], preset=c["preset"], table=c["table"], error=str(e), runs=[], skipped=[])
        doc["cases"].append(res)
    doc["load_after"] = list(os.getloadavg())
    doc["wall_s"] = time.time() - t0
    doc["children_cpu_s"] = Clock.now() - cpu0
    devs = {r["device"] for res in doc["cases"] for r in res["runs"]}
    doc["machine"]["device"] = ", ".join(sorted(devs))
    old_path = os.path.join(out, "results.json")
    if args.merge and os.path.exists(old_path):
        with open(old_path) as f:
            old = json.load(f)
        new = {c["name"]: c for c in doc["cases"]}
        update = {k: doc[k] for k in ("command", "date", "load_before", "load_after", "wall_s", "children_cpu_s")}
        update["cases"] = list(new)
        for c in doc["cases"]:
            c["run_date"] = doc["date"]
        old["cases"] = [new.pop(c["name"], c) for c in old["cases"]] + list(new.values())
        old.setdefault("updates", []).append(update)
        doc = old
    with open(os.path.join(out, "results.json"), "w") as f:
        json.dump(rounded(doc), f, separators=(",", ":"))
    with open(os.path.join(out, "results.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=CSV_KEYS, extrasaction="ignore")
        w.writeheader()
        for res in doc["cases"]:
            for r in res["runs"]:
                w.writerow(r)
    finish(doc, out)
    log(f"campaign: {time.time() - t0:.0f} s wall, {Clock.now() - cpu0:.0f} s user+sys of brdftab, "
        f"load average {load0[0]:.2f} before, {os.getloadavg()[0]:.2f} after; wrote {out}")
    return 0


def rounded(x):
    """The document with floats to 5 significant digits (the measurements' noise is
    far larger), to keep results.json small."""
    if isinstance(x, float):
        return float(f"{x:.5g}")
    if isinstance(x, dict):
        return {k: rounded(v) for k, v in x.items()}
    if isinstance(x, list):
        return [rounded(v) for v in x]
    return x


def finish(doc, out):
    m = doc["machine"]
    machine_line = (f"{doc['date']}, {m.get('cpu', '')} x{m.get('cores', '')}, load {doc['load_before'][0]:.1f}"
                    f"-{doc.get('load_after', [0])[0]:.1f}; {m.get('brdftab', '')}")
    for res in doc["cases"]:
        if not res.get("runs"):
            continue
        axes = ", ".join(f"{k} {v}" for k, v in res.get("refine", {}).items())
        hold = ", ".join(f"{k}={v}" for k, v in res.get("hold", {}).items())
        res["subtitle"] = (f"refined axes (coarsest nodes): {axes}" + (f"; held: {hold}" if hold else "")
                           + f"; {res['probes']} probes vs {res['reference']['method']} reference")
        plot_case(res, os.path.join(out, res["name"] + ".png"), machine_line)
    with open(os.path.join(out, "summary.md"), "w") as f:
        done = [r for r in doc["cases"] if r.get("runs")]
        f.write(compact_md(done) + "\n" + cases_md(doc) + "\n" + summary_md(done))


if __name__ == "__main__":
    sys.exit(main())

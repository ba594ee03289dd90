#!/usr/bin/env python3
"""hostile_probe.py BRDFTAB SOURCE_DIR [--tables N] [--specs N] [--seed S]

A replay of hostile input through the CLI, counting how each run ended:

* damaged tables: copies of three table files written by BRDFTAB (two
  closed-form tables, an RQMC albedo pair, one 3-D table), damaged by random
  bit flips anywhere, random bytes in the global heap (the string
  attributes), zeroed blocks, or the heap damage of
  tests/cli_reliability_tests.sh; each read by one of info --values, query,
  query --cubic, export --exr, plot and validate;
* mutated specs: tests/data/*.toml with a line deleted, duplicated or
  swapped, a number replaced by an extreme one, a character replaced or the
  text cut short, each run through `generate` on the host backend.

Prints the counts: exit 0, exit 2, exit 1, crashes (killed by a signal),
runs the read guard stopped (a crash or hang of the HDF5 library in its
child) and runs cut by the probe's own time limit.  A crash is the failure
the probe looks for; the exit status is 1 when there is one.
"""
import argparse
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile

GUARD = re.compile(r"did not finish within|crashed the HDF5 library|failed inside the HDF5 library")
EXTREMES = ["-1", "0", "1e308", "-1e308", "nan", "inf", "1e-320", "9223372036854775807",
            "18446744073709551616", "4294967296", "16777217", "1e6", "0.5", "\"x\"", "[]"]


def run(cmd, cwd, env, limit):
    try:
        p = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True,
                           errors="replace", timeout=limit)
    except subprocess.TimeoutExpired:
        return "time limit", ""
    rc = p.returncode
    if rc < 0 or rc >= 128:
        return "crash", p.stderr
    if rc == 2 and GUARD.search(p.stderr):
        return "guard stop", p.stderr
    return f"exit {rc}", p.stderr


def damage(data, r):
    b = bytearray(data)
    kind = r.randrange(4)
    heap = b.find(b"GCOL")
    if kind == 0:
        for _ in range(r.randint(1, 8)):
            k = r.randrange(len(b))
            b[k] ^= 1 << r.randrange(8)
    elif kind == 1 and heap >= 0:
        size = int.from_bytes(b[heap + 8:heap + 16], "little")
        for _ in range(r.randint(1, 6)):
            b[heap + 16 + r.randrange(max(1, min(size, len(b) - heap) - 16))] = r.randrange(256)
    elif kind == 2:
        at, n = r.randrange(len(b)), r.randint(16, 512)
        b[at:at + n] = bytes(len(b[at:at + n]))
    else:  # an object's index and another object's length, in the heap
        if heap < 0:
            return bytes(b)
        at, objects = heap + 16, []
        while at + 16 <= len(b):
            index = int.from_bytes(b[at:at + 2], "little")
            length = int.from_bytes(b[at + 8:at + 16], "little")
            if index == 0 or length > len(b):
                break
            objects.append(at)
            at += 16 + (length + 7) // 8 * 8
        if len(objects) >= 2:
            first, second = sorted(r.sample(objects, 2))
            b[first:first + 2] = (0xFF).to_bytes(2, "little")
            b[second + 8 + r.randrange(2, 6)] = r.randrange(1, 256)
    return bytes(b)


def mutate(text, r):
    lines = text.split("\n")
    kind = r.randrange(6)
    k = r.randrange(len(lines))
    if kind == 0:
        del lines[k]
    elif kind == 1:
        lines.insert(k, lines[r.randrange(len(lines))])
    elif kind == 2:
        j = r.randrange(len(lines))
        lines[k], lines[j] = lines[j], lines[k]
    elif kind == 3:
        numbers = [(i, m) for i, l in enumerate(lines) for m in re.finditer(r"-?\d+(\.\d+)?", l)]
        if numbers:
            i, m = r.choice(numbers)
            lines[i] = lines[i][:m.start()] + r.choice(EXTREMES) + lines[i][m.end():]
    elif kind == 4 and lines[k]:
        c = r.randrange(len(lines[k]))
        lines[k] = lines[k][:c] + r.choice("[]{}=\"'#,.0-x\\\n\t") + lines[k][c + 1:]
    else:
        return text[:r.randrange(len(text) + 1)]
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("brdftab")
    ap.add_argument("source_dir")
    ap.add_argument("--tables", type=int, default=600)
    ap.add_argument("--specs", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    bt = os.path.realpath(a.brdftab)
    data = os.path.join(os.path.realpath(a.source_dir), "tests", "data")
    r = random.Random(a.seed)
    work = tempfile.mkdtemp(prefix="hostile-probe-")
    env = dict(os.environ, BRDFTAB_READ_TIMEOUT="10", POCL_CACHE_DIR=os.path.join(work, "pocl"))
    crashes = []
    try:
        # The undamaged files: name -> (tables, a query of each table).
        sources = {"rough_dielectric_brdf_btdf.toml": "two.h5",
                   "rough_dielectric_albedo.toml": "alb.h5",
                   "rough_dielectric_brdf.toml": "t.h5"}
        bases = {}
        for spec, out in sources.items():
            subprocess.run([bt, "generate", os.path.join(data, spec), "-q", "-o", out],
                           cwd=work, env=env, check=True, capture_output=True)
            bases[out] = open(os.path.join(work, out), "rb").read()
        coords = {"two.h5": (["brdf", "btdf"], ["theta_i=30", "theta_o=140"]),
                  "alb.h5": (["albedo_r", "albedo_t"], ["theta_i=30", "alpha=0.5"]),
                  "t.h5": (["brdf"], ["theta_i=10", "theta_o=20", "phi_d=30"])}
        counts = {}
        for n in range(a.tables):
            base = r.choice(sorted(bases))
            open(os.path.join(work, "d.h5"), "wb").write(damage(bases[base], r))
            tables, point = coords[base]
            t = r.choice(tables)
            axis, value = point[0].split("=")
            cmd = r.choice([
                ["info", "--values", "d.h5"],
                ["query", "d.h5", "--table", t] + point,
                ["query", "d.h5", "--table", t, "--cubic"] + point,
                ["export", "d.h5", "--table", t, "--exr", "d.exr"] + (
                    ["--slice", point[2]] if len(point) > 2 else []),
                ["plot", "d.h5", "--table", t, "--slice", point[0], "-o", "d.png"],
                ["validate", "d.h5", "--table", t, "--points", "2", "--samples", "64",
                 "--device", "host", "-q"]])
            outcome, err = run([bt] + cmd, work, env, 120)
            counts[outcome] = counts.get(outcome, 0) + 1
            if outcome == "crash":
                keep = os.path.join(work, f"crash-table-{n}.h5")
                shutil.copy(os.path.join(work, "d.h5"), keep)
                crashes.append(" ".join(cmd) + f" (file kept as {keep})")
        print(f"damaged tables: {a.tables} runs: " +
              ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
        specs = sorted(f for f in os.listdir(data) if f.endswith(".toml"))
        counts = {}
        for n in range(a.specs):
            spec = r.choice(specs)
            text = mutate(open(os.path.join(data, spec)).read(), r)
            open(os.path.join(work, "m.toml"), "w").write(text)
            cmd = ["generate", "m.toml", "-q", "-o", "m.h5", "--device", "host",
                   "--samples", "16", "--max-memory", "256M"]
            outcome, err = run([bt] + cmd, work, env, 20)
            counts[outcome] = counts.get(outcome, 0) + 1
            if outcome == "crash":
                keep = os.path.join(work, f"crash-spec-{n}.toml")
                shutil.copy(os.path.join(work, "m.toml"), keep)
                crashes.append(f"generate {keep}")
        print(f"mutated specs: {a.specs} runs: " +
              ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
    finally:
        if not crashes:
            shutil.rmtree(work, ignore_errors=True)
    for c in crashes:
        print("crash:", c)
    return 1 if crashes else 0


if __name__ == "__main__":
    sys.exit(main())

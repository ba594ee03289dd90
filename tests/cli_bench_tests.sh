#!/usr/bin/env bash
# cli_bench_tests.sh BRDFTAB SOURCE_DIR — `brdftab bench --quick --json`
# runs every case on the three backends and emits the keys that
# docs/benchmarks.md documents; filters and bad filters.  No timing is
# checked (rates only have to be positive numbers).
source "$(dirname "$0")/cli_lib.sh"
cli_setup "$1" "$2"

# --seconds 0.02: the smallest useful workload, so the test stays short.
expect_exit 0 "bench --quick --json" -- "$BT" bench --quick --json --seconds 0.02
cp out.txt all.json
if "$PY" - all.json <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
for key in ("brdftab_bench", "machine", "settings", "cases", "targets"):
    assert key in r, key
for key in ("device", "precision", "host_threads", "peak_fma_gflops"):
    assert key in r["machine"], key
assert r["machine"]["peak_fma_gflops"] > 0
import os
if os.path.exists("/proc/loadavg"):  # Linux: the load around the run is reported
    for key in ("load_average_start", "load_average_end"):
        assert r["machine"][key] >= 0, key
want = {("rough-dielectric", "bsdf"), ("rough-dielectric", "albedo_r"),
        ("rough-dielectric", "albedo_t"), ("oren-nayar", "brdf"),
        ("interfaced-lambertian", "body"), ("interfaced-lambertian", "vcavity"),
        ("hfunction", "H"), ("lambert-sphere", "brdf_mc"), ("micrograin", "g_dist"),
        ("micrograin", "brdf")}
got = {(c["model"], c["quantity"]) for c in r["cases"]}
assert want <= got, want - got
for c in r["cases"]:
    for key in ("method", "unit", "cells", "samples_per_cell", "evaluations",
                "device_over_host", "device_over_threads", "threads_over_host"):
        assert key in c, (c["model"], c["quantity"], key)
    for b in ("device", "host", "host_threads"):
        assert c[b]["rate"] > 0 and c[b]["seconds"] > 0, (c["model"], c["quantity"], b)
        assert c[b]["backend"], b
    assert c["unit"] == ("cells/s" if c["method"] == "quadrature" else "evals/s")
    assert abs(c["device_over_host"] - c["device"]["rate"] / c["host"]["rate"]) < 1e-9 * c["device_over_host"]
# Instruction sets: the host CPU's against /proc/cpuinfo's flags; efficiency
# is device / serial host over cores x double lanes.
isa = r["machine"]["instruction_sets"]
for key in ("host_cpu", "host_build", "device", "device_target", "device_compute_units",
            "device_double_lanes", "device_preferred_double_lanes", "ideal_lanes"):
    assert key in isa, key
if os.path.exists("/proc/cpuinfo"):
    flags = set()
    for line in open("/proc/cpuinfo"):
        if line.startswith("flags"):
            flags = set(line.split(":", 1)[1].split())
            break
    if flags:
        want_isa = ("AVX-512" if "avx512f" in flags else "AVX2" if "avx2" in flags
                    else "AVX" if "avx" in flags else "SSE2")
        assert isa["host_cpu"] == want_isa, (isa["host_cpu"], want_isa)
assert isa["ideal_lanes"] == isa["device_compute_units"] * isa["device_double_lanes"]
assert isa["device_double_lanes"] in (1, 2, 4, 8, 16), isa
for c in r["cases"]:
    assert abs(c["efficiency"] - c["device_over_host"] / isa["ideal_lanes"]) <= 1e-9 * c["efficiency"]
bsdf = [c for c in r["cases"] if c["quantity"] == "bsdf"][0]
assert bsdf["device_gflops_estimate"] > 0 and bsdf["flops_per_evaluation_estimate"] > 0
for key in ("device_over_host_min", "device_over_host_median", "device_over_threads_min",
            "bsdf_evals_per_second", "met"):
    assert key in r["targets"], key
PY
then ok; else bad "bench --json lacks documented keys"; cat all.json; fi

# Filters select cases; the text report names the targets.
expect_exit 0 "bench --model --quantity" -- "$BT" bench --quick --seconds 0.02 --no-peak \
    --model micrograin --quantity g_dist
expect_grep "^micrograin +g_dist" out.txt "filtered report lists the case"
if grep -q "^rough-dielectric" out.txt; then bad "filter let other models through"; else ok; fi
expect_grep "issue #12 targets" out.txt "report states the targets"
if [ -r /proc/loadavg ]; then expect_grep "^load average" out.txt "report states the load"; fi
expect_exit 2 "bench with a filter matching nothing" -- "$BT" bench --quick --model no-such-model
expect_grep "no case matches" err.txt "bad filter is named"
cli_summary

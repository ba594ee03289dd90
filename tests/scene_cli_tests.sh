#!/usr/bin/env bash
# End-to-end tests of `brdftab scene`: dry run, a generated file and its
# manifest checked field by field, table values against `brdftab eval` of the
# mapped model, bad input, and a small mutation fuzz of the scene parsers.
# Usage: scene_cli_tests.sh BRDFTAB SOURCE_DIR
source "$(dirname "$0")/cli_lib.sh"
cli_setup "$1" "$2"
SCENES="$DATA/scenes"

# --- dry run: the plan, nothing written
expect_exit 0 "dry run" -- "$BT" scene "$SCENES/pbrt_v4.pbrt" --dry-run
expect_grep "dry run: nothing computed or written" out.txt "dry run says so"
expect_grep "t1 interfaced-lambertian bsdf .*lacquer-red, lacquer-blue" out.txt "shared table listed"
if ls ./*.h5 ./*.json >/dev/null 2>&1; then bad "dry run wrote files"; else ok; fi

# --- a glass from pbrt-v4: closed-form BSDF table, manifest, values = eval
cat > glass.pbrt <<'SCENE'
MakeNamedMaterial "glass" "string type" "dielectric" "float roughness" 0.09 "float eta" 1.5
MakeNamedMaterial "smooth" "string type" "dielectric"
NamedMaterial "glass"
Shape "sphere"
NamedMaterial "smooth"
Shape "sphere"
SCENE
expect_exit 0 "glass scene" -- "$BT" scene glass.pbrt --for bsdf -o glass.h5 -q
expect_grep "wrote glass.h5 \(1 tables\) and glass.json" out.txt "summary line"
"$PY" - <<'PY' >py.txt 2>&1 && ok || { bad "manifest fields"; cat py.txt; }
import json, math
m = json.load(open("glass.json"))
mats = {x["name"]: x for x in m["materials"]}
g = mats["glass"]
assert g["status"] == "tabulated", g
assert g["type"] == "dielectric" and g["model"] == "rough-dielectric", g
assert abs(g["parameters"]["alpha"] - math.sqrt(0.09)) < 1e-15, g   # pbrt-v4: alpha = sqrt(roughness)
assert g["parameters"]["eta"] == 1.5
assert g["parameters"]["distribution"] == "ggx"
assert g["parameters"]["shadowing"] == "height-correlated"
assert g["table"] == "t0_bsdf" and g["factored"] == {}, g
s = mats["smooth"]
assert s["status"] == "no-table-needed" and s["table"] is None, s
assert m["table_sets"][0]["materials"] == ["glass"]
PY
# Values at nodes (2-degree theta steps, 5-degree phi_d steps): the table
# stores float32, so they agree with eval to float rounding.
for point in "theta_i=30 theta_o=40 phi_d=180" "theta_i=60 theta_o=150 phi_d=175" \
             "theta_i=0 theta_o=88 phi_d=0" "theta_i=86 theta_o=120 phi_d=90"; do
  # shellcheck disable=SC2086
  q=$("$BT" query glass.h5 --table t0_bsdf $point --json)
  # shellcheck disable=SC2086
  e=$("$BT" eval rough-dielectric bsdf $point alpha=0.3 eta=1.5 distribution=ggx \
        shadowing=height-correlated --json)
  "$PY" -c "
import json,sys
q=json.loads(sys.argv[1])['value']; e=json.loads(sys.argv[2])['value']
sys.exit(0 if abs(q-e) <= 1e-6*abs(e) + 1e-12 else 1)" "$q" "$e" && ok || bad "bsdf at $point: $q vs $e"
done

# --- Mitsuba 0.6 roughdiffuse: Oren-Nayar albedo with rho recombined
expect_exit 0 "clay albedo" -- "$BT" scene "$SCENES/mitsuba06.xml" --for albedo --accuracy 3e-3 \
  -o clay.h5 --manifest clay-manifest.json -q
"$PY" - <<'PY' >py.txt 2>&1 && ok || { bad "clay manifest"; cat py.txt; }
import json, math
m = json.load(open("clay-manifest.json"))
c = {x["name"]: x for x in m["materials"]}["clay"]
assert c["model"] == "oren-nayar" and c["table"] == "t0_albedo", c
assert abs(c["parameters"]["sigma"] - 0.3 / math.sqrt(2) * 180 / math.pi) < 1e-12, c
assert c["factored"] == {"rho": [0.6, 0.5, 0.4]}, c
PY
sigma=$("$PY" -c "import math; print(repr(0.3/math.sqrt(2)*180/math.pi))")
mu=$("$PY" -c "print(repr(0.02 + 0.98*15/31))")   # a node of the mu_i axis
q=$("$BT" query clay.h5 --table t0_albedo mu_i="$mu" rho=0.6 --json)
e=$("$BT" eval oren-nayar albedo mu_i="$mu" sigma="$sigma" rho=0.6 --samples 262144 --json)
"$PY" -c "
import json,sys,math
q=json.loads(sys.argv[1])['value']; e=json.loads(sys.argv[2])
bound = 4*math.sqrt(e['stderr']**2 + (3e-3*q)**2)
sys.exit(0 if abs(q-e['value']) <= bound else 1)" "$q" "$e" && ok || bad "clay albedo: $q vs $e"

# --- bad input: exit 2, a message naming the place, nothing overwritten
echo "keep me" > keep.h5
printf 'Material "dielectric" "float roughness" 0.1 "float eta" 0\nShape "sphere"\n' > eta0.pbrt
expect_exit 2 "eta = 0" -- "$BT" scene eta0.pbrt -o keep.h5
expect_grep "anonymous-1.*eta = 0 is outside" err.txt "eta = 0 names the material"
grep -q "keep me" keep.h5 && ok || bad "failed run overwrote its output"
printf 'WorldBegin\nMaterial "dielectric" [ 1 2\n' > broken.pbrt
expect_exit 2 "pbrt syntax" -- "$BT" scene broken.pbrt --dry-run
expect_grep "broken.pbrt:2:" err.txt "syntax error names file:line"
expect_exit 2 "missing file" -- "$BT" scene nowhere.xml --dry-run
expect_grep "nowhere.xml" err.txt "missing file named"
expect_exit 2 "bad --for" -- "$BT" scene glass.pbrt --for everything --dry-run
expect_grep "bsdf, albedo, all" err.txt "--for lists its choices"
expect_exit 2 "bad --accuracy" -- "$BT" scene glass.pbrt --accuracy 0 --dry-run
expect_grep "\(0, 1\)" err.txt "--accuracy range"

# --- fuzz: mutated scene files end with exit 0 or 2, never a crash
"$PY" - "$SCENES" <<'PY'
import os, random, sys
random.seed(7)
src = sys.argv[1]
os.makedirs("fuzz", exist_ok=True)
n = 0
for name in sorted(os.listdir(src)):
    data = open(os.path.join(src, name), "rb").read()
    ext = os.path.splitext(name)[1]
    for k in range(40):
        b = bytearray(data)
        for _ in range(random.randint(1, 6)):
            op = random.random()
            i = random.randrange(len(b))
            if op < 0.4:
                b[i] = random.choice(b'"[]<>/$#=\n 0123456789.-eE' + bytes([random.randrange(256)]))
            elif op < 0.7:
                del b[i:i + random.randint(1, 20)]
            else:
                j = random.randrange(len(b))
                b[i:i] = b[j:j + random.randint(1, 40)]
        open(os.path.join("fuzz", "m%03d%s" % (n, ext)), "wb").write(b)
        n += 1
PY
crashes=0
for f in fuzz/*; do
  "$BT" scene "$f" --dry-run >/dev/null 2>fuzz-err.txt
  rc=$?
  if [ $rc -ne 0 ] && [ $rc -ne 2 ]; then crashes=$((crashes + 1)); echo "exit $rc on $f"; cat fuzz-err.txt; fi
done
[ $crashes -eq 0 ] && ok || bad "$crashes mutated scenes crashed"

cli_summary

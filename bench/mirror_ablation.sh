#!/usr/bin/env bash
# What limits the mirror filter (issue #34): panel-exciter with its sensor noise off, then with one part of the
# plant that the gray-box model [M1]-[M3] does not have taken away at a time (the panel mode, the amplifier's
# clipping, the DA/AD filters), all of them, friction and Le(x, i) too, and the same plants sampled at 12 kHz
# (oversample 4: the same RK4 step). Each plant: the identification record of bench/cancel.sh, design mirror
# (open loop), and the cut at equal output level at 80 and 160 Hz, programs 0.1 and 0.2 (evaluate --level-sweep).
# Usage: bash bench/mirror_ablation.sh DIR [PLANT...]   (default: every plant below; one line per plant on stdout)
# PANELBASS_BIN overrides the binary.
set -euo pipefail
if [ $# -lt 1 ]; then sed -n '2,8p' "$0" >&2; exit 2; fi
dir=$(realpath -m "$1"); shift
if [ -n "${PANELBASS_BIN:-}" ]; then PANELBASS_BIN=$(realpath "$PANELBASS_BIN"); fi
cd "$(dirname "$0")/.."
bin=$(realpath "${PANELBASS_BIN:-build/bin/panelbass}")
mkdir -p "$dir"; cd "$dir"
"$bin" plant show panel-exciter > panel-exciter.json
python3 - <<'PY'
import json
base = json.load(open("panel-exciter.json"))
base["sensor"]["noise_rms_V"] = 0.0
def variant(name, change):
    p = json.loads(json.dumps(base)); change(p); p["name"] = name
    json.dump(p, open(name + ".json", "w"), indent=1)
def no_mode(p): p["panel_modes"] = []
def no_clip(p): p["nonlinear"]["clipping"]["enabled"] = False
def no_filters(p):
    p["converters"]["da_filter"]["order"] = 0; p["converters"]["ad_filter"]["order"] = 0
def structure(p): no_mode(p); no_clip(p); no_filters(p)
def structure_no_fric_le(p):
    structure(p); p["nonlinear"]["friction"]["enabled"] = False; p["nonlinear"]["inductance"]["enabled"] = False
def at_12k(change):
    def c(p): change(p); p["fs"] = 12000; p["oversample"] = 4
    return c
variant("noise-off", lambda p: None)
variant("no-panel-mode", no_mode)
variant("no-clipping", no_clip)
variant("no-converter-filters", no_filters)
variant("model-structure", structure)
variant("model-structure-no-friction-no-Le", structure_no_fric_le)
variant("noise-off-12k", at_12k(lambda p: None))
variant("model-structure-12k", at_12k(structure))
PY
plants=${*:-noise-off no-panel-mode no-clipping no-converter-filters model-structure model-structure-no-friction-no-Le noise-off-12k model-structure-12k}
for p in $plants; do
  fs=$(python3 -c "import json; print(json.load(open('$p.json'))['fs'])")
  n=$(python3 -c "print(int(30000 * $fs / 3000))")  # 10 s of record
  "$bin" simulate --plant "$p.json" --signal multisine --f-min 10 --f-max 300 --amplitude 0.5 --samples "$n" --seed 1 \
    --out "$p-ident.csv" > /dev/null 2>&1
  "$bin" design mirror --data "$p-ident.csv" --fs "$fs" --out "$p-mirror.json" > "$p-fit.json" 2> /dev/null
  "$bin" chain --fs "$fs" --bandpass 0,1200 --ff "$p-mirror.json" --out "$p-chain.json" > /dev/null
  "$bin" evaluate --plant "$p.json" --chain "$p-chain.json" --level-sweep --probes 80,160 --levels 0.1,0.2 --seed 1 \
    --out "$p-eval.json" > /dev/null 2> "$p-eval.log"
  python3 - "$p" <<'PY'
import json, sys
p = sys.argv[1]
r = json.load(open(f"{p}-eval.json"))["level_sweep"]
fit = json.load(open(f"{p}-fit.json"))
cells = [f"{c['frequency_hz']:.0f} Hz @ {q['program_amplitude']}: {q['cut_db']:5.1f} dB ({q['chain']['thd_pct']:.3f} / {q['plant']['thd_pct']:.3f} %)"
         for c in r["curves"] for q in c["points"]]
print(f"{p:34} fit residual {fit['mechanical_fit_pct']:.4f} / {fit['electrical_fit_pct']:.4f} % | " + " | ".join(cells))
PY
done

#!/usr/bin/env bash
# Issue #34's figures: distortion cancelled at equal output level, as a listener hears it, end to end with the CLI.
#   1. panel-exciter driven by a 10-300 Hz multisine at peak 0.5 (30 000 samples, sensor noise on): drive, coil
#      current and displacement                                                  simulate
#   2. the mirror filter fitted to that record alone (gray-box exciter model), and the same filter with an
#      observer that adapts its stiffness on line from the sensor (an extended Kalman filter)  design mirror [--adapt]
#   3. their chains (low-pass 1200 Hz, mirror filter as the feedforward) → DIR/mirror-chain.json,
#      DIR/adaptive-chain.json                                                    chain
#   4. band-pass + LQ for comparison (OE model from noise, R = 1e-5, band 20-1200 Hz) → DIR/lq-chain.json
#   5. THD/H2/H3 against the sensor's fundamental at 40/80/160/320 Hz and two-tone IMD, each chain beside the
#      plant driven alone at the drive that gives the same fundamental, on panel-exciter (sensor noise on) and
#      on eight variants the design never saw: every nonlinear coefficient, the main resonance, and both, moved by
#      ±20 %
#                                                                                 evaluate --level-sweep --html
#   6. the best compensator's chain (the largest worst cut at 40/80/160 Hz over every plant; a point at the
#      noise floor counts as reached) copied to DIR/chain.json
# Usage: bash bench/cancel.sh DIR [SEED]   (the table on stdout; DIR keeps the models, chains, evaluations
# (JSON), the THD-versus-level pages (HTML) and the variants' plant files). Re-measure the chain on any plant:
#   panelbass evaluate --plant PLANT.json --chain DIR/chain.json --html thd.html
# or render a program through it: panelbass render --chain DIR/chain.json --plant PLANT.json --in x.wav --out y.wav
# PANELBASS_BIN overrides the binary; LEVELS the program amplitudes (default 0.1,0.2,0.3,0.4,0.5); CHAINS the chains
# evaluated (default "adaptive-chain mirror-chain lq-chain").
set -euo pipefail
if [ $# -lt 1 ]; then sed -n '2,23p' "$0" >&2; exit 2; fi
dir=$(realpath -m "$1")
seed=${2:-1}
if [ -n "${PANELBASS_BIN:-}" ]; then PANELBASS_BIN=$(realpath "$PANELBASS_BIN"); fi
cd "$(dirname "$0")/.."
bin=$(realpath "${PANELBASS_BIN:-build/bin/panelbass}")
levels=${LEVELS:-0.1,0.2,0.3,0.4,0.5}
mkdir -p "$dir"
cd "$dir"
stage() { echo "cancel: $(date +%H:%M:%S) $*" >&2; }

stage "identification record on panel-exciter (seed $seed)"
"$bin" simulate --plant panel-exciter --signal multisine --f-min 10 --f-max 300 --amplitude 0.5 --samples 30000 \
  --seed "$seed" --out ident.csv > /dev/null 2>&1
stage "mirror filter fitted to the record, and its adaptive form"
"$bin" design mirror --data ident.csv --fs 3000 --out mirror.json > mirror-fit.json
"$bin" chain --bandpass 0,1200 --ff mirror.json --out mirror-chain.json > /dev/null
"$bin" design mirror --data ident.csv --fs 3000 --adapt --out mirror-adaptive.json > mirror-adaptive-fit.json
"$bin" chain --bandpass 0,1200 --ff mirror-adaptive.json --out adaptive-chain.json > /dev/null
stage "band-pass + LQ (R = 1e-5) for comparison"
"$bin" simulate --plant panel-exciter --signal noise --samples 18000 --seed "$seed" --out noise.csv > /dev/null 2>&1
head -n 12001 noise.csv > est.csv
{ head -n 1 noise.csv; tail -n +12002 noise.csv; } > val.csv
"$bin" identify linear --data est.csv --val val.csv --fs 3000 --method oe --scan 1:16 --out lin.json > /dev/null 2>&1
"$bin" design lq --model lin.json --R 1e-5 --R0 20 --bandpass 20,1200 --out ff.json > /dev/null 2>&1
"$bin" chain --bandpass 20,1200 --ff ff.json --out lq-chain.json > /dev/null

stage "variants: nonlinear coefficients and main resonance at ±20 %"
"$bin" plant show panel-exciter > panel-exciter.json
python3 - <<'PY'
import json
base = json.load(open("panel-exciter.json"))
keys = {"stiffness": ["k1_per_mm", "k2_per_mm2"], "force_factor": ["b1_per_mm", "b2_per_mm2"],
        "inductance": ["l1_per_mm", "l2_per_mm2", "li2_per_A2"], "friction": ["coulomb_N"]}
# each change alone, then the four corners (both at once)
for nl, res in [(0.8, 1.0), (1.2, 1.0), (1.0, 0.8), (1.0, 1.2), (0.8, 0.8), (0.8, 1.2), (1.2, 0.8), (1.2, 1.2)]:
    p = json.loads(json.dumps(base))
    p["name"] = f"panel-exciter-nl{nl}-f{res}"
    for term, ks in keys.items():
        for k in ks:
            p["nonlinear"][term][k] *= nl
    p["mechanical"]["stiffness_N_per_m"] *= res * res  # the resonance moves with sqrt(K/m)
    json.dump(p, open(p["name"] + ".json", "w"), indent=2)
PY

plants="panel-exciter"
for nl in 0.8 1.2; do plants="$plants panel-exciter-nl$nl-f1.0"; done
for f in 0.8 1.2; do plants="$plants panel-exciter-nl1.0-f$f"; done
for nl in 0.8 1.2; do for f in 0.8 1.2; do plants="$plants panel-exciter-nl$nl-f$f"; done; done
chains=${CHAINS:-adaptive-chain mirror-chain lq-chain}
for chain in $chains; do
  for plant in $plants; do
    # band-pass + LQ is the comparison on the plant it was designed on
    if [ $chain = lq-chain ] && [ "$plant" != panel-exciter ]; then continue; fi
    stage "$chain on $plant"
    arg=$plant; [ -f "$plant.json" ] && [ "$plant" != panel-exciter ] && arg=$plant.json
    "$bin" evaluate --plant "$arg" --chain $chain.json --level-sweep --levels "$levels" --seed "$seed" \
      --html "$chain-$plant.html" --out "$chain-$plant.json" > /dev/null 2> "$chain-$plant.log"
  done
done

# The table: per chain and plant, the cut at equal output level at each probe (worst over the levels the chain
# reaches with its drive inside the limiter's knee; a level where the chain's THD is within 3 dB of the sensor
# noise floor counts as cut to the floor, "floor"), and the range of cuts over those levels.
CHAINS="$chains" python3 - $plants <<'PY'
import json, math, os, shutil, sys
plants = sys.argv[1:]
chains = os.environ["CHAINS"].split()
print(f"{'chain':15} {'plant':26} " + " ".join(f"{f'{f} Hz worst (range)':>24}" for f in (40, 80, 160, 320)) + "   IMD cut dB (range)")
score = {}
for chain in chains:
    for plant in plants:
        if chain == "lq-chain" and plant != "panel-exciter":
            continue
        r = json.load(open(f"{chain}-{plant}.json"))["level_sweep"]
        cells = []
        for c in r["curves"]:
            pts = [p for p in c["points"] if p["reachable"]]
            cuts = [p["cut_db"] for p in pts]
            worst = c["worst_cut_db"]
            w = "floor" if worst is None and pts else ("-" if worst is None else f"{worst:.1f}")
            rng = f"{min(cuts):.1f}..{max(cuts):.1f}" if cuts else "-"
            cells.append(f"{w:>8} ({rng:>13})")
            if c["frequency_hz"] in (40, 80, 160):
                s = math.inf if worst is None and pts else (-math.inf if worst is None else worst)
                score[chain] = min(score.get(chain, math.inf), s)
        imd = [p["cut_db"] for p in r["imd"] if p["reachable"]]
        irng = f"{min(imd):.1f}..{max(imd):.1f}" if imd else "-"
        print(f"{chain:15} {plant:26} " + " ".join(f"{x:>24}" for x in cells) + f"   {irng}")
best = max((c for c in chains if c != "lq-chain"), key=lambda c: score.get(c, -math.inf))
shutil.copyfile(f"{best}.json", "chain.json")
print(f"best compensator (worst cut at 40/80/160 Hz over every plant {score.get(best, float('nan')):.1f} dB): {best}.json -> chain.json")
PY
stage "done: $dir/chain.json is the best compensator's chain, the one the figures were measured with"

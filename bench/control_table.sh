#!/usr/bin/env bash
# The Control issue's evaluation table on the panel-exciter preset, end to end with the CLI:
#   1. full-drive uniform noise → linear model (OE, order scan)            identify linear
#   2. LQ feedforward, R = 1e-5, R0 = 20, band-pass 20-1200 Hz              design lq
#   3. the plant driven in its operating regime: the feedforward's output
#      for noise + stepped sines, RECORDS records of 22 500 samples at steady
#      drive peaks 0.35-0.85 (program peaks where the chain's gain is below 1;
#      default 24 = 540 000 samples: the harmonics
#      at small drives, 40 dB under the fundamental, need them) → NARX      simulate --signal control, identify narx
#   4. the NARX model's harmonics checked against a 100 s stepped-sine
#      recording at each probe's drive, level and phase (MODELS candidates:
#      the one that would cancel the most at its worst probe is kept)                          evaluate, simulate, harmonics
#   5. neural feedback controller trained through the loop                  design nn
#   6. chain files (feedback in model mode and in sensor mode) → table      chain, evaluate
# The probes run where band-pass + feedforward reach a steady drive peak of 0.6: below the amplifier's
# clipping (0.7) and the controller's soft limit (0.8), so that the feedback has headroom to correct; the
# table at the limiter's knee (0.8, the evaluate default) follows for comparison.
# Usage: [RECORDS=24] [MODELS=1] bash bench/control_table.sh [SEED] [SINE_SHARE]   (the table on stdout, each stage
# and the training's progress on stderr; about 15 min per model at 20 hidden nodes;
# at 40 the training alone took 100 min of CPU a seed)
# WEIGHTED=1 trains the NARX model with the records' harmonic weights (identify narx --weight-col w: every
# step's harmonics count alike). LQ_WEIGHT chooses the feedforward's weight (default "--R 1e-5", the thesis's;
# LQ_WEIGHT="--max-input 0.33": R searched so that the chain takes a third of full scale). NARX_FLAGS adds flags to identify narx (e.g. NARX_FLAGS="--friction-units 3,10":
# hidden nodes seeded as the exciter's Coulomb friction). PANELBASS_BIN overrides the binary; PLOTS=DIR keeps the evaluation figures of the model-mode chain at the
# 0.6 probe peak (the response, and the harmonics per probe); KEEP=DIR keeps every file the run made (models,
# controllers, chains, records, evaluations) for a closer look. HIDDEN sets the NARX plant model's hidden
# nodes (default 20). PLANT runs it on another transducer: a preset or a plant file (e.g. panel-exciter with
# all but one nonlinear term switched off).
set -euo pipefail
# paths the user gave, resolved where they were given
if [ -n "${PANELBASS_BIN:-}" ]; then PANELBASS_BIN=$(realpath "$PANELBASS_BIN"); fi
if [ -n "${PLOTS:-}" ]; then PLOTS=$(realpath -m "$PLOTS"); fi
if [ -n "${KEEP:-}" ]; then KEEP=$(realpath -m "$KEEP"); fi
plant=${PLANT:-panel-exciter}
if [ -f "$plant" ]; then plant=$(realpath "$plant"); fi
hidden=${HIDDEN:-20}
cd "$(dirname "$0")/.."
here=$(pwd)
bin=$(realpath "${PANELBASS_BIN:-build/bin/panelbass}")
seed=${1:-1}
share=${2:-0.75}
work=$(mktemp -d)
trap 'if [ -n "${KEEP:-}" ]; then mkdir -p "$KEEP" && cp -r "$work"/. "$KEEP"/; fi; rm -rf "$work"' EXIT
cd "$work"
field() { sed -n "s/^  \"$1\": \([-0-9.e+]*\).*/\1/p" | head -n 1; }
# stage WHAT: where the run is, on stderr (the table is stdout); the NARX training and the controller design,
# the long steps, show their own progress there too
stage() { echo "control_table: $(date +%H:%M:%S) $*" >&2; }

stage "seed $seed on $plant: linear model and LQ feedforward"
"$bin" simulate --plant "$plant" --signal noise --samples 18000 --seed "$seed" --out all.csv > /dev/null 2>&1
head -n 12001 all.csv > est.csv
{ head -n 1 all.csv; tail -n +12002 all.csv; } > val.csv
lin=$("$bin" identify linear --data est.csv --val val.csv --fs 3000 --method oe --scan 1:16 --out lin.json 2> /dev/null)
lq_weight=${LQ_WEIGHT:---R 1e-5}
lq=$("$bin" design lq --model lin.json $lq_weight --R0 20 --bandpass 20,1200 --out ff.json 2> /dev/null)
records=${RECORDS:-24}
stage "$records regime records and the probes' stepped-sine recordings"
source "$here/bench/regime_records.sh"
regime_records "$bin" reg_est.csv "$records" $((seed * 1000 + 10)) --plant "$plant" --ff ff.json
"$bin" simulate --plant "$plant" --signal control --ff ff.json --samples 10000 --seed $((seed * 1000 + 999)) --sine-peak 0.65 --out reg_val.csv > /dev/null 2>&1
# Each probe's steady drive behind band-pass + feedforward, and a 100 s stepped-sine recording there (the
# sensor noise on: a measurement, as a user would make one; 100 s puts its floor under the -50 dB harmonics).
"$bin" chain --bandpass 20,1200 --ff ff.json --out chain-ff.json > /dev/null
"$bin" evaluate --plant "$plant" --chain chain-ff.json --probe-peak 0.6 --out eval-ff.json > /dev/null 2>&1
probes=$(python3 -c 'import json; e = json.load(open("eval-ff.json"))
print(" ".join("%g:%.4f" % (p["frequency_hz"], p["drive_peak"]) for p in e["rows"][1]["probes"]))')
for probe in $probes; do
  "$bin" simulate --plant "$plant" --signal stepped --freqs "${probe%%:*}" --amplitude "${probe#*:}" --measure 300000 --seed "$seed" \
    --out "stepped-${probe%%:*}.csv" > /dev/null 2>&1
done
# harmonics_check MODEL: the recording's and the model's harmonics (level and phase) at every probe and how
# much of the recording's distortion a canceller designed on the model would remove there, from the complex
# difference of the harmonics (bench/harmonics_bound.py); the last line is the smallest, dB.
harmonics_check() {
  for probe in $probes; do
    "$bin" harmonics --data "stepped-${probe%%:*}.csv" --fs 3000 --freqs "${probe%%:*}" --amplitudes "${probe#*:}" \
      --measure 300000 --model "$1" 2> /dev/null
  done | python3 "$here/bench/harmonics_bound.py"
}
models=${MODELS:-1}
best=-1000
checks=""
kept=0
for m in $(seq 0 $((models - 1))); do
  stage "NARX candidate $m of $models (10/10/$hidden: the longest step, its progress follows)"
  out=$("$bin" identify narx --data reg_est.csv --val reg_val.csv --fs 3000 --na 10 --nb 10 --hidden "$hidden" --train pem,oem-d \
          ${WEIGHTED:+--weight-col w} ${NARX_FLAGS:-} \
          --max-iter 60 --seed $((seed + 100 * m)) --out "narx-$m.json")
  check=$(harmonics_check "narx-$m.json")
  score=$(echo "$check" | tail -n 1)
  checks+="- NARX candidate $m (seed $((seed + 100 * m)), J_val $(echo "$out" | field J_val_pct | awk '{printf "%.2f", $1}') %):"$'\n'"$(echo "$check" | head -n -1)"$'\n'
  if awk -v a="$score" -v b="$best" 'BEGIN { exit !(a > b) }'; then best=$score; nn=$out; cp "narx-$m.json" narx.json; kept=$m; fi
done
stage "neural feedback controller"
source "$here/bench/design_nn_flags.sh"
fb=$("$bin" design nn --plant narx.json --ff ff.json "${design_nn_flags[@]}" --hidden "$design_nn_hidden" \
       --iterations "$design_nn_iterations" --samples "$design_nn_samples" --sine-share "$share" --seed "$seed" --out fb.json)
echo "## Control on $plant (seed $seed)"
echo "- linear model: OE order $(echo "$lin" | field order), J_val $(echo "$lin" | field J_val_pct | awk '{printf "%.2f", $1}') %;" \
     "LQ ($lq_weight → R $(echo "$lq" | field R), R0 20, 20-1200 Hz): max in $(echo "$lq" | field max_input_worst | awk '{printf "%.3f", $1}') worst," \
     "$(echo "$lq" | field max_input_noise | awk '{printf "%.3f", $1}') noise"
echo -n "$checks"
echo "- NARX plant model kept: candidate $kept (regime data $((records * 22500)) samples, 10/10/$hidden): J_val $(echo "$nn" | field J_val_pct | awk '{printf "%.2f", $1}') %;" \
     "neural feedback: J_c on the plant model $(echo "$fb" | field jc_val_before_pct | awk '{printf "%.2f", $1}') %" \
     "→ $(echo "$fb" | field jc_val_after_pct | awk '{printf "%.2f", $1}') % (validation, sine share $share)"
table() {  # table EVAL.json TITLE
  echo
  echo "### $2 (THD in %, H2/H3 in dB)"
  /usr/bin/env python3 - "$1" <<'PY'
import json, math, sys
e = json.load(open(sys.argv[1]))
probes = [p["frequency_hz"] for p in e["rows"][0]["probes"]]
print("| configuration | ripple dB | J_c % | ripple dB / J_c % through the noisy sensor | " +
      " | ".join(f"THD {f:.0f} Hz (H2/H3)" for f in probes) + " | max drive | drive at rest |")
print("|---|---:|---:|---:|" + "---:|" * len(probes) + "---:|---:|")
for r in e["rows"]:
    cells = [f'{p["thd_pct"]:.2f} ({p["h2_db"]:.0f}/{p["h3_db"]:.0f})' for p in r["probes"]]
    print(f'| {r["name"]} | {r["ripple_db"]:.2f} | {r["jc_pct"]:.2f} | '
          f'{r["measured_ripple_db"]:.2f} / {r["measured_jc_pct"]:.1f} | ' + " | ".join(cells) +
          f' | {r["max_drive"]:.3f} | {r["rest_drive_peak"]:.4f} |')
if len(e["rows"]) == 3:
    change = [20 * math.log10(c["thd_pct"] / b["thd_pct"]) for b, c in zip(e["rows"][1]["probes"], e["rows"][2]["probes"])]
    print("THD change by the feedback: " + ", ".join(f"{f:.0f} Hz {d:+.1f} dB" for f, d in zip(probes, change)))
    predicted = [20 * math.log10(c["model_thd_pct"] / b["model_thd_pct"])
                 for b, c in zip(e["rows"][1]["probes"], e["rows"][2]["probes"])]
    print("the same on the design's NARX plant model (what the design expected): " +
          ", ".join(f"{f:.0f} Hz {d:+.1f} dB" for f, d in zip(probes, predicted)))
print(f'J_c noise floor of the sensor: {e["jc_noise_floor_pct"]:.1f} %; noise program amplitude {e["noise_amplitude"]:.3f}')
PY
}
stage "evaluation on the transducer"
for source in model sensor; do
  "$bin" chain --bandpass 20,1200 --ff ff.json --fb fb.json --source "$source" --out "chain-$source.json" > /dev/null
  plots=()
  if [ -n "${PLOTS:-}" ] && [ "$source" = model ]; then plots=(--plot "$PLOTS"); fi
  "$bin" evaluate --plant "$plant" --chain "chain-$source.json" --probe-peak 0.6 --out "eval-$source.json" "${plots[@]}" > /dev/null 2>&1
  table "eval-$source.json" "feedback in $source mode, probes at a drive peak of 0.6"
done
"$bin" evaluate --plant "$plant" --chain chain-model.json --out eval-knee.json > /dev/null 2>&1
table eval-knee.json "feedback in model mode, probes at the limiter's knee (0.8)"

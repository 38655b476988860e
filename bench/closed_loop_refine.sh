#!/usr/bin/env bash
# Identification for control on a kept control_table.sh run (KEEP=DIR): the plant model refined on records of
# the plant driven by a feedback controller designed on it, then a controller designed on the refined model.
#   1. design nn on DIR/narx.json with FIRST_FLAGS                      (the controller the records run)
#   2. RECORDS closed-loop records: `simulate --signal control --fb`, the control program at drive peaks
#      0.35-0.85 as control_table.sh's, the drive the controller's in model mode
#   3. identify narx --start-from DIR/narx.json on DIR/reg_est.csv + those records, --train oem-d,
#      REFINE_ITER iterations, early stopping on a closed-loop validation record
#   4. each probe's harmonics of the refined model against DIR's 100 s recordings (bench/harmonics_bound.py)
#   5. design nn on the refined model with each of SECOND_FLAGS..., chained in model mode, evaluated on the
#      transducer at the 0.6 drive-peak probes
# One table row a controller: THD change by the feedback at 40/80/160/320 Hz on the transducer and on the
# design's own plant model.
# Usage: [RECORDS=24] [REFINE_ITER=15] bash bench/closed_loop_refine.sh DIR SEED FIRST_FLAGS SECOND_FLAGS...
# Example: bash bench/closed_loop_refine.sh /tmp/k2 2 "--hidden 16 --iterations 300 --desired plant-fundamental" \
#            "--hidden 16 --iterations 300 --desired plant-fundamental --distortion-weighting"
# (a 40-node plant model on 1.08 M samples: about 35 min for the refinement on one core, 2-5 min a design).
# Unset design flags take control_table.sh's (bench/design_nn_flags.sh) with --seed SEED and sine share 0.75.
# KEEP_REFINED=DIR keeps the records, the refined model and the controllers. PANELBASS_BIN overrides the binary.
set -euo pipefail
if [ $# -lt 4 ]; then
  sed -n '2,22p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
keep=$(realpath "$1")
seed=$2
first=$3
shift 3
source "$(dirname "$0")/kept_run.sh"
require_kept closed_loop_refine "$keep" narx.json ff.json reg_est.csv eval-ff.json stepped-40.csv stepped-80.csv stepped-160.csv stepped-320.csv
if [ -n "${KEEP_REFINED:-}" ]; then KEEP_REFINED=$(realpath -m "$KEEP_REFINED"); fi
cd "$(dirname "$0")/.."
here=$(pwd)
source bench/design_nn_flags.sh
source bench/regime_records.sh
bin=$(realpath "${PANELBASS_BIN:-build/bin/panelbass}")
records=${RECORDS:-24}
refine_iter=${REFINE_ITER:-15}
work=$(mktemp -d)
trap 'if [ -n "${KEEP_REFINED:-}" ]; then mkdir -p "$KEEP_REFINED" && cp -r "$work"/. "$KEEP_REFINED"/; fi; rm -rf "$work"' EXIT
cd "$work"
stage() { echo "closed_loop_refine: $(date +%H:%M:%S) $*" >&2; }
# design PLANT FLAGS OUT: design nn with control_table.sh's settings where FLAGS leave them unset
design() {
  local defaults
  defaults=$(design_nn_defaults "$2" "$seed")
  # shellcheck disable=SC2086  # the flags are words
  "$bin" design nn --plant "$1" --ff "$keep/ff.json" "${design_nn_flags[@]}" $defaults $2 --out "$3" > /dev/null 2> design.err ||
    { echo "closed_loop_refine: design nn $2 failed:" >&2; tail -n 3 design.err >&2; exit 1; }
}
# row PLANT FB LABEL: the controller chained in model mode, evaluated on the transducer, one table row
row() {
  "$bin" chain --bandpass 20,1200 --ff "$keep/ff.json" --fb "$2" --source model --out chain.json > /dev/null
  "$bin" evaluate --plant panel-exciter --chain chain.json --probe-peak 0.6 --out eval.json > /dev/null 2>&1
  echo "| $1 | $3 |$(python3 "$here/bench/thd_change_cells.py" eval.json)"
}

stage "seed $seed: the controller the records run (design nn $first)"
design "$keep/narx.json" "$first" fb-first.json
stage "$records closed-loop records"
regime_records "$bin" loop_est.csv "$records" $((seed * 1000 + 500)) --ff "$keep/ff.json" --fb fb-first.json
"$bin" simulate --signal control --ff "$keep/ff.json" --fb fb-first.json --samples 10000 --seed $((seed * 1000 + 998)) \
  --sine-peak 0.65 --out loop_val.csv > /dev/null 2>&1
{ cat "$keep/reg_est.csv"; tail -n +2 loop_est.csv; } > refine_est.csv
stage "plant model refined on the open- and closed-loop records (identify narx --start-from: the longest step)"
"$bin" identify narx --data refine_est.csv --val loop_val.csv --fs 3000 --start-from "$keep/narx.json" --train oem-d \
  --max-iter "$refine_iter" --out narx-refined.json > refine.json
# j_closed_loop MODEL: the model's simulation J on the closed-loop validation record (50 samples set the state)
j_closed_loop() {
  "$bin" validate --model "$1" --data loop_val.csv --fs 3000 --init 50 2> /dev/null |
    python3 -c 'import json, sys; print("%.3f" % json.load(sys.stdin)["J_sim_pct"])'
}
probes=$(python3 -c 'import json, sys; e = json.load(open(sys.argv[1]))
print(" ".join("%g:%.4f" % (p["frequency_hz"], p["drive_peak"]) for p in e["rows"][1]["probes"]))' "$keep/eval-ff.json")
bound() {
  for probe in $probes; do
    "$bin" harmonics --data "$keep/stepped-${probe%%:*}.csv" --fs 3000 --freqs "${probe%%:*}" --amplitudes "${probe#*:}" \
      --measure 300000 --model "$1" 2> /dev/null
  done | python3 "$here/bench/harmonics_bound.py" | tail -n 1
}
echo "## Plant model refined for control (seed $seed; $records closed-loop records with design nn $first)"
echo "- closed-loop validation J: $(j_closed_loop "$keep/narx.json") % before, $(j_closed_loop narx-refined.json) % after" \
     "($refine_iter iterations of oem-d from the kept model)"
echo "- smallest cancellable harmonics at the probes (bench/harmonics_bound.py): $(bound "$keep/narx.json") dB before," \
     "$(bound narx-refined.json) dB after"
echo
echo "| plant model | design nn flags (control_table.sh's where unset) | THD change on the transducer, 40/80/160/320 Hz, dB | on the design's plant model | worst, transducer / model | max drive |"
echo "|---|---|---|---|---|---|"
row "kept" fb-first.json "$first"
n=0
for flags in "$@"; do
  stage "design nn $flags on the refined model"
  design narx-refined.json "$flags" "fb-$((++n)).json"
  row "refined" "fb-$n.json" "$flags"
done
stage done

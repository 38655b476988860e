#!/usr/bin/env bash
# A neural feedback design on the plant model, then the same controller tuned on the device (design nn
# --start-from … --tune-on …), each chained in model mode and evaluated on the transducer at the 0.6
# drive-peak probes. The device is the transducer itself with its sensor noise switched off, or with it on
# (NOISY=1; then pass --tune-playbacks R in the tuning flags, 16 in the Control issue's runs). One table row
# each: the THD change by the feedback at each probe on the transducer, the same on the design's plant model,
# the worst of each and the largest drive.
# Usage: bash bench/device_tuning.sh KEEP_DIR SEED "DESIGN FLAGS" ["TUNING FLAGS"]   (table on stdout)
# Example: NOISY=1 bash bench/device_tuning.sh /tmp/k2 12 "--hidden 16 --iterations 300 --desired
#          plant-fundamental --distortion-weighting --samples 144000" "--iterations 100 --tune-playbacks 16"
# KEEP_DIR holds a control_table.sh run's narx.json and ff.json (KEEP=DIR). Unset design flags take
# control_table.sh's (bench/design_nn_flags.sh). The tuning trains on from the design with --desired
# plant-fundamental --distortion-weighting, the design's seed, and the TUNING FLAGS (default --iterations 100).
# KEEP_TUNED=DIR keeps the controllers and evaluations; DESIGNED=FB.json takes that controller as the design on
# the model (one this bench kept, say) instead of designing it again. PANELBASS_BIN overrides the binary; PLANT
# the transducer (default panel-exciter). About 5-15 min a design; the tuning as long, 30-45 min with 16 playbacks.
set -euo pipefail
if [ $# -lt 3 ]; then
  sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
keep=$(realpath "$1")
seed=$2
design_flags=$3
tuning_flags=${4:---iterations 100}
source "$(dirname "$0")/kept_run.sh"
require_kept device_tuning "$keep" narx.json ff.json
plant=$(transducer_plant)
cd "$(dirname "$0")/.."
here=$(pwd)
source bench/design_nn_flags.sh
bin=$(realpath "${PANELBASS_BIN:-build/bin/panelbass}")
work=${KEEP_TUNED:-$(mktemp -d)}
mkdir -p "$work"
work=$(realpath "$work")
[ -n "${KEEP_TUNED:-}" ] || trap 'rm -rf "$work"' EXIT
cd "$work"

# The device: the transducer's own configuration, its sensor noise off unless NOISY=1.
"$bin" plant show "$plant" > device.json
if [ "${NOISY:-0}" != 1 ]; then
  python3 -c 'import json, sys; d = json.load(open("device.json")); d["sensor"]["noise_rms_V"] = 0.0
json.dump(d, open("device.json", "w"), indent=1)'
fi

# evaluate_row NAME FB: chains FB in model mode, evaluates it on the transducer, prints the row.
evaluate_row() {
  "$bin" chain --bandpass 20,1200 --ff "$keep/ff.json" --fb "$2" --source model --out "chain-$1.json" > /dev/null
  "$bin" evaluate --plant "$plant" --chain "chain-$1.json" --probe-peak 0.6 --out "eval-$1.json" > /dev/null 2>&1
  echo "| $1 |$(python3 "$here/bench/thd_change_cells.py" "eval-$1.json")"
}

echo "| controller | THD change on the transducer, 40/80/160/320 Hz, dB | on the design's plant model | worst, transducer / model | max drive |"
echo "|---|---|---|---|---|"
defaults=$(design_nn_defaults "$design_flags" "$seed")
if [ -n "${DESIGNED:-}" ]; then
  echo "device_tuning: the design on the model is $DESIGNED" >&2
  cp "$DESIGNED" fb-model.json
else
  echo "device_tuning: $(date +%H:%M:%S) design nn $design_flags" >&2
  # shellcheck disable=SC2086  # the flags are words
  "$bin" design nn --plant "$keep/narx.json" --ff "$keep/ff.json" "${design_nn_flags[@]}" $defaults $design_flags \
    --out fb-model.json > design-model.json 2> design-model.err ||
    { echo "device_tuning: design nn failed:" >&2; tail -n 3 design-model.err >&2; exit 1; }
fi
evaluate_row "designed on the model" fb-model.json

echo "device_tuning: $(date +%H:%M:%S) tuning on the device: $tuning_flags" >&2
# The tuning keeps the design's structure (--start-from), so only the record flags are passed on.
record_flags=(--bandpass 20,1200 --sine-peak 0.6)
for flag in --samples --sine-share; do
  value=$(sed -n "s/.*$flag \([^ ]*\).*/\1/p" <<< "$defaults $design_flags")
  [ -z "$value" ] || record_flags+=("$flag" "$value")
done
# shellcheck disable=SC2086
"$bin" design nn --plant "$keep/narx.json" --ff "$keep/ff.json" "${record_flags[@]}" --seed "$seed" \
  --desired plant-fundamental --distortion-weighting --tune-on device.json --start-from fb-model.json $tuning_flags \
  --out fb-tuned.json > design-tuned.json 2> design-tuned.err ||
  { echo "device_tuning: the tuning failed:" >&2; tail -n 3 design-tuned.err >&2; exit 1; }
evaluate_row "tuned on the device" fb-tuned.json

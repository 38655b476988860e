#!/usr/bin/env bash
# Neural feedback designs with other options on one plant model, side by side: for each VARIANT (a quoted
# list of `design nn` flags) a controller is designed on the NARX model and feedforward that a
# control_table.sh run kept (KEEP=DIR), chained in model mode and evaluated on the transducer at the 0.6
# drive-peak probes. One table row a variant: the THD change by the feedback at each probe on the transducer,
# the same on the design's own plant model (what the design expected), the worst probe of each and the largest drive.
# Usage: bash bench/controller_sweep.sh KEEP_DIR SEED VARIANT...   (the table on stdout, progress on stderr)
# Example: bash bench/controller_sweep.sh /tmp/k2 2 "" "--hidden 16 --iterations 300 --distortion-weighting"
# A variant sets any `design nn` flag; unset ones take control_table.sh's (bench/design_nn_flags.sh: --hidden 8
# --iterations 150, --nu 6 --nv 2 --ny 4, 48 000 samples, sine peak 0.6; and --seed SEED, sine share 0.75).
# About 1-3 min a variant.
# PANELBASS_BIN overrides the binary; PLANT the transducer (default panel-exciter).
set -euo pipefail
if [ $# -lt 3 ]; then
  sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
keep=$(realpath "$1")
seed=$2
shift 2
source "$(dirname "$0")/kept_run.sh"
require_kept controller_sweep "$keep" narx.json ff.json
plant=$(transducer_plant)
cd "$(dirname "$0")/.."
here=$(pwd)
source bench/design_nn_flags.sh
bin=$(realpath "${PANELBASS_BIN:-build/bin/panelbass}")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
echo "| design nn flags (control_table.sh's where unset) | THD change on the transducer, 40/80/160/320 Hz, dB | on the design's plant model | worst, transducer / model | max drive |"
echo "|---|---|---|---|---|"
for variant in "$@"; do
  echo "controller_sweep: $(date +%H:%M:%S) design nn $variant" >&2
  defaults=$(design_nn_defaults "$variant" "$seed")
  # shellcheck disable=SC2086  # the flags are words
  "$bin" design nn --plant "$keep/narx.json" --ff "$keep/ff.json" "${design_nn_flags[@]}" $defaults $variant --out fb.json \
    > /dev/null 2> design.err ||
    { echo "controller_sweep: design nn $variant failed:" >&2; tail -n 3 design.err >&2; exit 1; }
  "$bin" chain --bandpass 20,1200 --ff "$keep/ff.json" --fb fb.json --source model --out chain.json > /dev/null
  "$bin" evaluate --plant "$plant" --chain chain.json --probe-peak 0.6 --out eval.json > /dev/null 2>&1
  echo "| ${variant:-(none)} |$(python3 "$here/bench/thd_change_cells.py" eval.json)"
done

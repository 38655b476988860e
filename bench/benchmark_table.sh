#!/usr/bin/env bash
# Issue #36's benchmark table by the official protocol of the `nonlinear_benchmarks` loader: a model is
# fitted on each benchmark's estimation data only (split into estimation and validation as each row
# says; the test sets decide nothing), then simulated in free run on the official test set with its
# first outputs setting the state (50 samples; EMPS 20; the benchmark's initialisation window) and the
# RMSE taken over the rest. Beside each figure: the best published one (../shared/data/RESULTS.md) and
# the training time on this machine. NARX models trained pem then oem-d by Levenberg–Marquardt with
# early stopping on the validation part (the J the model reports, `--init 50`).
# The neural state-space rows (SS, `identify ss`: SUBNET's linear part plus tanh networks, encoder of past
# data, Adam on truncated simulation windows) select on the same validation part and J; each trains for at
# most SS_SECONDS seconds (default 600).
# Usage: bash bench/benchmark_table.sh [MAX_ITER]   (default 100 iterations per mode)
#   ONLY=ss runs the SS rows alone; SS_SECONDS, SS_EPOCHS bound their training; SS_EXTRA adds options to
#   every identify ss (e.g. "--polish-iter 2000 --polish-window 200", "--lr-final 1e-5" with SS_EPOCHS=6000).
#   PANELBASS_BIN (default build/bin/panelbass), PANELBASS_DATA (default ../shared/data)
#   EXTRA="--weight-decay 1" adds options to every identify narx.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${PANELBASS_BIN:-build/bin/panelbass}
data=${PANELBASS_DATA:-../shared/data}
iters=${1:-100}
extra=${EXTRA:-}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

source bench/split_record.sh
top() { sed -n "s/^  \"$1\": \([-0-9.e+]*\).*/\1/p"; }
# narx NAME FS NA NB HIDDEN [DATA OPTIONS...]: trains $work/NAME.json on NAME-est/-val, prints "seconds"
narx() {
  local name=$1 fs=$2 na=$3 nb=$4 hidden=$5
  shift 5
  # shellcheck disable=SC2086
  "$bin" identify narx --data "$work/$name-est.csv" --val "$work/$name-val.csv" --fs "$fs" "$@" --na "$na" --nb "$nb" \
    --hidden "$hidden" --train pem,oem-d --optimizer lm --max-iter "$iters" --seed 1 $extra \
    --out "$work/$name.json" 2>/dev/null | top seconds | awk '{printf "%.0f", $1}'
}
ss_seconds=${SS_SECONDS:-600}
ss_epochs=${SS_EPOCHS:-100000}
ss_extra=${SS_EXTRA:-}
# ss NAME FS NX HIDDEN LAGS WINDOW [DATA OPTIONS...]: trains $work/NAME-ss.json on NAME-est/-val, prints "seconds"
ss() {
  local name=$1 fs=$2 nx=$3 hidden=$4 lags=$5 window=$6
  shift 6
  # shellcheck disable=SC2086
  "$bin" identify ss --data "$work/$name-est.csv" --val "$work/$name-val.csv" --fs "$fs" "$@" --nx "$nx" \
    --hidden "$hidden" --lags "$lags" --window "$window" --epochs "$ss_epochs" --max-seconds "$ss_seconds" --seed 1 \
    $ss_extra --out "$work/$name-ss.json" 2>/dev/null | top seconds | awk '{printf "%.0f", $1}'
}
# rmse MODEL TEST FS INIT SCALE [DATA OPTIONS...]: the test RMSE times SCALE (units)
rmse() {
  local model=$1 test=$2 fs=$3 init=$4 scale=$5
  shift 5
  "$bin" validate --model "$model" --data "$test" --fs "$fs" --init "$init" "$@" 2>/dev/null | top rmse |
    awk -v s="$scale" '{printf "%.3g", $1 * s}'
}

echo "| benchmark | test set | model | init | test RMSE | best published | train s |"
echo "|---|---|---|---:|---:|---:|---:|"

sb=$data/silverbox/splits
fs_sb=610.3515625
split "$sb/train_val_multisine.csv" 52000 sb
wh=$data/wiener_hammerstein_2009/splits
split "$wh/train.csv" 80000 wh
if [ "${ONLY:-}" = ss ]; then
  s=$(ss sb $fs_sb 4 20 20 100)
  for t in multisine:0.264 arrow_full:0.26 arrow_no_extrapolation:0.307; do
    echo "| Silverbox | $(echo "${t%:*}" | tr _ ' ') | SS nx=4, 20 nodes | 50 | $(rmse "$work/sb-ss.json" "$sb/test_${t%:*}.csv" $fs_sb 50 1000) mV | ${t#*:} mV | $s |"
  done
  s=$(ss wh 51200 6 20 50 100)
  echo "| Wiener–Hammerstein 2009 | test | SS nx=6, 20 nodes | 50 | $(rmse "$work/wh-ss.json" "$wh/test.csv" 51200 50 1000) mV | 0.241 mV (SUBNET nx=6) | $s |"
  exit 0
fi
s=$(narx sb $fs_sb 6 6 20)
echo "| Silverbox | multisine | NARX 6-6-20 | 50 | $(rmse "$work/sb.json" "$sb/test_multisine.csv" $fs_sb 50 1000) mV | 0.264 mV (SS-encoder nx=8, its own validation part) | $s |"
echo "| Silverbox | arrow full | NARX 6-6-20 | 50 | $(rmse "$work/sb.json" "$sb/test_arrow_full.csv" $fs_sb 50 1000) mV | 0.26 mV (PNLSS) | $s |"
echo "| Silverbox | arrow no extrapolation | NARX 6-6-20 | 50 | $(rmse "$work/sb.json" "$sb/test_arrow_no_extrapolation.csv" $fs_sb 50 1000) mV | 0.307 mV (SS-encoder nx=8) | $s |"

s=$(ss sb $fs_sb 4 20 20 100)
echo "| Silverbox | multisine | SS nx=4, 20 nodes | 50 | $(rmse "$work/sb-ss.json" "$sb/test_multisine.csv" $fs_sb 50 1000) mV | 0.264 mV | $s |"
echo "| Silverbox | arrow full | SS nx=4, 20 nodes | 50 | $(rmse "$work/sb-ss.json" "$sb/test_arrow_full.csv" $fs_sb 50 1000) mV | 0.26 mV | $s |"
echo "| Silverbox | arrow no extrapolation | SS nx=4, 20 nodes | 50 | $(rmse "$work/sb-ss.json" "$sb/test_arrow_no_extrapolation.csv" $fs_sb 50 1000) mV | 0.307 mV | $s |"

s=$(narx wh 51200 10 10 20)
echo "| Wiener–Hammerstein 2009 | test | NARX 10-10-20 | 50 | $(rmse "$work/wh.json" "$wh/test.csv" 51200 50 1000) mV | 0.241 mV (SUBNET nx=6) | $s |"
s=$(ss wh 51200 6 20 50 100)
echo "| Wiener–Hammerstein 2009 | test | SS nx=6, 20 nodes | 50 | $(rmse "$work/wh-ss.json" "$wh/test.csv" 51200 50 1000) mV | 0.241 mV (SUBNET nx=6) | $s |"

# cascaded tanks: estimation rows [0, 700) of uEst/yEst, validation [700, 1024) (as Champneys et al. 2024)
ct=$data/cascaded_tanks/dataBenchmark.csv
split "$ct" 700 ct
s=$(narx ct 0.25 2 2 5 --input-col uEst --output-col yEst)
echo "| Cascaded tanks | uVal/yVal | NARX 2-2-5 | 50 | $(rmse "$work/ct.json" "$ct" 0.25 50 1 --input-col uVal --output-col yVal) V | 0.191 V (grey box) | $s |"

# EMPS: u = vir, y = qm; estimation rows [0, 20000) of DATA_EMPS, validation the rest; test DATA_EMPS_PULSES
em=$data/emps
split "$em/DATA_EMPS.csv" 20000 em
s=$(narx em 1000 2 2 10 --input-col vir --output-col qm)
echo "| EMPS | DATA_EMPS_PULSES | NARX 2-2-10 | 20 | $(rmse "$work/em.json" "$em/DATA_EMPS_PULSES.csv" 1000 20 1000 --input-col vir --output-col qm) mm | 2.64 mm (dynoNet) | $s |"

echo "| Fine steering mirror | 100 / 200 / 300 mV | not run: 3 inputs × 3 outputs, panelbass's models are single-input single-output | 100 | – | 0.0866 / 0.131 / 0.169 µm (NL-LFR) | – |"

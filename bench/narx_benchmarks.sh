#!/usr/bin/env bash
# Neural NARX identification on the real benchmark data (../shared/data), trained on its simulation
# error (pem then oem-d, Levenberg–Marquardt, early stopping on the validation part), then free-run RMSE
# on the official test sets with the first 50 outputs setting the state (the benchmark protocol).
# Usage: bash bench/narx_benchmarks.sh [MAX_ITER]   (default 100 per mode)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/bin/panelbass
data=${PANELBASS_DATA:-../shared/data}
iters=${1:-100}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

source bench/split_record.sh
rmse_mv() { sed -n 's/.*"rmse": \([-0-9.e+]*\).*/\1/p' | awk '{printf "%.3f", $1 * 1000}'; }
top() { sed -n "s/^  \"$1\": \([-0-9.e+]*\).*/\1/p"; }

sb=$data/silverbox/splits
split "$sb/train_val_multisine.csv" 52000 sb
echo "## Silverbox: NARX trained pem,oem-d (LM, ≤ $iters iterations per mode) on rows 0..52000 of train_val_multisine"
echo "| na | nb | hidden | params | J_val % | multisine mV | arrow full mV | arrow no-extrap. mV | train s |"
echo "|---:|---:|---|---:|---:|---:|---:|---:|---:|"
for cfg in "4 4 15" "6 6 20"; do
  read -r na nb hidden <<< "$cfg"
  out=$($bin identify narx --data "$work/sb-est.csv" --val "$work/sb-val.csv" --fs 610.3515625 --na "$na" --nb "$nb" \
        --hidden "$hidden" --train pem,oem-d --optimizer lm --max-iter "$iters" --seed 1 --out "$work/sb.json" 2>/dev/null)
  row="| $na | $nb | $hidden | $(echo "$out" | top params) | $(echo "$out" | top J_val_pct | awk '{printf "%.4f", $1}')"
  for t in test_multisine test_arrow_full test_arrow_no_extrapolation; do
    row="$row | $($bin validate --model "$work/sb.json" --data "$sb/$t.csv" --init 50 | rmse_mv)"
  done
  echo "$row | $(echo "$out" | top seconds | awk '{printf "%.1f", $1}') |"
done

wh=$data/wiener_hammerstein_2009/splits
split "$wh/train.csv" 80000 wh
echo
echo "## Wiener–Hammerstein 2009: NARX trained pem,oem-d (LM, ≤ $iters iterations per mode) on rows 0..80000 of train"
echo "| na | nb | hidden | params | J_val % | test mV | train s |"
echo "|---:|---:|---|---:|---:|---:|---:|"
for cfg in "6 6 15" "10 10 20"; do
  read -r na nb hidden <<< "$cfg"
  out=$($bin identify narx --data "$work/wh-est.csv" --val "$work/wh-val.csv" --fs 51200 --na "$na" --nb "$nb" \
        --hidden "$hidden" --train pem,oem-d --optimizer lm --max-iter "$iters" --seed 1 --out "$work/wh.json" 2>/dev/null)
  echo "| $na | $nb | $hidden | $(echo "$out" | top params) | $(echo "$out" | top J_val_pct | awk '{printf "%.4f", $1}') | $($bin validate --model "$work/wh.json" --data "$wh/test.csv" --init 50 | rmse_mv) | $(echo "$out" | top seconds | awk '{printf "%.1f", $1}') |"
done

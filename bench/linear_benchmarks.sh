#!/usr/bin/env bash
# Linear identification on the real benchmark data (../shared/data): Silverbox and
# Wiener–Hammerstein 2009. Fits on the official estimation part (split into estimation and
# validation as below; the test sets are never used for a decision), then free-run simulation RMSE on
# each official test set with the first 50 outputs setting the state (the benchmark protocol).
# Usage: bash bench/linear_benchmarks.sh [METHOD...]   (default: arx oe zhu backx)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/bin/panelbass
data=${PANELBASS_DATA:-../shared/data}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
methods=("$@")
[ ${#methods[@]} -gt 0 ] || methods=(arx oe zhu backx)

source bench/split_record.sh
rmse_mv() { sed -n 's/.*"rmse": \([-0-9.e+]*\).*/\1/p' | awk '{printf "%.2f", $1 * 1000}'; }
field() { sed -n "s/.*\"$1\": \([-0-9.e+]*\).*/\1/p" | head -n 1; }

sb=$data/silverbox/splits
fs_sb=610.3515625
split "$sb/train_val_multisine.csv" 52000 sb
echo "## Silverbox (fs $fs_sb Hz): estimation rows 0..52000 of train_val_multisine, validation the rest"
echo "| method | order | J_val % | multisine mV | arrow full mV | arrow no-extrap. mV | fit s |"
echo "|---|---:|---:|---:|---:|---:|---:|"
for m in "${methods[@]}"; do
  start=$(date +%s.%N)
  out=$($bin identify linear --data "$work/sb-est.csv" --val "$work/sb-val.csv" --fs $fs_sb --method "$m" \
        --scan 1:10 --out "$work/sb-$m.json" 2>/dev/null)
  secs=$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN{print b - a}')
  row="| $m | $(echo "$out" | field order) | $(echo "$out" | field J_val_pct | awk '{printf "%.3f", $1}')"
  for t in test_multisine test_arrow_full test_arrow_no_extrapolation; do
    row="$row | $($bin validate --model "$work/sb-$m.json" --data "$sb/$t.csv" --init 50 | rmse_mv)"
  done
  echo "$row | $(printf %.1f "$secs") |"
done

wh=$data/wiener_hammerstein_2009/splits
split "$wh/train.csv" 80000 wh
echo
echo "## Wiener–Hammerstein 2009 (fs 51200 Hz): estimation rows 0..80000 of train, validation the rest"
echo "| method | order | J_val % | test mV | fit s |"
echo "|---|---:|---:|---:|---:|"
for m in "${methods[@]}"; do
  start=$(date +%s.%N)
  out=$($bin identify linear --data "$work/wh-est.csv" --val "$work/wh-val.csv" --fs 51200 --method "$m" \
        --scan 1:10 --out "$work/wh-$m.json" 2>/dev/null)
  secs=$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN{print b - a}')
  echo "| $m | $(echo "$out" | field order) | $(echo "$out" | field J_val_pct | awk '{printf "%.3f", $1}') | $($bin validate --model "$work/wh-$m.json" --data "$wh/test.csv" --init 50 | rmse_mv) | $(printf %.1f "$secs") |"
done

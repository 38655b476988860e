#!/usr/bin/env bash
# The thesis's table after fig. 7.8 on the virtual transducer: the largest program amplitude "in" that
# keeps the LQ feedforward controller's output u* within [-1, 1] behind a Butterworth band-pass, for
# the thesis's weights (R = 1e-5 and R = 3, R0 = 20) and band-passes 0-1200, 20-1200, 50-1200 Hz.
# The thesis found 0.33 / 0.40 / 0.43 (R = 1e-5). "worst" is 1/||h||_1 (any program), "noise" the
# largest amplitude of band-limited uniform white noise that stays within [-1, 1].
#
# Data: uniform noise at full scale on the panel-exciter preset at 3000 Hz, EST samples to estimate
# (default 12000) and half as many to validate; the linear model is the one the order scan picks
# (default OE, orders 1..16).
# Usage: bash bench/lq_table.sh [METHOD] [SEED] [EST]   (METHOD: oe or zhu; PANELBASS_BIN overrides the binary)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${PANELBASS_BIN:-build/bin/panelbass}
method=${1:-oe}
seed=${2:-1}
est=${3:-12000}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
field() { sed -n "s/^  \"$1\": \([-0-9.e+]*\).*/\1/p" | head -n 1; }
ripple() { tr -d '\n ' | sed -n "s/.*\"ripple_db\":{[^}]*\"$1\":\([-0-9.e+]*\).*/\1/p"; }

"$bin" simulate --plant panel-exciter --signal noise --amplitude 1 --samples $((est + est / 2)) --seed "$seed" \
    --out "$work/all.csv" > /dev/null 2>&1
head -n $((est + 1)) "$work/all.csv" > "$work/est.csv"
{ head -n 1 "$work/all.csv"; tail -n +$((est + 2)) "$work/all.csv"; } > "$work/val.csv"
id=$("$bin" identify linear --data "$work/est.csv" --val "$work/val.csv" --fs 3000 --method "$method" \
       --scan 1:16 --out "$work/lin.json" 2> /dev/null)
echo "## LQ feedforward on panel-exciter: $method model of order $(echo "$id" | field order)," \
     "delay $(echo "$id" | field delay), J_val $(echo "$id" | field J_val_pct | awk '{printf "%.2f", $1}') %" \
     "(seed $seed, $est + $((est / 2)) samples)"
echo
echo "| R | R0 | band-pass (Hz) | states | max in, worst | max in, noise | thesis | pass-band ripple (≥ 20 Hz), model → controlled (dB) |"
echo "|---:|---:|---|---:|---:|---:|---:|---|"
for R in 1e-5 3; do
  for band in 0,1200 20,1200 50,1200; do
    thesis="–"
    if [ "$R" = 1e-5 ]; then
      case $band in 0,1200) thesis=0.33 ;; 20,1200) thesis=0.40 ;; 50,1200) thesis=0.43 ;; esac
    fi
    out=$("$bin" design lq --model "$work/lin.json" --R "$R" --R0 20 --bandpass "$band" --samples 100000 \
            --seed "$seed" --out "$work/ff.json")
    printf '| %s | 20 | %s | %s | %.3f | %.3f | %s | %.1f → %.1f |\n' "$R" "${band/,/–}" "$(echo "$out" | field order)" \
        "$(echo "$out" | field max_input_worst)" "$(echo "$out" | field max_input_noise)" "$thesis" \
        "$(echo "$out" | ripple model)" "$(echo "$out" | ripple controlled)"
  done
done

#!/usr/bin/env bash
# The thesis's table after fig. 7.8 on the virtual transducer: the largest program amplitude "in" that
# keeps the LQ feedforward controller's output u* within [-1, 1] behind a Butterworth band-pass, for
# the thesis's weights (R = 1e-5 and R = 3, R0 = 20) and band-passes 0-1200, 20-1200, 50-1200 Hz.
# The thesis found 0.33 / 0.40 / 0.43 (R = 1e-5). "worst" is 1/||h||_1 (any program), "noise" the
# largest amplitude of band-limited uniform white noise that stays within [-1, 1]. The last rows turn
# the question round: the R that design lq --max-input 0.33 finds (the flattest design that still takes
# a third of full scale) and the ripple it leaves. "drive peak" is where band-pass · controller has its
# largest gain: below the band-pass's low corner, the controller boosts what the band-pass removes.
#
# Two models: (1) the one a user gets: uniform noise at full scale on the panel-exciter preset at
# 3000 Hz, EST samples to estimate (default 12000) and half as many to validate, the order the scan
# picks (default OE, orders 1..16); (2) the reference: the same transducer with its nonlinearities and
# sensor noise off (the "linear" preset, noise 0), 60 000 samples, orders 1..12: the table the
# transducer's linear physics gives, free of estimation error.
# Usage: bash bench/lq_table.sh [METHOD] [SEED] [EST]   (METHOD: oe or zhu; PANELBASS_BIN overrides the binary)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=$(realpath "${PANELBASS_BIN:-build/bin/panelbass}")
method=${1:-oe}
seed=${2:-1}
est=${3:-12000}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
field() { sed -n "s/^  \"$1\": \([-0-9.e+]*\).*/\1/p" | head -n 1; }
ripple() { tr -d '\n ' | sed -n "s/.*\"ripple_db\":{[^}]*\"$1\":\([-0-9.e+]*\).*/\1/p"; }
peak() { tr -d '\n ' | sed -n "s/.*\"drive_peak\":{[^}]*\"$1\":\([-0-9.e+]*\).*/\1/p"; }

# identify PLANT SAMPLES SCAN NAME: the order scan's linear model of PLANT, first 2/3 to estimate.
identify() {
  local n=$2 e=$(( $2 * 2 / 3 ))
  "$bin" simulate --plant "$1" --signal noise --amplitude 1 --samples "$n" --seed "$seed" --out "$work/all.csv" > /dev/null 2>&1
  head -n $((e + 1)) "$work/all.csv" > "$work/est.csv"
  { head -n 1 "$work/all.csv"; tail -n +$((e + 2)) "$work/all.csv"; } > "$work/val.csv"
  "$bin" identify linear --data "$work/est.csv" --val "$work/val.csv" --fs 3000 --method "$method" \
      --scan "$3" --out "$work/$4.json" 2> /dev/null
}

# table MODEL TITLE: the rows for MODEL.
table() {
  echo "$2"
  echo
  echo "| R | R0 | band-pass (Hz) | max in, worst | max in, noise | thesis | drive peak (Hz, dB) | pass-band ripple (≥ 20 Hz), model → controlled (dB) |"
  echo "|---:|---:|---|---:|---:|---:|---|---|"
  for weight in "--R 1e-5" "--R 3" "--max-input 0.33"; do
    for band in 0,1200 20,1200 50,1200; do
      thesis="–"
      if [ "$weight" = "--R 1e-5" ]; then
        case $band in 0,1200) thesis=0.33 ;; 20,1200) thesis=0.40 ;; 50,1200) thesis=0.43 ;; esac
      fi
      out=$("$bin" design lq --model "$work/$1.json" $weight --R0 20 --bandpass "$band" --samples 100000 \
              --seed "$seed" --out "$work/ff.json" 2> /dev/null)
      label=$(echo "$out" | field R)
      if [ "$weight" = "--max-input 0.33" ]; then label=$(printf '%.3g (searched)' "$label"); fi
      printf '| %s | 20 | %s | %.3f | %.3f | %s | %.1f, %+.1f | %.1f → %.1f |\n' "$label" "${band/,/–}" \
          "$(echo "$out" | field max_input_worst)" "$(echo "$out" | field max_input_noise)" "$thesis" \
          "$(echo "$out" | peak frequency_hz)" "$(echo "$out" | peak gain_db)" \
          "$(echo "$out" | ripple model)" "$(echo "$out" | ripple controlled)"
    done
  done
  echo
}

id=$(identify panel-exciter $((est + est / 2)) 1:16 lin)
table lin "## LQ feedforward on panel-exciter: $method model of order $(echo "$id" | field order), delay $(echo "$id" | field delay), J_val $(echo "$id" | field J_val_pct | awk '{printf "%.2f", $1}') % (seed $seed, $est + $((est / 2)) samples)"

"$bin" plant show linear | python3 -c 'import json, sys; p = json.load(sys.stdin); p["sensor"]["noise_rms_V"] = 0.0; json.dump(p, sys.stdout)' > "$work/quiet.json"
id=$(identify "$work/quiet.json" 60000 1:12 ref)
table ref "## Reference: the same transducer linear and noise-free, $method model of order $(echo "$id" | field order), J_val $(echo "$id" | field J_val_pct | awk '{printf "%.5f", $1}') % (60 000 samples)"

#!/usr/bin/env bash
# Issue #36: where the exciter record's validation J exceeds its noise floor. The record of
# bench/narx_speed.sh (panel exciter, uniform noise of peak 1, seed 11; samples 0–4999 estimation,
# 5000–9999 validation), extended to 30000 samples (the first 10000 are the same), and the same record
# from the plant with sensor.noise_rms_V 0 (the noise-free output). Prints, J by `validate --init 50`:
#  1. the noise floor (J of the noise-free output, k ≥ 50) on the validation and the estimation half;
#  2. memory: linear OE J_val at orders 2..16 on the record, and on the linear, noise-free plant (every
#     nonlinear term off) at 4..8;
#  3. the NARX 17-17-1 (na = nb = 8, pem then oem-d by LM, --weight-decay 0.1, --seed 3) with
#     --max-iter 100 and 400 (converged?), on the 20000 later samples (4× the data), and on the noise-free
#     estimation output (noise or structure?); each judged on the validation half, on its first 4000
#     samples, and against the noise-free output there (the model's own error);
#  4. the largest displacement (column x) of the estimation parts and of the validation half's two parts.
# Four NARX trainings: 4–15 minutes on 2 loaded cores. Usage: bash bench/exciter_excess.sh
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${PANELBASS_BIN:-build/bin/panelbass}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
[[ -x $bin ]] || { echo "exciter_excess: $bin not found; build first" >&2; exit 1; }

noise_off() { sed 's/"noise_rms_V": [0-9.e+-]*/"noise_rms_V": 0.0/'; }
"$bin" plant show panel-exciter | noise_off > "$work/clean-plant.json"
# every nonlinear term off: each "enabled": true under "nonlinear" (the only ones in the file)
sed 's/"enabled": true/"enabled": false/' "$work/clean-plant.json" > "$work/linear-plant.json"
record() { "$bin" simulate --plant "$1" --signal noise --amplitude 1 --samples 30000 --seed 11 --out "$2" >/dev/null 2>&1; }
record panel-exciter "$work/n.csv"
record "$work/clean-plant.json" "$work/c.csv"
record "$work/linear-plant.json" "$work/l.csv"
rows() { { head -n 1 "$1"; sed -n "$(($2 + 2)),$(($3 + 1))p" "$1"; } > "$4"; }  # rows FILE FROM TO OUT: data rows FROM..TO−1
rows "$work/n.csv" 0 5000 "$work/est.csv";      rows "$work/n.csv" 5000 10000 "$work/val.csv"
rows "$work/n.csv" 10000 30000 "$work/est4.csv"; rows "$work/c.csv" 0 5000 "$work/estc.csv"
rows "$work/n.csv" 5000 9000 "$work/val4k.csv";  rows "$work/c.csv" 5000 9000 "$work/valc4k.csv"
rows "$work/c.csv" 5000 10000 "$work/valc.csv"
rows "$work/l.csv" 0 5000 "$work/le.csv";        rows "$work/l.csv" 5000 10000 "$work/lv.csv"

j() { "$bin" validate --model "$1" --data "$2" --fs 3000 --init 50 2>/dev/null | sed -n 's/.*"J_sim_pct": \([-0-9.e+]*\).*/\1/p' | awk '{printf "%.4f", $1}'; }
floor() { paste -d, "$1" "$2" | awk -F, 'NR > 51 { e += ($2 - $6)^2; s += $2^2 } END { printf "%.4f", 100 * e / s }'; }
echo "noise floor: validation half $(floor "$work/val.csv" "$work/valc.csv") %, its first 4000 samples $(floor "$work/val4k.csv" "$work/valc4k.csv") %," \
  "estimation half $(floor "$work/est.csv" "$work/estc.csv") %"

printf 'linear OE J_val %%, the record:'
for n in 2 4 6 8 10 12 16; do
  "$bin" identify linear --data "$work/est.csv" --val "$work/val.csv" --fs 3000 --method oe --order $n --out "$work/oe.json" >/dev/null 2>&1
  printf ' n=%d %s' $n "$(j "$work/oe.json" "$work/val.csv")"
done
printf '\nlinear OE J_val %%, linear noise-free plant:'
for n in 4 6 8; do
  "$bin" identify linear --data "$work/le.csv" --val "$work/lv.csv" --fs 3000 --method oe --order $n --out "$work/oe.json" >/dev/null 2>&1
  printf ' n=%d %s' $n "$(j "$work/oe.json" "$work/lv.csv")"
done
echo

narx() {  # narx NAME EST MAX_ITER: trains, prints its J figures
  local start end
  start=$(date +%s.%N)
  "$bin" identify narx --data "$2" --val "$work/val.csv" --fs 3000 --na 8 --nb 8 --hidden 17 --train pem,oem-d \
    --optimizer lm --max-iter "$3" --weight-decay 0.1 --seed 3 --out "$work/$1.json" >/dev/null 2>&1
  end=$(date +%s.%N)
  printf '%-28s J_val %s  own error %s | first 4000: J %s own error %s | %.0f s\n' "$1" \
    "$(j "$work/$1.json" "$work/val.csv")" "$(j "$work/$1.json" "$work/valc.csv")" \
    "$(j "$work/$1.json" "$work/val4k.csv")" "$(j "$work/$1.json" "$work/valc4k.csv")" "$(awk "BEGIN { print $end - $start }")"
}
echo "NARX 17-17-1, J % (own error: against the noise-free output):"
narx "5000 samples, 100 iter" "$work/est.csv" 100
narx "5000 samples, 400 iter" "$work/est.csv" 400
narx "20000 samples, 100 iter" "$work/est4.csv" 100
narx "5000 noise-free, 100 iter" "$work/estc.csv" 100

maxabs() { awk -F, -v a="$2" -v b="$3" 'NR > 1 && NR - 2 >= a && NR - 2 < b { v = $4 < 0 ? -$4 : $4; if (v > m) m = v } END { printf "%.2f", 1000 * m }' "$1"; }
echo "largest |x|, mm: estimation $(maxabs "$work/n.csv" 0 5000), the 20000 later samples $(maxabs "$work/n.csv" 10000 30000)," \
  "validation first 4000 $(maxabs "$work/n.csv" 5000 9000), last 1000 $(maxabs "$work/n.csv" 9000 10000)"

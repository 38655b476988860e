#!/usr/bin/env bash
# `panelbass diagnose` on real data: Silverbox (../shared/data/silverbox), an electronic Duffing
# oscillator whose documented physics is a hardening cubic spring. Estimation = rows 0..52000 of the
# official train/val multisine part, validation = the rest (as bench/linear_benchmarks.sh); the test
# sets are not used. Reports the baseline, every finding and validation J before/after.
# Usage: bash bench/diagnose_bench.sh [BUILD_DIR]   (default: build)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${1:-build}/bin/panelbass
data=${PANELBASS_DATA:-../shared/data}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

split() {  # split FILE at data row N into $work/NAME-est.csv and $work/NAME-val.csv
  local file=$1 rows=$2 name=$3
  head -n $((rows + 1)) "$file" > "$work/$name-est.csv"
  { head -n 1 "$file"; tail -n +$((rows + 2)) "$file"; } > "$work/$name-val.csv"
}

sb=$data/silverbox/splits
fs_sb=610.3515625
split "$sb/train_val_multisine.csv" 52000 sb
echo "## Silverbox (fs $fs_sb Hz): diagnose, estimation rows 0..52000 of train_val_multisine, validation the rest"
start=$(date +%s.%N)
"$bin" diagnose --data "$work/sb-est.csv" --val "$work/sb-val.csv" --fs "$fs_sb" --scan-from 2 --scan-to 8 \
  --out "$work/sb-report.json" > "$work/sb-summary.json"
end=$(date +%s.%N)
python3 - "$work/sb-report.json" "$(echo "$end - $start" | bc)" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
b = r["baseline"]
print(f"baseline: linear OE na={b['na']} nb={b['nb']} nk={b['nk']}, J_val {b['J_val_pct']:.4f} %, noise floor {r['noise_floor_pct']:.4f} %")
print("| # | effect | J_val before % | J_val after % | explanation |")
print("|---:|---|---:|---:|---|")
for i, f in enumerate(r["findings"], 1):
    print(f"| {i} | {f['effect']} | {f['J_val_before_pct']:.4f} | {f['J_val_after_pct']:.4f} | {f['explanation']} |")
first = r["findings"][0]["effect"] if r["findings"] else "none"
print(f"first finding: {first}; J_val {r['J_val_before_pct']:.4f} % -> {r['J_val_after_pct']:.4f} % ({float(sys.argv[2]):.1f} s)")
PY

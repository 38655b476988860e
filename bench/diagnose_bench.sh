#!/usr/bin/env bash
# `panelbass diagnose` on real data: Silverbox (../shared/data/silverbox), an electronic Duffing
# oscillator whose documented physics is a hardening cubic spring: estimation = rows 0..52000 of the
# official train/val multisine part, validation = the rest; and Wiener–Hammerstein 2009
# (../shared/data/wiener_hammerstein_2009), a diode-resistor saturation between two filters: estimation
# = rows 0..80000 of the official estimation part, validation = the rest (as bench/linear_benchmarks.sh).
# The test sets are not used. Then periodic data of the virtual transducer. Reports the baseline, every
# finding, validation J before/after and where the residual lies before and after.
# Usage: bash bench/diagnose_bench.sh [BUILD_DIR]   (default: build; PANELBASS_HTML=DIR also writes DIR/sb.html, wh.html)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${1:-build}/bin/panelbass
data=${PANELBASS_DATA:-../shared/data}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

source bench/split_record.sh

report() {  # report REPORT.json SECONDS: the baseline, every finding, the first, J before/after
  python3 - "$1" "$2" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
b = r["baseline"]
print(f"baseline: linear OE na={b['na']} nb={b['nb']} nk={b['nk']}, J_val {b['J_val_pct']:.4f} %, noise floor {r['noise_floor_pct']:.4f} %")
print("| # | effect | confidence | J_val before % | J_val after % | explanation |")
print("|---:|---|---|---:|---:|---|")
for i, f in enumerate(r["findings"], 1):
    p = f["parameters"]
    where = f" ({p['structure']}, {p.get('shape', '')})" if "structure" in p else ""
    word = f["confidence"].get("word", "")
    print(f"| {i} | {f['effect']}{where} | {word} | {f['J_val_before_pct']:.4f} | {f['J_val_after_pct']:.4f} | {f['explanation']} |")
def where(l):
    f, d = l["frf_error"], l["distortion"]
    frf = (f"FRF error {f['band_low_hz']:.0f}-{f['band_high_hz']:.0f} Hz ({f['relative_db']:.1f} dB at {f['frequency_hz']:.0f} Hz)"
           if f["significant"] else "no FRF error")
    db = lambda x: "n/a" if x is None else f"{x:.2f} dB"
    dist = (f"periodic ({d['period']} samples): residual odd {db(d['residual_odd_db'])}, even {db(d['residual_even_db'])} over noise"
            if d["periodic"] and d["odd_lines_only"] else "not periodic" if not d["periodic"] else "periodic, even lines excited")
    top = max(l["states"], key=lambda p: p["shape_chi2"])
    return f"{frf}; {dist}; most state-dependent: {top['state']} (chi2 {top['shape_chi2']:.1f})"
loc = r["location"]
print(f"where the residual lies, before: {where(loc['validation'])}")
print(f"where the residual lies, after:  {where(loc['validation_after'])}")
first = r["findings"][0]["effect"] if r["findings"] else "none"
print(f"first finding: {first}; J_val {r['J_val_before_pct']:.4f} % -> {r['J_val_after_pct']:.4f} % ({float(sys.argv[2]):.1f} s)")
PY
}

run() {  # run NAME FS SCAN_FROM SCAN_TO: diagnose $work/NAME-est.csv against $work/NAME-val.csv
  local name=$1 fs=$2 from=$3 to=$4 start end
  start=$(date +%s.%N)
  "$bin" diagnose --data "$work/$name-est.csv" --val "$work/$name-val.csv" --fs "$fs" --scan-from "$from" --scan-to "$to" \
    --out "$work/$name-report.json" ${PANELBASS_HTML:+--html "$PANELBASS_HTML/$name.html"} > "$work/$name-summary.json"
  end=$(date +%s.%N)
  report "$work/$name-report.json" "$(echo "$end - $start" | bc)"
}

sb=$data/silverbox/splits
split "$sb/train_val_multisine.csv" 52000 sb
echo "## Silverbox (fs 610.3515625 Hz): diagnose, estimation rows 0..52000 of train_val_multisine, validation the rest"
run sb 610.3515625 2 8

wh=$data/wiener_hammerstein_2009/splits
split "$wh/train.csv" 80000 wh
echo
echo "## Wiener-Hammerstein 2009 (fs 51200 Hz): diagnose, estimation rows 0..80000 of train, validation the rest"
run wh 51200 2 10

# Periodic data: the panel-exciter virtual transducer driven by five periods of a random-odd multisine
# (8192 samples, 10-1200 Hz, full drive), estimation and validation with different phases: the odd and even
# distortion at the empty lines is read before and after the diagnosis.
for seed in 1 2; do
  "$bin" simulate --plant panel-exciter --signal multisine --lines random-odd --period 8192 --samples 40960 \
    --seed "$seed" --out "$work/ms-$seed.csv" > /dev/null 2>&1
done
mv "$work/ms-1.csv" "$work/ms-est.csv"
mv "$work/ms-2.csv" "$work/ms-val.csv"
echo
echo "## panel-exciter, periodic random-odd multisine (fs 3000 Hz, 5 periods of 8192): diagnose"
run ms 3000 8 14

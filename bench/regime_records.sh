# The plant in its operating regime, as the control benches record it (sourced by control_table.sh and
# closed_loop_refine.sh).

# regime_records BIN OUT COUNT FIRST_SEED SIMULATE_FLAGS...: COUNT records of 22 500 samples of
# `simulate --signal control SIMULATE_FLAGS` at steady drive peaks 0.35-0.85 (record i at 0.35 + 0.1 (i mod 6),
# seed FIRST_SEED + i), one after another in the CSV file OUT under one header.
regime_records() {
  local bin=$1 out=$2 count=$3 first_seed=$4 i peak
  shift 4
  for i in $(seq 0 $((count - 1))); do
    peak=$(awk -v i="$i" 'BEGIN { printf "%.2f", 0.35 + 0.1 * (i % 6) }')
    "$bin" simulate --signal control "$@" --samples 22500 --seed $((first_seed + i)) --sine-peak "$peak" \
      --out regime_record.csv > /dev/null 2>&1
    if [ "$i" = 0 ]; then cat regime_record.csv > "$out"; else tail -n +2 regime_record.csv >> "$out"; fi
  done
  rm -f regime_record.csv
}

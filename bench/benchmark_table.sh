#!/usr/bin/env bash
# Issue #36's benchmark table by the official protocol of the `nonlinear_benchmarks` loader: a model is
# fitted on each benchmark's estimation data only (split into estimation and validation as each row
# says; the test sets decide nothing), then simulated in free run on the official test set with its
# first outputs setting the state (50 samples; EMPS 20; the benchmark's initialisation window) and the
# RMSE taken over the rest. Beside each figure: the best published one (../shared/data/RESULTS.md) and
# the training time on this machine (wall seconds). NARX models trained pem then oem-d by
# Levenberg–Marquardt with early stopping on the validation part (the J the model reports, `--init 50`).
# The oscillator rows (`identify oscillator`: a continuous-time Duffing oscillator with named terms, its input
# band-limited between samples, fitted in stages by Levenberg–Marquardt) choose their stage on the same part.
# The neural state-space rows (`identify ss`: SUBNET's linear part plus tanh networks, encoder of past
# data, Adam on truncated simulation windows; PNLSS: the same linear part plus cubic monomials of the
# state and input, no tanh layer; or of the states alone) select on the same validation part and J. The
# Wiener–Hammerstein start (`--wiener-hammerstein`: the linear model's poles and zeros split between two
# filters, tanh nodes between them, refined jointly by Levenberg–Marquardt) is written as an ss model.
#
# Trained models are kept in MODELS (default bench/benchmark_models, in the repository): a row whose
# model file KEY.json is there is not retrained — the table is printed from the file, with the training
# seconds recorded beside it in KEY.seconds (for a model trained in stages, the stages' sum; the
# commands are in docs/identification.md). A missing model is trained and kept there (TRAIN=0 prints
# "not trained" instead). So `bash bench/benchmark_table.sh` reads the kept models and prints the table in
# about a minute; `MODELS=$(mktemp -d) bash bench/benchmark_table.sh` retrains everything.
# Usage: bash bench/benchmark_table.sh [MAX_ITER]   (default 100 NARX iterations per mode)
#   SS_SECONDS (default 600) bounds each identify ss that has to be trained; SS_EXTRA adds options to it.
#   PANELBASS_BIN (default build/bin/panelbass), PANELBASS_DATA (default ../shared/data)
#   EXTRA="--weight-decay 1" adds options to every identify narx.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${PANELBASS_BIN:-build/bin/panelbass}
data=${PANELBASS_DATA:-../shared/data}
iters=${1:-100}
extra=${EXTRA:-}
models=${MODELS:-bench/benchmark_models}
train=${TRAIN:-1}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$models"

source bench/split_record.sh
top() { sed -n "s/^  \"$1\": \([-0-9.e+]*\).*/\1/p"; }
# narx OUT NAME FS NA NB HIDDEN [DATA OPTIONS...]: trains OUT on NAME-est/-val, prints its seconds
narx() {
  local out=$1 name=$2 fs=$3 na=$4 nb=$5 hidden=$6
  shift 6
  # shellcheck disable=SC2086
  "$bin" identify narx --data "$work/$name-est.csv" --val "$work/$name-val.csv" --fs "$fs" "$@" --na "$na" --nb "$nb" \
    --hidden "$hidden" --train pem,oem-d --optimizer lm --max-iter "$iters" --seed 1 $extra \
    --out "$out" 2>/dev/null | top seconds | awk '{printf "%.0f", $1}'
}
# ss OUT NAME FS NX HIDDEN LAGS WINDOW [MORE OPTIONS...]: trains OUT on NAME-est/-val, prints its seconds
ss() {
  local out=$1 name=$2 fs=$3 nx=$4 hidden=$5 lags=$6 window=$7
  shift 7
  # shellcheck disable=SC2086
  "$bin" identify ss --data "$work/$name-est.csv" --val "$work/$name-val.csv" --fs "$fs" --nx "$nx" \
    --hidden "$hidden" --lags "$lags" --window "$window" --max-seconds "${SS_SECONDS:-600}" --seed 1 "$@" \
    ${SS_EXTRA:-} --out "$out" 2>/dev/null | top seconds | awk '{printf "%.0f", $1}'
}
# oscillator OUT NAME FS [OPTIONS...]: identify oscillator on NAME-est/-val, prints its seconds
oscillator() {
  local out=$1 name=$2 fs=$3
  shift 3
  "$bin" identify oscillator --data "$work/$name-est.csv" --val "$work/$name-val.csv" --fs "$fs" "$@" --out "$out" \
    2>/dev/null | top seconds | awk '{printf "%.0f", $1}'
}
# linear OUT NAME FS METHOD ORDER [DATA OPTIONS...]: a linear model (oe, zhu, backx …) of order ORDER on
# NAME-est/-val, prints its seconds
linear() {
  local out=$1 name=$2 fs=$3 method=$4 order=$5
  shift 5
  local began
  began=$(date +%s.%N)
  "$bin" identify linear --data "$work/$name-est.csv" --val "$work/$name-val.csv" --fs "$fs" "$@" --method "$method" \
    --order "$order" --out "$out" > /dev/null 2>&1
  awk -v a="$began" -v b="$(date +%s.%N)" 'BEGIN {printf "%.0f", b - a}'
}
# average OUT NAME MEMBER-KEYS...: identify average of the kept models MEMBER-KEYS, members chosen on NAME-val;
# prints the members' training seconds summed with its own
average() {
  local out=$1 name=$2
  shift 2
  local files=() total=0 began key
  for key in "$@"; do
    files+=("$models/$key.json")
    total=$(awk -v a="$total" -v b="$(cat "$models/$key.seconds")" 'BEGIN {print a + b}')
  done
  began=$(date +%s.%N)
  "$bin" identify average --models "${files[@]}" --val "$work/$name-val.csv" --out "$out" > /dev/null 2>&1
  awk -v a="$began" -v b="$(date +%s.%N)" -v t="$total" 'BEGIN {printf "%.0f", t + b - a}'
}
# fitted_start OUT NAME FS KEY: the kept ss model KEY with its initial state fitted per record (identify ss
# --start-from it --epochs 0 --initial-state fit on NAME-est/-val); prints KEY's training seconds summed with its own
fitted_start() {
  local out=$1 name=$2 fs=$3 key=$4
  local began
  began=$(date +%s.%N)
  "$bin" identify ss --data "$work/$name-est.csv" --val "$work/$name-val.csv" --fs "$fs" --start-from "$models/$key.json" \
    --epochs 0 --initial-state fit --out "$out" > /dev/null 2>&1
  awk -v a="$began" -v b="$(date +%s.%N)" -v t="$(cat "$models/$key.seconds")" 'BEGIN {printf "%.0f", t + b - a}'
}
# fit KEY TRAINER ARGS...: $models/KEY.json, trained by TRAINER with it as OUT unless it is kept already;
# prints the training seconds (KEY.seconds), or fails the row when it is missing and TRAIN=0
fit() {
  local key=$1 trainer=$2
  shift 2
  if [ ! -f "$models/$key.json" ]; then
    [ "$train" = 0 ] && return 1
    echo "benchmark_table: training $key" >&2
    "$trainer" "$models/$key.json" "$@" > "$models/$key.seconds"
  fi
  cat "$models/$key.seconds" 2>/dev/null || echo "?"
}
# rmse MODEL TEST FS INIT SCALE [DATA OPTIONS...]: the test RMSE times SCALE (units)
rmse() {
  local model=$1 test=$2 fs=$3 init=$4 scale=$5
  shift 5
  "$bin" validate --model "$model" --data "$test" --fs "$fs" --init "$init" "$@" 2>/dev/null | top rmse |
    awk -v s="$scale" '{printf "%.3g", $1 * s}'
}
# row BENCHMARK TEST-SET MODEL-TEXT KEY TEST FS INIT SCALE UNIT PUBLISHED TRAINER ARGS... (TEST options after --)
row() {
  local bench=$1 set=$2 text=$3 key=$4 test=$5 fs=$6 init=$7 scale=$8 unit=$9 published=${10} trainer=${11}
  shift 11
  local train_args=() test_args=()
  while [ $# -gt 0 ] && [ "$1" != -- ]; do train_args+=("$1"); shift; done
  [ $# -gt 0 ] && shift
  test_args=("$@")
  local s
  if ! s=$(fit "$key" "$trainer" "${train_args[@]}"); then
    echo "| $bench | $set | $text | $init | not trained | $published | – |"
    return
  fi
  echo "| $bench | $set | $text | $init | $(rmse "$models/$key.json" "$test" "$fs" "$init" "$scale" "${test_args[@]}") $unit | $published | $s |"
}

echo "| benchmark | test set | model | init | test RMSE | best published | train s |"
echo "|---|---|---|---:|---:|---:|---:|"

sb=$data/silverbox/splits
fs_sb=610.3515625
split "$sb/train_val_multisine.csv" 52000 sb
wh=$data/wiener_hammerstein_2009/splits
split "$wh/train.csv" 80000 wh
sb_published=(multisine:"0.264 mV (SS-encoder nx=8, its own validation part)" arrow_full:"0.26 mV (PNLSS)"
  arrow_no_extrapolation:"0.307 mV (SS-encoder nx=8)")
for t in "${sb_published[@]}"; do
  set_name=$(echo "${t%%:*}" | tr _ ' ')
  row Silverbox "$set_name" "NARX 6-6-20" sb-narx "$sb/test_${t%%:*}.csv" $fs_sb 50 1000 mV "${t#*:}" \
    narx sb $fs_sb 6 6 20
  row Silverbox "$set_name" "SS nx=4, 20 nodes, polished" sb-ss "$sb/test_${t%%:*}.csv" $fs_sb 50 1000 mV "${t#*:}" \
    ss sb $fs_sb 4 20 20 100 --polish-iter 2000 --polish-window 200
  row Silverbox "$set_name" "PNLSS nx=2, degree 3" sb-pnlss "$sb/test_${t%%:*}.csv" $fs_sb 50 1000 mV "${t#*:}" \
    ss sb $fs_sb 2 0 20 100 --poly-degree 3 --polish-iter 2000 --polish-window 500
  row Silverbox "$set_name" "PNLSS nx=2, degree 3, states-only monomials" sb-pnlss-x "$sb/test_${t%%:*}.csv" $fs_sb 50 1000 mV \
    "${t#*:}" ss sb $fs_sb 2 0 20 100 --poly-degree 3 --poly-states-only --polish-iter 2000 --polish-window 500
  row Silverbox "$set_name" "Oscillator: Duffing + 6 terms, 8+8 taps" sb-oscillator "$sb/test_${t%%:*}.csv" $fs_sb 50 1000 mV \
    "${t#*:}" oscillator sb $fs_sb --terms y3,v_log_v,y_v,v2,y_v2,y_abs_y,v_y2 --output-taps 8 --input-taps 8
done

row "Wiener–Hammerstein 2009" test "NARX 10-10-20" wh-narx "$wh/test.csv" 51200 50 1000 mV "0.241 mV (SUBNET nx=6)" \
  narx wh 51200 10 10 20
row "Wiener–Hammerstein 2009" test "SS nx=6, 20 nodes, 50 lags" wh-ss "$wh/test.csv" 51200 50 1000 mV "0.241 mV (SUBNET nx=6)" \
  ss wh 51200 6 20 50 100 --polish-iter 2000 --polish-window 200
row "Wiener–Hammerstein 2009" test "SS nx=6 from a Wiener–Hammerstein start, 20 nodes, 50 lags" wh-block "$wh/test.csv" 51200 50 \
  1000 mV "0.241 mV (SUBNET nx=6)" ss wh 51200 6 20 50 100 --wiener-hammerstein --wh-iter 1000 --epochs 0
row "Wiener–Hammerstein 2009" test "SS nx=6 from a Wiener–Hammerstein start, 10 nodes, 50 lags" wh-block10 "$wh/test.csv" 51200 \
  50 1000 mV "0.241 mV (SUBNET nx=6)" ss wh 51200 6 10 50 100 --wiener-hammerstein --wh-iter 1000 --epochs 0
# kept: wh-block10 polished by L-BFGS on whole-record windows in four runs (2000 + 3000 + 5000 + 5000 iterations,
# docs/identification.md); retrained, in one run (stopped at 2·SS_SECONDS)
row "Wiener–Hammerstein 2009" test "SS nx=6 from a Wiener–Hammerstein start, 10 nodes, 50 lags, whole-record polish" \
  wh-block10-polish "$wh/test.csv" 51200 50 1000 mV "0.241 mV (SUBNET nx=6)" ss wh 51200 6 10 50 100 --wiener-hammerstein \
  --wh-iter 1000 --epochs 0 --polish-iter 15000 --polish-window 79950

# The members of an average (identify average): block models from other starts — today's OE start with 12 or 15
# nodes, and Zhu's linear model (order 6, its input delay estimated, 0 or 2; order 7) with 10, 15 or 20 nodes; each
# alone no better, their errors partly independent of the OE start's. The average's members are chosen on the
# validation part.
fit wh-lin-zhu linear wh 51200 zhu 6 > /dev/null || true
fit wh-lin-zhu0 linear wh 51200 zhu 6 --delay 0 > /dev/null || true
fit wh-lin-zhu2 linear wh 51200 zhu 6 --delay 2 > /dev/null || true
fit wh-lin-zhu7 linear wh 51200 zhu 7 > /dev/null || true
for member in "12 wh-block12" "15 wh-block15"; do
  read -r nodes key <<< "$member"
  row "Wiener–Hammerstein 2009" test "SS nx=6 from a Wiener–Hammerstein start, $nodes nodes, 50 lags" "$key" "$wh/test.csv" \
    51200 50 1000 mV "0.241 mV (SUBNET nx=6)" ss wh 51200 6 "$nodes" 50 100 --wiener-hammerstein --wh-iter 1000 --epochs 0
done
for member in "zhu10 wh-lin-zhu 6 10" "zhu15 wh-lin-zhu 6 15" "zhu20 wh-lin-zhu 6 20" "zhu0-10 wh-lin-zhu0 6 10" \
  "zhu2-10 wh-lin-zhu2 6 10" "zhu7-10 wh-lin-zhu7 7 10" "zhu7-15 wh-lin-zhu7 7 15"; do
  read -r key start nx nodes <<< "$member"
  row "Wiener–Hammerstein 2009" test "SS nx=$nx from a Wiener–Hammerstein start of $start, $nodes nodes, 50 lags" "wh-$key" \
    "$wh/test.csv" 51200 50 1000 mV "0.241 mV (SUBNET nx=6)" ss wh 51200 "$nx" "$nodes" 50 100 --linear "$models/$start.json" \
    --wiener-hammerstein --wh-iter 600 --epochs 0
done
row "Wiener–Hammerstein 2009" test "average of the block models above, members chosen by J_val (identify average)" wh-average \
  "$wh/test.csv" 51200 50 1000 mV "0.241 mV (SUBNET nx=6)" average wh wh-block wh-block10 wh-block10-polish wh-block12 \
  wh-block15 wh-zhu10 wh-zhu15 wh-zhu20 wh-zhu0-10 wh-zhu2-10 wh-zhu7-10 wh-zhu7-15
# The same models with the initial state fitted per record through the model (--initial-state fit) instead of
# the encoder's: the first 50 measured outputs set x(0) against the prior of the model's states.
row "Wiener–Hammerstein 2009" test "SS nx=6, Wiener–Hammerstein start, whole-record polish; initial state fitted" \
  wh-block10-polish-fit "$wh/test.csv" 51200 50 1000 mV "0.241 mV (SUBNET nx=6)" fitted_start wh 51200 wh-block10-polish
row "Wiener–Hammerstein 2009" test "the average above; initial state fitted" wh-average-fit "$wh/test.csv" 51200 50 1000 mV \
  "0.241 mV (SUBNET nx=6)" fitted_start wh 51200 wh-average

# cascaded tanks: estimation rows [0, 700) of uEst/yEst, validation [700, 1024) (as Champneys et al. 2024)
ct=$data/cascaded_tanks/dataBenchmark.csv
split "$ct" 700 ct
row "Cascaded tanks" uVal/yVal "NARX 2-2-5" ct-narx "$ct" 0.25 50 1 V "0.191 V (grey box)" \
  narx ct 0.25 2 2 5 --input-col uEst --output-col yEst -- --input-col uVal --output-col yVal
row "Cascaded tanks" uVal/yVal "SS nx=3, 20 nodes, 10 lags, polished" ct-ss "$ct" 0.25 50 1 V "0.191 V (grey box)" \
  ss ct 0.25 3 20 10 100 --batch 4 --epochs 2000 --polish-iter 2000 --polish-window 300 --input-col uEst --output-col yEst \
  -- --input-col uVal --output-col yVal

# EMPS: u = vir, y = qm; estimation rows [0, 20000) of DATA_EMPS, validation the rest; test DATA_EMPS_PULSES
em=$data/emps
split "$em/DATA_EMPS.csv" 20000 em
row EMPS DATA_EMPS_PULSES "NARX 2-2-10" em-narx "$em/DATA_EMPS_PULSES.csv" 1000 20 1000 mm "2.64 mm (dynoNet)" \
  narx em 1000 2 2 10 --input-col vir --output-col qm -- --input-col vir --output-col qm
row EMPS DATA_EMPS_PULSES "OE order 2 (linear)" em-oe "$em/DATA_EMPS_PULSES.csv" 1000 20 1000 mm "2.64 mm (dynoNet)" \
  linear em 1000 oe 2 --input-col vir --output-col qm -- --input-col vir --output-col qm
row EMPS DATA_EMPS_PULSES "SS nx=2, 10 nodes, 20 lags, polished" em-ss "$em/DATA_EMPS_PULSES.csv" 1000 20 1000 mm "2.64 mm (dynoNet)" \
  ss em 1000 2 10 20 200 --lr 1e-4 --epochs 300 --polish-iter 1000 --polish-window 1000 --input-col vir --output-col qm \
  -- --input-col vir --output-col qm

# Fine steering mirror (3 piezo inputs, 3 displacement outputs, periodic multisines in steady state): a linear MIMO
# state space (`identify mimo`: circular FIR, Kung's realisation, Levenberg–Marquardt on the steady-state simulation
# error), per amplitude level and on all three together; the last training realization of every file held out for
# selection. Test RMSE by the baseline notebook's protocol (merijnfloren/fsm-benchmark-data,
# baseline_results/analyze_models.ipynb): per realization the two periods in sequence after a 1000-sample
# periodic warm-up, the RMSE of each output, realization and period over its samples 100..8191, averaged.
fsm=$data/fine_steering_mirror
for level in 100mV 200mV 300mV; do
  for split in train test; do zcat "$fsm/fsm_${level}_$split.csv.gz" > "$work/fsm-$level-$split.csv"; done
done
# mimo OUT ORDER TAPS ITERATIONS LEVEL...: identify mimo on the LEVELs' training files, prints its seconds
mimo() {
  local out=$1 order=$2 taps=$3 iterations=$4
  shift 4
  local files=()
  for level in "$@"; do files+=(--data "$work/fsm-$level-train.csv"); done
  "$bin" identify mimo "${files[@]}" --fs 6400 --order "$order" --taps "$taps" --max-iter "$iterations" \
    --val-realizations 1 --out "$out" 2>/dev/null | top seconds | awk '{printf "%.0f", $1}'
}
fsm_published=(100mV:"0.114 µm (BLA of 100 mV); NL-LFR 0.0866" 200mV:"0.216 µm (BLA of 200 mV); NL-LFR 0.131"
  300mV:"0.228 µm (BLA of 300 mV); NL-LFR 0.169")
for t in "${fsm_published[@]}"; do
  level=${t%%:*}
  row "Fine steering mirror" "$level" "linear MIMO state space n=52, fitted on $level" "fsm-$level" \
    "$work/fsm-$level-test.csv" 6400 100 1e6 µm "${t#*:}" mimo 52 150 40 "$level" -- --warmup 1000
done
fsm_single=(100mV:"0.252 µm (single BLA); NL-LFR 0.0866" 200mV:"0.179 µm (single BLA); NL-LFR 0.131"
  300mV:"0.658 µm (single BLA); NL-LFR 0.169")
for t in "${fsm_single[@]}"; do
  level=${t%%:*}
  row "Fine steering mirror" "$level" "linear MIMO state space n=52, fitted on all three levels" fsm-all \
    "$work/fsm-$level-test.csv" 6400 100 1e6 µm "${t#*:}" mimo 52 150 20 100mV 200mV 300mV -- --warmup 1000
done

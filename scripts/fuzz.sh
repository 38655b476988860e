#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/) with clang in build-fuzz and runs each for a set time on a scratch
# copy of its seed corpus (the committed corpus in fuzz/corpus/ is never grown), then prints one row per
# target: executions, exec/s, coverage (cov: edges, ft: features, from libFuzzer's final stats), crashes
# (crash, leak, out-of-memory, or an input slower than 30 s), and slow inputs (over 10 s: a warning).
#
#   bash scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET ...]    (default 600 s; targets: csv wav model_json
#                                                              chain_json plant_json http record_upload; default all)
# Environment: FUZZ_JOBS build parallelism (2), FUZZ_PARALLEL targets run at once (1),
#              FUZZ_WORK scratch folder (a new one under /tmp), FUZZ_BUILD build folder (build-fuzz),
#              FUZZ_CONFIGURE=0 to use FUZZ_BUILD as it is configured (scripts/sanitize.sh's clang build).
# Exit 0: no crash; 1: a crash, hang, leak or out-of-memory input (its file is printed); 2: bad usage.
set -euo pipefail

seconds=${1:-600}
if ! [[ $seconds =~ ^[0-9]+$ ]] || (( seconds < 1 )); then
  echo "usage: bash scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET ...]" >&2
  exit 2
fi
shift || true
all_targets=(csv wav model_json chain_json plant_json http record_upload)
targets=("$@")
(( ${#targets[@]} )) || targets=("${all_targets[@]}")

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
# Absolute: the targets run from their own scratch folders.
build=$(realpath -m "${FUZZ_BUILD:-$root/build-fuzz}")
jobs=${FUZZ_JOBS:-2}
parallel=${FUZZ_PARALLEL:-1}
work=${FUZZ_WORK:-$(mktemp -d /tmp/panelbass-fuzz.XXXXXX)}
# The targets' temporary files (inputs written for the file readers, the HTTP target's store), in memory.
shm=$([[ -d /dev/shm ]] && echo /dev/shm || echo /tmp)
export PANELBASS_FUZZ_TMP=$(mktemp -d "$shm/panelbass-fuzz.XXXXXX")
trap 'rm -rf "$PANELBASS_FUZZ_TMP"' EXIT

for t in "${targets[@]}"; do
  [[ -d $root/fuzz/corpus/$t && -f $root/fuzz/${t}_fuzz.cpp ]] || { echo "fuzz.sh: no target \"$t\"" >&2; exit 2; }
done

echo "== configure and build ($build)" >&2
if [[ ${FUZZ_CONFIGURE:-1} != 0 ]]; then
  bash "$root/scripts/install_packages.sh" clang libclang-rt-14-dev
  CC=clang CXX=clang++ cmake -S "$root" -B "$build" -DPANELBASS_FUZZ=ON -DPANELBASS_FUZZ_COVERAGE=ON -DBUILD_TESTING=OFF \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
fi
cmake --build "$build" -j "$jobs" --target "${targets[@]/%/_fuzz}" >&2

# Runs one target in $work/<target>: corpus/ (the scratch copy), artifacts/, log.
run_target() {
  local t=$1 dir=$work/$1
  rm -rf "$dir"
  mkdir -p "$dir/corpus" "$dir/artifacts"
  cp -r "$root/fuzz/corpus/$t/." "$dir/corpus/"
  local status=0
  (cd "$dir" && "$build/bin/${t}_fuzz" -max_total_time="$seconds" -print_final_stats=1 -timeout=30 \
     -rss_limit_mb=4096 -artifact_prefix="$dir/artifacts/" corpus >"$dir/log" 2>&1) || status=$?
  echo "$status" >"$dir/status"
}

echo "== run ${#targets[@]} target(s) × ${seconds} s in $work (${parallel} at a time)" >&2
running=0
for t in "${targets[@]}"; do
  echo "   $t …" >&2
  run_target "$t" &
  running=$((running + 1))
  if (( running >= parallel )); then wait -n || true; running=$((running - 1)); fi
done
wait

# The table, from each log's final stats and its last status line ("#N DONE cov: X ft: Y corp: …").
failed=()
printf '%-11s %8s %12s %8s %7s %8s %10s %8s %6s\n' target seconds executions exec/s cov ft corpus crashes slow
for t in "${targets[@]}"; do
  dir=$work/$t log=$work/$t/log
  stat() { sed -n "s/^stat::$1: *//p" "$log" | tail -1; }
  last=$(grep -E '^#[0-9]+.*cov: ' "$log" | tail -1 || true)
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$last")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$last")
  corp=$(sed -n 's/.* corp: \([0-9]*\/[0-9a-zA-Z]*\).*/\1/p' <<<"$last")
  mapfile -t found < <(find "$dir/artifacts" -type f \( -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' -o -name 'oom-*' \) | sort)
  status=$(cat "$dir/status")
  crashes=${#found[@]}
  if (( crashes == 0 && status != 0 )); then crashes=1; found=("$log (exit $status, no artifact)"); fi
  slow=$(find "$dir/artifacts" -type f -name 'slow-unit-*' | wc -l)
  printf '%-11s %8s %12s %8s %7s %8s %10s %8s %6s\n' "$t" "$seconds" "$(stat number_of_executed_units)" \
    "$(stat average_exec_per_sec)" "${cov:--}" "${ft:--}" "${corp:--}" "$crashes" "$slow"
  why=$(grep -m1 -E '^SUMMARY: |^[a-z_]+_fuzz: |runtime error: ' "$log" | cut -c1-200 || true)
  for f in "${found[@]}"; do failed+=("$t: $f${why:+ ($why)}"); done
done

if (( ${#failed[@]} )); then
  echo "== CRASHES (reproduce: $build/bin/<target>_fuzz FILE; logs in $work/<target>/log)" >&2
  printf '   %s\n' "${failed[@]}" >&2
  exit 1
fi
echo "== no crashes; logs in $work" >&2

#!/usr/bin/env bash
# The detection bench of issue #35's "Done when": every effect of the vocabulary at its concealed size (the effect
# below the sensor noise in the raw residual spectrum), SEEDS seeds each, the look-alike pairs included; first
# from the drive and the acceleration alone, then with the coil current (the force channel) for the effects
# that look alike from the drive; and the scenario with no effect (false positives), without and with the
# current. Runs niced, JOBS processes side by side; prints the tables and the time taken.
# Usage: bash bench/diagnosis_detection.sh [BUILD_DIR] [SEEDS] [JOBS] [PLAIN]   (defaults: build 6 2 20)
# PANELBASS_WORK=DIR keeps each run's table and log in DIR (read them while it runs); otherwise a temporary folder.
# N_EST / N_VAL set the records' lengths (defaults 60000 / 40000 samples, the tests' concealed scenarios).
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/diagnosis_common.sh
diagnosis_setup "${1:-build}" 60000 40000
seeds=${2:-6}
jobs=${3:-2}
plain=${4:-20}

# One process per effect (and channel set), JOBS at a time: the look-alikes with and without the current and the
# effect-free runs first, then the rest of the vocabulary.
runs=()
for e in $look_alikes; do runs+=("current $e" "drive $e"); done
runs+=("plain none" "plaincurrent none")
for e in $all; do
  case " $look_alikes " in *" $e "*) ;; *) runs+=("drive $e") ;; esac
done
printf '%s\n' "${runs[@]}" | xargs -P "$jobs" -I{} bash -c '
  set -- {}
  out="'"$work"'/$1-$2"
  if [ "$1" = plain ]; then
    nice -n 15 "'"$bin"'" --seeds 1 --effects dc_offset --sizes 1 --plain '"$plain"' '"$lengths"' > "$out.md" 2> "$out.log"
  elif [ "$1" = plaincurrent ]; then
    nice -n 15 "'"$bin"'" --seeds 0 --plain '"$plain"' --current '"$lengths"' > "$out.md" 2> "$out.log"
  elif [ "$1" = current ]; then
    nice -n 15 "'"$bin"'" --seeds '"$seeds"' --sizes 1 --effects "$2" --plain 0 --current '"$lengths"' > "$out.md" 2> "$out.log"
  else
    nice -n 15 "'"$bin"'" --seeds '"$seeds"' --sizes 1 --effects "$2" --plain 0 '"$lengths"' > "$out.md" 2> "$out.log"
  fi'

table() {  # table CHANNEL EFFECTS...: the rows of each effect's run, then the totals
  local channel=$1; shift
  local first=1
  for e in "$@"; do
    f="$work/$channel-$e.md"
    if [ $first = 1 ]; then sed -n '/^| effect/,/^|---/p' "$f"; first=0; fi
    grep "^| $e " "$f" || echo "| $e | (failed: see the log) |"
  done
  python3 - "$work" "$channel" "$@" <<'PY'
import re, sys
work, channel, effects = sys.argv[1], sys.argv[2], sys.argv[3:]
right = amb = wrong_clear = wrong_named = runs = 0
for e in effects:
    text = open(f"{work}/{channel}-{e}.md").read()
    m = re.search(r"right first: (\d+)/(\d+); right, or ambiguous naming the right one: (\d+)/", text)
    w = re.search(r"\(a wrong first name called clear\): (\d+)/\d+; a wrong name not called ambiguous: (\d+)/", text)
    if not m or not w: continue
    right += int(m[1]); runs += int(m[2]); amb += int(m[3]); wrong_clear += int(w[1]); wrong_named += int(w[2])
if runs:
    pct = lambda k: f"{k}/{runs} ({100.0 * k / runs:.1f} %)"
    print(f"\nright first: {pct(right)}; right, or ambiguous naming the right one: {pct(amb)}; "
          f"wrong and clear: {pct(wrong_clear)}; wrong, not called ambiguous: {pct(wrong_named)}")
PY
}

echo "## diagnose detection: drive and acceleration ($seeds seeds per effect, concealed size, ${N_EST:-60000} + ${N_VAL:-40000} samples)"
echo
table drive $all
echo
echo "## with the coil current (the force channel): the effects that look alike from the drive"
echo
table current $look_alikes
echo
echo "drive alone: $(grep "false positives" "$work/plain-none.md")"
echo "with the current: $(grep "false positives" "$work/plaincurrent-none.md")"
echo
echo "time: $(( $(date +%s) - start )) s wall, $jobs processes, niced"

#!/usr/bin/env bash
# The detection bench on one family of plants (issue 58): every effect of the vocabulary at its concealed size,
# SEEDS seeds each, from the drive and the acceleration; the look-alikes again with the coil current; and the
# family's effect-free records (the second family's: pink sensor noise, other converters, an L2R2 branch, and a
# microphone 3.4 samples behind on every other seed); and issue 58's three look-alike pairs at once. Prints the
# confusion matrix — true effect down, first finding
# across, "none" included both ways — for each channel set. Runs niced, JOBS processes side by side.
# Usage: bash bench/diagnosis_family.sh [BUILD_DIR] [FAMILY] [SEEDS] [JOBS] [PLAIN]   (defaults: build second 3 2 6)
# N_EST / N_VAL set the records' lengths (defaults 30000 / 20000); PANELBASS_WORK=DIR keeps each run's output
# (PANELBASS_MERGE_ONLY=1 then reprints the tables from it without running anything).
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/diagnosis_common.sh
diagnosis_setup "${1:-build}" 30000 20000
family=${2:-second}
seeds=${3:-3}
jobs=${4:-2}
plain=${5:-6}

pairs="asymmetric_force_factor+asymmetric_stiffness,nonlinear_damping+hysteresis,cubic_stiffness+force_factor"
runs=("drive none" "current none" "drive pairs" "current pairs")
for e in $all; do runs+=("drive $e"); done
for e in $look_alikes; do runs+=("current $e"); done
# PANELBASS_MERGE_ONLY=1 with PANELBASS_WORK: print the tables of the runs already in that folder.
[ -n "${PANELBASS_MERGE_ONLY:-}" ] || printf '%s\n' "${runs[@]}" | xargs -P "$jobs" -I{} bash -c '
  set -- {}
  out="'"$work"'/$1-$2"
  flag=""; [ "$1" = current ] && flag=--current
  if [ "$2" = pairs ]; then
    nice -n 15 "'"$bin"'" --family '"$family"' --seeds '"$seeds"' --plain 0 --pairs '"$pairs"' $flag '"$lengths"' > "'"$work"'/pairs-$1.md" 2> "$out.log"
  elif [ "$2" = none ]; then
    nice -n 15 "'"$bin"'" --family '"$family"' --seeds 0 --plain '"$plain"' $flag '"$lengths"' > "$out.md" 2> "$out.log"
  else
    nice -n 15 "'"$bin"'" --family '"$family"' --seeds '"$seeds"' --sizes 1 --effects "$2" --plain 0 $flag '"$lengths"' > "$out.md" 2> "$out.log"
  fi'

matrix() {  # matrix CHANNEL: the confusion rows of every run of that channel set, merged into one matrix
  python3 - "$work" "$1" <<'PY'
import glob, re, sys
from collections import defaultdict
work, channel = sys.argv[1], sys.argv[2]
rows = defaultdict(lambda: defaultdict(int))
later = defaultdict(lambda: defaultdict(int))  # findings after the first
named = 0  # right first, or ambiguous with the right one as its runner-up (the bench's own count)
for path in sorted(glob.glob(f"{work}/{channel}-*.md")):
    text = open(path).read()
    m = re.search(r"right, or ambiguous naming the right one: (\d+)/", text)
    named += int(m[1]) if m else 0
    part = text.split("## confusion", 1)
    if len(part) < 2:
        print(f"({path}: no confusion table — see its log)")
        continue
    long_form = part[1].split("| true \\ first", 1)[0]  # the long form only, not the matrix after it
    firsts, _, laters = long_form.partition("## later findings")
    for m in re.finditer(r"^\| (\S+) \| ([^|]+?) \| (\d+) \|$", firsts, re.M):
        rows[m[1]][m[2]] += int(m[3])
    for m in re.finditer(r"^\| (\S+) \| ([^|]+?) \| (\d+) \|$", laters, re.M):
        later[m[1]][m[2]] += int(m[3])
truths = sorted(rows, key=lambda t: (t.startswith("none"), t))
columns = sorted({f.split(" ")[0] for r in rows.values() for f in r}, key=lambda c: (c == "none", c))
print("| true \\ first | " + " | ".join(columns) + " | words of the first findings | later findings |")
print("|---|" + "---:|" * len(columns) + "---|---|")
right = amb = wrong_clear = wrong = total = 0
for t in truths:
    r = rows[t]
    n = lambda c: sum(v for f, v in r.items() if f.split(" ")[0] == c)
    words = ", ".join(f"{f} {v}" for f, v in sorted(r.items()))
    afterwards = ", ".join(f"{f} {v}" for f, v in sorted(later[t].items()))
    print(f"| {t} | " + " | ".join(str(n(c)) if n(c) else "" for c in columns) + f" | {words} | {afterwards} |")
    if t.startswith("none"):
        continue
    for f, v in r.items():
        name = f.split(" ")[0]
        total += v
        right += v if name == t else 0
        wrong_clear += v if name not in (t, "none") and "(clear)" in f else 0
        wrong += v if name not in (t, "none") and "(ambiguous)" not in f else 0
none_runs = sum(sum(rows[t].values()) for t in truths if t.startswith("none"))
none_findings = sum(v for t in truths if t.startswith("none") for f, v in rows[t].items() if f != "none")
later_clear = sum(v for t in truths for f, v in later[t].items() if "(clear)" in f and not f.startswith(t + " "))
print(f"\nfindings after the first called clear: {later_clear}")
print(f"right first: {right}/{total}; right, or ambiguous naming it: {named}/{total}; a wrong first name called clear: {wrong_clear}/{total}; "
      f"a wrong first name not called ambiguous: {wrong}/{total}; a finding on an effect-free record: {none_findings}/{none_runs}")
PY
}

echo "## diagnose detection on the $family family: drive and acceleration ($seeds seeds per effect, concealed size, ${N_EST:-30000} + ${N_VAL:-20000} samples)"
echo
matrix drive
echo
echo "## with the coil current: the look-alikes and the effect-free records"
echo
matrix current
echo
echo "## look-alike pairs at once (issue 58's three): both found, from the drive and with the current"
for c in drive current; do
  echo
  echo "$c:"
  echo
  sed -n '/^| pair/,/^$/p' "$work/pairs-$c.md" 2>/dev/null || echo "(no pairs run)"
done
echo
echo "time: $(( $(date +%s) - start )) s wall, $jobs processes, niced"

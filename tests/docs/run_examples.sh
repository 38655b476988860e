#!/usr/bin/env bash
# Executable documentation: runs every shell example of one Markdown page that is marked runnable (a line
# `<!-- runnable -->` right above its fence), in order, in one bash with `set -euo pipefail`, exactly as
# printed, as a new user would type them: in a fresh empty folder where `build/`, `bench/` and `scripts/`
# are the project's (so `build/bin/panelbass …` works), with its own server on a free port when the page
# starts one. A step that fails fails the test and names the page's line. Anything the page started in the
# background is stopped at the end.
#   bash tests/docs/run_examples.sh PAGE.md BUILD_DIR
set -euo pipefail
[ $# -eq 2 ] || { echo "usage: run_examples.sh PAGE.md BUILD_DIR" >&2; exit 2; }
page=$(realpath "$1")
build=$(realpath "$2")
root=$(realpath "$(dirname "$0")/../..")

work=$(mktemp -d)
script=$work/.examples.sh
cleanup() { rm -rf "$work"; }
trap cleanup EXIT
ln -s "$build" "$work/build"
ln -s "$root/bench" "$work/bench"
ln -s "$root/scripts" "$work/scripts"

# The runnable blocks, each announced with the page's line, in the page's order.
awk -v page="$(basename "$page")" '
  /^<!-- runnable -->[[:space:]]*$/ { marked = 1; next }
  marked && /^```/ && !inside { inside = 1; marked = 0; start = NR + 1
    printf "printf \"\\n## %s, line %d\\n\" >&2\n", page, start; next }
  inside && /^```[[:space:]]*$/ { inside = 0; blocks++; next }
  inside { print; next }
  { marked = 0 }
  END { if (inside) { print "run_examples: " page ": a runnable block is not closed" > "/dev/stderr"; exit 1 }
        if (!blocks) { print "run_examples: " page ": no runnable block" > "/dev/stderr"; exit 1 } }
' "$page" > "$script.body"

{
  echo 'set -euo pipefail'
  echo 'stop_background() { local p; for p in $(jobs -p); do kill "$p" 2>/dev/null; wait "$p" 2>/dev/null || true; done; }'
  echo 'trap stop_background EXIT'
  echo 'set -x'
  cat "$script.body"
} > "$script"
cd "$work"
PS4='+ ' bash "$script"
echo "run_examples: every runnable example of $(basename "$page") passed"

#!/usr/bin/env bash
# Optional check of an `panelbass analyze ... --html REPORT.html` report in a real browser.
# It is NOT part of the build or of the test suite: run it by hand (or from CI if wanted).
#
#   bash scripts/report_screenshot.sh REPORT.html [WIDTH]
#
# Opens the report in Debian's headless Chromium and
#   1. checks that the page has at least one <img> and that every one of them loaded
#      (complete and naturalWidth > 0), by loading a hidden copy of the report (next to it,
#      removed afterwards, so relative URLs resolve the same) with a small script appended
#      that writes the counts into an attribute of <html>, read back with --dump-dom;
#   2. screenshots the original report, full page, at WIDTH (default 1280) css px wide,
#      into REPORT.png next to the report (kept as an artifact).
# Prints {"images": N, "loaded": N, "screenshot": "REPORT.png"} on stdout.
# Exit 0 when all images loaded and there is at least one; 1 otherwise, with the reason on
# stderr (chromium's own log is shown only when chromium itself fails).
# Installs the Debian package chromium when missing (as root, or through sudo); no network is
# needed otherwise: the report is self-contained and chromium is started with everything that
# could reach out switched off.
set -euo pipefail

die() { echo "report_screenshot: $*" >&2; exit 1; }

[ $# -ge 1 ] && [ $# -le 2 ] || die "usage: bash scripts/report_screenshot.sh REPORT.html [WIDTH]"
report=$1
width=${2:-1280}
[ -f "$report" ] || die "no such file: $report"
case "$width" in ''|*[!0-9]*) die "WIDTH must be a number of pixels, got '$width'" ;; esac

# Idempotent install, as scripts/bootstrap.sh does it: touch apt only when the package is missing.
if ! dpkg-query -W -f='${Status}' chromium 2>/dev/null | grep -q 'ok installed'; then
  echo "report_screenshot: installing chromium (optional report check)" >&2
  apt_get=(apt-get); [ "$(id -u)" -eq 0 ] || apt_get=(sudo apt-get)
  "${apt_get[@]}" update -q >&2
  DEBIAN_FRONTEND=noninteractive "${apt_get[@]}" install -y -q --no-install-recommends chromium >&2
fi
browser=/usr/bin/chromium
[ -x "$browser" ] || die "$browser not found after installing the chromium package"

dir=$(cd "$(dirname "$report")" && pwd)
name=$(basename "$report")
abs="$dir/$name"
shot="${report%.*}.png"
[ "$shot" != "$report" ] || shot="$report.png"

work=$(mktemp -d)
probe=$(mktemp "$dir/.${name%.*}.check.XXXXXX.html")
cleanup() { rm -rf "$work" "$probe"; }
trap cleanup EXIT

# file:// URL of an absolute path: percent-encode, byte by byte, what a URL may not hold.
file_url() {
  local LC_ALL=C p=$1 out='' c i
  for ((i = 0; i < ${#p}; i++)); do
    c=${p:i:1}
    case "$c" in
      [A-Za-z0-9/._~-]) out+=$c ;;
      *) out+=$(printf '%%%02X' "'$c") ;;
    esac
  done
  printf 'file://%s' "$out"
}

# Chromium with the flags that work here as root, a fresh profile each run, and a time limit.
run_chromium() {
  local profile
  profile=$(mktemp -d "$work/profile.XXXXXX")
  timeout 120 "$browser" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
    --disable-background-networking --disable-component-update --disable-sync \
    --hide-scrollbars --user-data-dir="$profile" --virtual-time-budget=5000 "$@" \
    2>>"$work/chromium.log"
}
chromium_failed() {
  echo "report_screenshot: chromium failed ($1); the end of its log:" >&2
  tail -n 20 "$work/chromium.log" >&2 || true
  exit 1
}

# 1. The check: the report plus a script that, once the page has loaded, writes
#    images=N loaded=N height=H failed=<list> into <html data-report-check="...">.
#    (Appended after </html>: the parser puts it into <body>, and it runs after the rest.)
cp "$report" "$probe"
cat >>"$probe" <<'EOF'
<script>
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images), loaded = 0, failed = [];
  imgs.forEach(function (img, k) {
    if (img.complete && img.naturalWidth > 0) { loaded++; return; }
    var what = img.alt || (img.closest('figure') && img.closest('figure').id) ||
               (img.getAttribute('src') || '').slice(0, 40);
    failed.push('#' + (k + 1) + '(' + what.replace(/[^A-Za-z0-9 _.,:\/+-]/g, '').slice(0, 60) + ')');
  });
  var d = document.documentElement, b = document.body;
  var height = Math.max(d.scrollHeight, b ? b.scrollHeight : 0);
  d.setAttribute('data-report-check', 'images=' + imgs.length + ' loaded=' + loaded +
                 ' height=' + height + ' failed=' + failed.join(' '));
});
</script>
EOF
run_chromium --window-size="$width,800" --dump-dom "$(file_url "$probe")" >"$work/dom.html" ||
  chromium_failed "loading the report for the image check"
check=$(grep -o 'data-report-check="[^"]*"' "$work/dom.html" | head -n 1 | sed 's/^data-report-check="//; s/"$//') ||
  die "the check script did not run in $report (chromium printed no result; is scripting blocked?)"
field() { sed -n "s/.*\\b$1=\\([0-9]*\\).*/\\1/p" <<<"$check"; }
images=$(field images)
loaded=$(field loaded)
height=$(field height)
failed=${check#*failed=}
[ -n "$images" ] && [ -n "$loaded" ] && [ -n "$height" ] || die "unreadable check result: '$check'"

# 2. The screenshot of the report itself, as tall as the page (capped: chromium's limit).
[ "$height" -ge 600 ] || height=600
[ "$height" -le 16000 ] || height=16000
rm -f "$shot"
run_chromium --window-size="$width,$height" --screenshot="$work/shot.png" "$(file_url "$abs")" >/dev/null ||
  chromium_failed "taking the screenshot"
[ -s "$work/shot.png" ] || chromium_failed "no screenshot was written"
mv "$work/shot.png" "$shot"

json_str() { local s=${1//\\/\\\\}; printf '"%s"' "${s//\"/\\\"}"; }
printf '{"images": %d, "loaded": %d, "screenshot": %s}\n' "$images" "$loaded" "$(json_str "$shot")"

if [ "$images" -eq 0 ]; then
  die "$report has no <img> at all (expected the analysis figures)"
fi
if [ "$loaded" -ne "$images" ]; then
  die "$((images - loaded)) of $images images in $report did not load (naturalWidth 0): $failed"
fi
exit 0

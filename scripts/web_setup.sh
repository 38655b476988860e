#!/usr/bin/env bash
# Sets up what the web UI and its browser test need (called from scripts/bootstrap.sh):
#   - Debian's chromium (the test drives /usr/bin/chromium; no browser is ever downloaded), and
#   - web/node_modules from web/package-lock.json (uPlot for the page, playwright-core for the test),
#     installed with `npm ci` only when node_modules is missing or the lock file changed since.
# Idempotent: a second run installs nothing. Needs node and npm (Debian's nodejs/npm if missing).
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(chromium)
command -v node >/dev/null 2>&1 || packages+=(nodejs)
command -v npm >/dev/null 2>&1 || packages+=(npm)
missing=()
for p in "${packages[@]}"; do
  case "$p" in
    nodejs|npm) missing+=("$p") ;;   # only listed when the command is absent
    *) dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'ok installed' || missing+=("$p") ;;
  esac
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "web_setup: installing ${missing[*]}" >&2
  apt_get=(apt-get); [ "$(id -u)" -eq 0 ] || apt_get=(sudo apt-get)
  "${apt_get[@]}" update -q
  DEBIAN_FRONTEND=noninteractive "${apt_get[@]}" install -y -q --no-install-recommends "${missing[@]}"
fi
[ -x /usr/bin/chromium ] || { echo "web_setup: /usr/bin/chromium missing after installing chromium" >&2; exit 1; }

# npm ci when node_modules is missing or was installed from another lock file (its hash is kept inside
# node_modules, so removing node_modules also forgets it).
stamp=web/node_modules/.panelbass-lock.sha256
want=$(sha256sum web/package-lock.json | cut -d' ' -f1)
if [ ! -f web/node_modules/uplot/dist/uPlot.iife.min.js ] || [ ! -d web/node_modules/playwright-core ] \
   || [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  echo "web_setup: npm ci in web/" >&2
  # PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD: playwright-core downloads nothing, but say so anyway.
  (cd web && PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --no-audit --no-fund --loglevel=error)
  echo "$want" > "$stamp"
fi

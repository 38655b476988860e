#!/usr/bin/env bash
# Sets up what the web UI and its browser test need (called from scripts/bootstrap.sh):
#   - Debian's chromium (the test drives /usr/bin/chromium; no browser is ever downloaded), and
#   - web/node_modules from web/package-lock.json (uPlot for the page, playwright-core for the test),
#     installed with `npm ci` only when node_modules is missing or the lock file changed since.
# Idempotent: a second run installs nothing. Needs node and npm (Debian's nodejs/npm if missing).
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(chromium)
# node and npm only when the commands are absent (they may come from elsewhere than Debian).
command -v node >/dev/null 2>&1 || packages+=(nodejs)
command -v npm >/dev/null 2>&1 || packages+=(npm)
bash scripts/install_packages.sh "${packages[@]}"
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

#!/usr/bin/env bash
# Sets up what the web UI and its browser test need (called from scripts/bootstrap.sh):
#   - Debian's chromium (the test drives /usr/bin/chromium; no browser is ever downloaded), and
#   - web/node_modules from web/package-lock.json (uPlot for the page; for the tests playwright-core, pinned to
#     1.61.x, the newest that runs on Debian 12's Node 18, and @seriousme/openapi-schema-validator), installed
#     with `npm ci` only when node_modules is missing or the lock file changed since, and
#   - Node 18.20.4 (Debian 12's) from the npm registry into tests/web/.node18, only when missing, for the test
#     that the set-up works on it (ctest web.ui_on_debian12_node).
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

# Debian 12's Node (18.20.4) for the check that the browser test runs on it (ctest web.ui_on_debian12_node):
# the official binary as the npm registry serves it (the package node-linux-<arch>), in tests/web/.node18, installed
# only when missing. The machine's own node may be newer, which would hide a dependency that needs Node 20.
node18_version=18.20.4
node18=tests/web/.node18/bin/node
if [ "$("$node18" --version 2>/dev/null)" != "v$node18_version" ]; then
  case "$(uname -m)" in
    x86_64) node18_arch=x64 ;;
    aarch64) node18_arch=arm64 ;;
    *) echo "web_setup: no Node $node18_version package for $(uname -m); web.ui_on_debian12_node will fail" >&2; exit 0 ;;
  esac
  echo "web_setup: Node $node18_version (npm package node-linux-$node18_arch) into tests/web/.node18" >&2
  rm -rf tests/web/.node18
  mkdir -p tests/web/.node18/bin
  npm install --prefix tests/web/.node18 --no-save --no-package-lock --no-audit --no-fund --loglevel=error \
    "node-linux-$node18_arch@$node18_version"
  ln -sf "../node_modules/node-linux-$node18_arch/bin/node" "$node18"
  [ "$("$node18" --version)" = "v$node18_version" ] || { echo "web_setup: $node18 is not Node $node18_version" >&2; exit 1; }
fi

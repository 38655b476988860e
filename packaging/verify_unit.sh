#!/usr/bin/env bash
# `systemd-analyze verify` on the configured unit file ($1), its ExecStart pointed at the built binary ($2)
# so that the check does not depend on an installed copy. Exit 77 (ctest: skipped) without systemd-analyze.
set -euo pipefail
unit=$1 binary=$2
command -v systemd-analyze >/dev/null 2>&1 || { echo "systemd-analyze missing: skipped"; exit 77; }
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
sed "s|^ExecStart=[^ ]*/panelbass |ExecStart=$binary |" "$unit" > "$dir/panelbass.service"
grep -q "^ExecStart=$binary --config .* serve " "$dir/panelbass.service" || { echo "ExecStart not found in $unit" >&2; exit 1; }
# verify prints warnings and errors; any output about our unit is a failure.
out=$(SYSTEMD_LOG_LEVEL=warning systemd-analyze verify "$dir/panelbass.service" 2>&1 || echo "exit status $?")
echo "$out"
if echo "$out" | grep -q "panelbass.service\|exit status"; then exit 1; fi
echo "systemd-analyze verify: panelbass.service is valid"

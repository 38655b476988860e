#!/usr/bin/env bash
# Which physics makes the distortion at each probe: a chain evaluated on a virtual transducer, then on
# copies of it with one nonlinear element left on at a time (every other element and the linear part
# unchanged). Each row's THD and harmonics are what that element alone adds at the probe's drive.
#   1. panelbass plant show PLANT → the full configuration
#   2. for the plant and each enabled element: a copy with only that element on → evaluate --chain
#   3. a table per probe: THD % and H2 / H3 / H4 dB of the chain's row, per element
# The probes' drives are the chain's (the same in every row), so the rows are comparable.
# Usage: bash bench/probe_physics.sh CHAIN.json [PLANT] [PROBE_PEAK] [ROW]
#   PLANT defaults to panel-exciter; PROBE_PEAK (default 0.6) as in evaluate --probe-peak; ROW is the
#   evaluation row to show (default: the chain's last, e.g. band-pass + feedforward + feedback).
#   PANELBASS_BIN overrides the binary.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=$(realpath "${PANELBASS_BIN:-build/bin/panelbass}")
chain=$(realpath "${1:?usage: bash bench/probe_physics.sh CHAIN.json [PLANT] [PROBE_PEAK] [ROW]}")
plant=${2:-panel-exciter}
peak=${3:-0.6}
row=${4:--1}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

"$bin" plant show "$plant" > "$work/plant.json"
elements=$(python3 - "$work" <<'EOF'
import json, sys
work = sys.argv[1]
plant = json.load(open(work + "/plant.json"))
enabled = [name for name, e in plant["nonlinear"].items() if e.get("enabled")]
for name in enabled:
    only = json.loads(json.dumps(plant))
    for other in only["nonlinear"]:
        only["nonlinear"][other]["enabled"] = other == name
    only["name"] = plant["name"] + " (only " + name + ")"
    json.dump(only, open(f"{work}/only-{name}.json", "w"), indent=1)
print(" ".join(enabled))
EOF
)
"$bin" evaluate --plant "$work/plant.json" --chain "$chain" --probe-peak "$peak" --out "$work/eval-all.json" > /dev/null 2>&1
for e in $elements; do
  "$bin" evaluate --plant "$work/only-$e.json" --chain "$chain" --probe-peak "$peak" --out "$work/eval-$e.json" > /dev/null 2>&1
done
python3 - "$work" "$row" "$elements" <<'EOF'
import json, sys
work, row, elements = sys.argv[1], int(sys.argv[2]), sys.argv[3].split()
def probes(name):
    e = json.load(open(f"{work}/eval-{name}.json"))
    return e["rows"][row]["name"], e["rows"][row]["probes"]
label, whole = probes("all")
print(f"row: {label}")
print("%-14s" % "element" + "".join("| %-30s" % ("%g Hz (drive %.3f)" % (p["frequency_hz"], p["drive_peak"])) for p in whole))
def line(name, ps):
    cells = []
    for p in ps:
        h = p["harmonics_db"] + [float("-inf")] * 3
        cells.append("| THD %6.3f %%  H2/H3/H4 %4.0f/%4.0f/%4.0f" % (p["thd_pct"], h[0], h[1], h[2]))
    print("%-14s" % name + "".join(cells))
line("all", whole)
for name in elements:
    line(name, probes(name)[1])
EOF

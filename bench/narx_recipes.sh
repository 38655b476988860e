#!/usr/bin/env bash
# Issue 59: panelbass's NARX training against PyTorch's multiple-shooting recipe, side by side in one run per
# record. panelbass: the recipes of `identify narx` in PB_RECIPES (below; `;` between recipes) through
# build/bin/narx_recipe_bench, which logs the validation J of every iteration with its second; PyTorch:
# bench/peers/narx_torch.py --recipe ms (series-parallel Adam warm start, then multiple-shooting L-BFGS), time-boxed to PEER_BUDGET seconds. Both
# judge by the same J — [2A] on the validation part, the first 50 measured outputs setting the state, then free
# run (identify narx's --init 50 protocol) — on the same split and scaling, and both train on one core (torch
# with one thread); their clocks leave out process start, data loading and the torch import. Each record's two
# runs follow one another, so the machine's load (shared: say so with the figures) falls on both alike.
#
# Records: the panel exciter (`simulate --plant panel-exciter --signal noise --amplitude 1 --samples 10000
# --seed 11`, 5000 + 5000, NARX 17-17-1 with na = nb = 8) at the preset's sensor noise (0.07 V rms) and at
# 0.01 V; the thesis's second-order point A = 0.99 ([5Q], uniform white noise, 5000 + 5000, NN 3-5-1:
# na = 2, nb = 0); Silverbox (rows 0..15000 of splits/train_val_multisine: 10000 + 5000, NARX 4-4-15).
# "Reaches" a J = first logged J_val ≤ 1.05 × that J.
#
# Usage: bash bench/narx_recipes.sh [RECORD...]   (exciter-noise exciter-low a099 silverbox; default all)
#   env: PEER_BUDGET=120 seconds for the whole peer recipe, PB_RECIPES="--train …; --train …" (flags of
#        narx_recipe_bench, as identify narx's; its --weight-decay defaults to the library's 0, not the CLI's 0.01,
#        so the recipes name theirs; its --pem-min-progress is the library's and the CLI's 0.1, --pem-min-progress 0
#        turns the rule off; --evidence-decay all|oem re-estimates the decay every LM iteration, or pem's excepted, from
#        --weight-decay on),
#        PANELBASS_DATA=../shared/data, PYTHON=/usr/bin/python3, NARX_WORK=DIR (keep the records, RECORD.csv,
#        and the logs, RECORD-pbI.csv per recipe I and RECORD-peer.csv, there instead of a temporary folder)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/bin/panelbass
bench=build/bin/narx_recipe_bench
python=${PYTHON:-/usr/bin/python3}
budget=${PEER_BUDGET:-120}
data=${PANELBASS_DATA:-../shared/data}
recipes=${PB_RECIPES:-"--train pem,oem-d --weight-decay 0.01; --train pem,oem-d --weight-decay 0.01 --evidence-decay all; --train pem,oem-d --weight-decay 0.01 --evidence-decay oem; --train pem,oem-ms,oem-d --weight-decay 0.01 --evidence-decay all"}
IFS=';' read -r -a recipe_list <<< "$recipes"
if [[ -n ${NARX_WORK:-} ]]; then  # keep the records and the per-iteration logs there
  work=$NARX_WORK; mkdir -p "$work"
else
  work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
fi

for b in "$bin" "$bench"; do [[ -x $b ]] || { echo "narx_recipes: $b not found; build it first" >&2; exit 1; }; done
if ! "$python" -c 'import torch' 2>/dev/null || ! command -v jq >/dev/null; then
  echo "narx_recipes: installing python3-torch and jq with apt-get (bench only)" >&2
  if [[ $(id -u) -ne 0 ]] || ! { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-torch jq; } >&2; then
    echo "narx_recipes: cannot install python3-torch/jq; as root run: apt-get install -y python3-torch jq" >&2
    exit 1
  fi
fi

make_record() {  # make_record NAME: $work/NAME.csv (u,y; estimation rows first)
  case $1 in
    exciter-noise)
      $bin simulate --plant panel-exciter --signal noise --amplitude 1 --samples 10000 --seed 11 --out "$work/$1.csv" >/dev/null 2>&1 ;;
    exciter-low)
      $bin plant show panel-exciter | jq '.sensor.noise_rms_V = 0.01' > "$work/low-plant.json"
      $bin simulate --plant "$work/low-plant.json" --signal noise --amplitude 1 --samples 10000 --seed 11 --out "$work/$1.csv" >/dev/null 2>&1 ;;
    a099)  # [5Q]: poles 0.99·e^{±j23°}, b such that max |y| = 1
      "$python" - "$work/$1.csv" <<'PY'
import math, sys
import numpy as np
u = np.random.default_rng(7).uniform(-1, 1, 10000)
c, a2, y = 2 * 0.99 * math.cos(math.radians(23)), 0.99 ** 2, np.zeros(10000)
for k in range(10000):
    y[k] = u[k] + (c * y[k - 1] if k >= 1 else 0) - (a2 * y[k - 2] if k >= 2 else 0)
y /= np.abs(y).max()
with open(sys.argv[1], "w") as f:
    f.write("u,y\n" + "".join(f"{a!r},{b!r}\n" for a, b in zip(u, y)))
PY
      ;;
    silverbox) head -n 15001 "$data/silverbox/splits/train_val_multisine.csv" > "$work/$1.csv" ;;
    *) echo "narx_recipes: unknown record $1" >&2; exit 2 ;;
  esac
}

shape() {  # shape NAME: est-rows fs na nb hidden
  case $1 in
    exciter-*) echo "5000 3000 8 8 17" ;;
    a099) echo "5000 1 2 0 5" ;;
    silverbox) echo "10000 610.3515625 4 4 15" ;;
  esac
}

echo "| record | panelbass recipe | panelbass best J_val % (s to it) | PyTorch best J_val % (s to it) | panelbass s to PyTorch's best | PyTorch s to panelbass's best | PyTorch's time to its best ÷ panelbass's time to it |"
echo "|---|---|---:|---:|---:|---:|---:|"
records=("$@")
[[ ${#records[@]} -gt 0 ]] || records=(exciter-noise exciter-low a099 silverbox)
for r in "${records[@]}"; do
  make_record "$r"
  read -r est fs na nb hidden <<< "$(shape "$r")"
  for i in "${!recipe_list[@]}"; do
    # shellcheck disable=SC2086  # a recipe is a list of flags
    $bench --data "$work/$r.csv" --fs "$fs" --est-rows "$est" --na "$na" --nb "$nb" --hidden "$hidden" --seed 1 \
      --max-iter 200 ${recipe_list[$i]} --name "$i" --out "$work/$r-pb$i.csv" > /dev/null 2> "$work/$r-pb$i.err"
  done
  "$python" bench/peers/narx_torch.py --data "$work/$r.csv" --est-rows "$est" --na "$na" --nb "$nb" --hidden "$hidden" \
    --seed 1 --recipe ms --init 50 --budget "$budget" --out "$work/$r-peer.csv" 2> "$work/$r-peer.err" \
    || { cat "$work/$r-peer.err" >&2; echo "narx_recipes: the peer failed on $r" >&2; exit 1; }
  for i in "${!recipe_list[@]}"; do
  "$python" - "$r" "$work/$r-pb$i.csv" "$work/$r-peer.csv" "${recipe_list[$i]}" <<'PY'
import csv, math, sys
def log(path):
    rows = [(float(r["seconds"]), float(r["J_val_pct"])) for r in csv.DictReader(open(path))]
    return [(t, j) for t, j in rows if math.isfinite(j)]
def first(rows, level):
    return next((t for t, j in rows if j <= 1.05 * level), None)
name, pb, peer = sys.argv[1], log(sys.argv[2]), log(sys.argv[3])
pb_best, peer_best = min(j for _, j in pb), min(j for _, j in peer)
pb_best_t = next(t for t, j in pb if j == pb_best)
peer_best_t = next(t for t, j in peer if j == peer_best)
pb_to_peer, peer_to_pb = first(pb, peer_best), first(peer, pb_best)
fmt = lambda t: "never" if t is None else f"{t:.2f}"
ratio = "—" if pb_to_peer is None else f"{peer_best_t / pb_to_peer:.1f}"
print(f"| {name} | `{sys.argv[4].strip()}` | {pb_best:.4g} ({pb_best_t:.2f}) | {peer_best:.4g} ({peer_best_t:.2f}) | {fmt(pb_to_peer)} | "
      f"{fmt(peer_to_pb)} | {ratio} |")
PY
  done
done
echo
echo "panelbass: narx_recipe_bench --seed 1 --max-iter 200 RECIPE; PyTorch: narx_torch.py --recipe ms --init 50 --budget $budget --seed 1."
echo "s = seconds of each tool's own training clock; reached = J_val ≤ 1.05 × the J named. Machine load during the run: $(cut -d' ' -f1-3 /proc/loadavg)."

#!/usr/bin/env bash
# Speed against a peer: NN 17-17-1 NARX (na = nb = 8) on the simulated panel exciter, panelbass (pem then
# oem-d, Levenberg–Marquardt) against PyTorch (bench/peers/narx_torch.py: PEM warm start, then BPTT
# output-error training with Adam and LBFGS), compared by the wall time to reach the same validation J.
#
# J is the training history's: [2A] on the validation half, free run from rest, k ≥ 2(na+nb) = 32 (the
# peer computes the same; its --check-model line shows it on panelbass's model). The target is panelbass's
# final validation J in that sense (the kept model's, i.e. the history's minimum); a tool "reaches" it when
# its validation J first gets within 5 %: J_val ≤ 1.05·target. Times are training clocks (process start,
# data loading and the torch import left out). panelbass logs no per-iteration time, so its time to the
# target is interpolated: the pem phase's seconds come from a pem-only run (the same deterministic
# trajectory), and each mode's seconds are spread evenly over its iterations. panelbass figures are the
# median of 3 runs; the peer runs once (each optimizer time-boxed to PEER_BUDGET seconds).
#
# Needs PyTorch for Debian's python3 (not a dependency of the build or tests): installed here with
# apt-get (python3-torch, and jq) if missing; fails with a message if it cannot.
# Usage: bash bench/narx_speed.sh   (env: PEER_BUDGET=600 seconds per peer optimizer, PYTHON=/usr/bin/python3)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/bin/panelbass
python=${PYTHON:-/usr/bin/python3}
budget=${PEER_BUDGET:-600}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

[[ -x $bin ]] || { echo "narx_speed: $bin not found; build first (see README)" >&2; exit 1; }
if ! "$python" -c 'import torch' 2>/dev/null || ! command -v jq >/dev/null; then
  echo "narx_speed: installing python3-torch and jq with apt-get (bench only)" >&2
  if [[ $(id -u) -ne 0 ]] || ! { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-torch jq; } >&2; then
    echo "narx_speed: cannot install python3-torch/jq; as root run: apt-get install -y python3-torch jq" >&2
    exit 1
  fi
  "$python" -c 'import torch' || { echo "narx_speed: $python still cannot import torch" >&2; exit 1; }
fi

$bin simulate --plant panel-exciter --signal noise --amplitude 1 --samples 10000 --seed 11 --out "$work/n.csv" >/dev/null 2>&1
head -n 5001 "$work/n.csv" > "$work/est.csv"
{ head -n 1 "$work/n.csv"; tail -n +5002 "$work/n.csv"; } > "$work/val.csv"

train() {  # train MODES RUN: panelbass NN 17-17-1 into $work/RUN.json (its printed JSON), $work/RUN-history.json and $work/RUN.wall
  local start end
  start=$(date +%s.%N)
  $bin identify narx --data "$work/est.csv" --val "$work/val.csv" --fs 3000 --na 8 --nb 8 --hidden 17 \
    --train "$1" --optimizer lm --max-iter 100 --seed 1 --out "$work/$2-model.json" --history "$work/$2-history.json" \
    > "$work/$2.json" 2>/dev/null
  end=$(date +%s.%N)
  calc "$end - $start" > "$work/$2.wall"
}
calc() { awk "BEGIN { print $1 }"; }
median() { sort -g | awk '{v[NR] = $1} END {print v[int((NR + 1) / 2)]}'; }

for r in 1 2 3; do train pem,oem-d full$r; train pem pem$r; done
seconds=$(for r in 1 2 3; do jq .seconds "$work/full$r.json"; done | median)
wall=$(cat "$work"/full[123].wall | median)
pem_seconds=$(for r in 1 2 3; do jq .seconds "$work/pem$r.json"; done | median)
full=$work/full1.json
history=$work/full1-history.json
iterations=$(jq .iterations "$full")
pem_iterations=$(jq '[.history[] | select(.mode == "pem" and .iter > 0)] | length' "$history")
target=$(jq '[.history[].J_val_pct] | min' "$history")
threshold=$(calc "1.05 * $target")
hit=$(jq --argjson t "$threshold" '[.history[] | select(.J_val_pct <= $t) | .iter] | min' "$history")
# Seconds at iteration `hit`: pem iterations share the pem run's seconds, oem-d ones the rest.
pb_time=$(awk -v k="$hit" -v kp="$pem_iterations" -v n="$iterations" -v tp="$pem_seconds" -v t="$seconds" \
  'BEGIN { print (k <= kp) ? tp * k / kp : tp + (t - tp) * (k - kp) / (n - kp) }')

"$python" bench/peers/narx_torch.py --data "$work/n.csv" --est-rows 5000 --na 8 --nb 8 --hidden 17 --seed 1 \
  --budget "$budget" --target "$threshold" --check-model "$work/full1-model.json" --out "$work/peer.csv" 2> "$work/peer.err" \
  || { cat "$work/peer.err" >&2; echo "narx_speed: the peer failed" >&2; exit 1; }

echo "## NARX NN 17-17-1 (na = nb = 8, 324 parameters), panel exciter, noise, 5000 + 5000 samples"
echo "Target: panelbass final J_val = $(printf %.4f "$target") % (from rest, k ≥ 32); reached = J_val ≤ $(printf %.4f "$threshold") %."
echo "panelbass J_val with the first 50 measured outputs setting the state (its top-level figure): $(jq '.J_val_pct * 10000 | round / 10000' "$full") %."
echo "Peer check, panelbass's model through the peer's code: $(sed -n 's/^check: .*: \(J_val [^ ]* %\).*/\1/p' "$work/peer.err")."
echo
echo "| tool | training | iterations | seconds | ms / iteration | best J_val % | first J_val ≤ target+5 % | ratio to panelbass |"
echo "|---|---|---:|---:|---:|---:|---:|---:|"
printf '| panelbass | pem %d + oem-d %d, LM | %d | %.2f (process %.2f) | %.1f | %.4f | %.2f s (iteration %d) | 1 |\n' \
  "$pem_iterations" $((iterations - pem_iterations)) "$iterations" "$seconds" "$wall" \
  "$(calc "1000 * $seconds / $iterations")" "$target" "$pb_time" "$hit"
pem_row=$(awk -F, '$1 == "pem" { n = $2; t = $3; if (best == "" || $4 + 0 < best + 0) best = $4 } END { print n, t, best }' "$work/peer.csv")
read -r peer_pem_iterations peer_pem_seconds peer_pem_best <<< "$pem_row"
printf '| PyTorch | pem warm start (LBFGS, series-parallel) | %d | %.2f | %.1f | %.4f | shared by the rows below | |\n' \
  "$peer_pem_iterations" "$peer_pem_seconds" "$(calc "1000 * $peer_pem_seconds / $peer_pem_iterations")" "$peer_pem_best"
# One row per peer OEM run: epochs, seconds (PEM included), ms per epoch (OEM only), best J and when, first hit.
awk -F, -v thr="$threshold" -v pb="$pb_time" -v pem="$peer_pem_seconds" '
  NR > 1 && $1 != "pem" {
    if (!($1 in seen)) { seen[$1] = 1; order[++runs] = $1; best[$1] = $4; best_t[$1] = $3 }
    epochs[$1] = $2; secs[$1] = $3
    if ($4 + 0 < best[$1] + 0) { best[$1] = $4; best_t[$1] = $3 }
    if (!($1 in hit) && $4 + 0 <= thr + 0) { hit[$1] = $3; hit_epoch[$1] = $2 }
  }
  END {
    for (i = 1; i <= runs; i++) {
      r = order[i]
      first = (r in hit) ? sprintf("%.2f s (epoch %d)", hit[r], hit_epoch[r]) : sprintf("never (best at %.1f s)", best_t[r])
      ratio = (r in hit) ? sprintf("%.1f", hit[r] / pb) : sprintf("> %.1f", secs[r] / pb)
      printf "| PyTorch | pem + oem, %s, BPTT | %d | %.2f | %.1f | %.4f | %s | %s |\n", r, epochs[r], secs[r],
             epochs[r] ? 1000 * (secs[r] - pem) / epochs[r] : 0, best[r], first, ratio
      if ((r in hit) && (fastest == "" || hit[r] < hit[fastest])) fastest = r
      if (lowest == "" || best[r] + 0 < best[lowest] + 0) lowest = r
    }
    if (fastest != "") summary = sprintf("Ratio, best peer optimizer (%s): %.1f (%.2f s against %.2f s).", fastest, hit[fastest] / pb, hit[fastest], pb)
    else summary = sprintf("The peer never reached the target: its best J_val %.4f %% (%s, at %.1f s, PEM included).", best[lowest], lowest, best_t[lowest])
    print summary > summary_file
  }' summary_file="$work/summary" "$work/peer.csv"
echo
cat "$work/summary"
echo "Ratio = the peer's seconds to first J_val ≤ target+5 % over panelbass's (best peer optimizer: the smallest);"
echo "\"> x\" = never reached within the peer's run (time box ${budget} s per optimizer, or 200 epochs without improvement)."
echo "Peer run log:"; sed 's/^/  /' "$work/peer.err"

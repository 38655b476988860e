#!/usr/bin/env bash
# Issue #36's reproduction of model selection on a badly damped system: y(k) = 2·0.99·cos 23°·y(k−1)
# − 0.99²·y(k−2) + u(k) (poles 0.99·e^{±j23°}), u uniform white noise in ±1, output scaled to peak 1 plus
# Gaussian noise of σ = 0.05 % of the peak; 3000 estimation samples, the next 2000 validation (so the
# validation record starts mid-stream); NN na = 2, nb = 0, 5 hidden, pem then oem-d by LM, 200 iterations.
# Prints the noise floor (J of the noise-free output on the validation part, from sample 50) and
# `validate --init 50`'s J_sim with and without --val.
# Usage: bash bench/selection_repro.sh [SEED]   (default 1: the seed of the input and of the noise)
#   EXTRA="--restarts 3" adds options to both trainings (--restarts needs --val, so it goes to the first only).
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${PANELBASS_BIN:-build/bin/panelbass}
seed=${1:-1}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# the record: u, y (noisy), y0 (noise-free); awk's generator seeded, the noise by Box–Muller
awk -v seed="$seed" 'BEGIN {
  srand(seed); pi = atan2(0, -1); c = 2 * 0.99 * cos(23 * pi / 180); a2 = 0.99 * 0.99; n = 5000
  for (k = 0; k < n; k++) {
    u[k] = 2 * rand() - 1
    y[k] = u[k] + (k >= 1 ? c * y[k - 1] : 0) - (k >= 2 ? a2 * y[k - 2] : 0)
    if (y[k] > peak) peak = y[k]; if (-y[k] > peak) peak = -y[k]
  }
  print "u,y,y0"
  for (k = 0; k < n; k++) {
    e = sqrt(-2 * log(1 - rand())) * cos(2 * pi * rand())
    printf "%.17g,%.17g,%.17g\n", u[k], y[k] / peak + 5e-4 * e, y[k] / peak
  }
}' > "$work/all.csv"
head -n 3001 "$work/all.csv" > "$work/est.csv"
{ head -n 1 "$work/all.csv"; tail -n 2000 "$work/all.csv"; } > "$work/val.csv"

floor=$(tail -n +52 "$work/val.csv" | awk -F, '{ e += ($3 - $2)^2; s += $2^2 } END { printf "%.3g", 100 * e / s }')
j_sim() { sed -n 's/.*"J_sim_pct": \([-0-9.e+]*\).*/\1/p' | awk '{printf "%.3g", $1}'; }
extra=${EXTRA:-}
train() {
  "$bin" identify narx --data "$work/est.csv" "$@" --fs 1000 --na 2 --nb 0 --hidden 5 --train pem,oem-d \
    --optimizer lm --max-iter 200 --seed 1 --out "$work/nn.json" 2>/dev/null > "$work/out.json"
  echo "$(sed -n 's/^  "seconds": \([-0-9.e+]*\).*/\1/p' "$work/out.json" | awk '{printf "%.1f", $1}')"
}
echo "noise floor (J of the noise-free output, validation k >= 50): $floor %"
# shellcheck disable=SC2086
secs=$(train --val "$work/val.csv" $extra)
echo "with --val:    J_sim (validate --init 50) $("$bin" validate --model "$work/nn.json" --data "$work/val.csv" --fs 1000 --init 50 2>/dev/null | j_sim) %, $secs s"
secs=$(train)
echo "without --val: J_sim (validate --init 50) $("$bin" validate --model "$work/nn.json" --data "$work/val.csv" --fs 1000 --init 50 2>/dev/null | j_sim) %, $secs s"

#!/usr/bin/env bash
# Builds the peer experiment bench/peers/silverbox_ct_duffing.cpp and fits its continuous-time Duffing model to the
# Silverbox benchmark in five warm-started stages (about 2 minutes, one core); each stage prints est / val /
# multisine / arrow no extrapolation / arrow full RMSE in mV (the last line: the model of docs/identification.md).
# Usage: bash bench/peers/silverbox_ct_duffing.sh [WORK_DIR]   (default: a temporary folder, kept and printed)
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
work=${1:-$(mktemp -d)}
mkdir -p "$work"
cd "$work"
g++ -O2 -std=c++20 -I/usr/include/eigen3 -o duff "$root/bench/peers/silverbox_ct_duffing.cpp"
export SILVERBOX_DIR=$root/../shared/data/silverbox/
B=(nice -n 10 ./duff --hold sinc --N 4 --delay)
"${B[@]}" --vlog --tag r1_vlog --save r1.txt
"${B[@]}" --vlog --poly --init r1.txt --tag r2_poly --save r2.txt
"${B[@]}" --vlog --poly --kyay --init r2.txt --tag r3_kyay --save r3.txt
"${B[@]}" --vlog --poly --kyay --cvy2 --init r3.txt --tag r4_cvy2 --save r4.txt
"${B[@]}" --vlog --poly --kyay --cvy2 --M 8 --L 8 --init r4.txt --tag r5_M8L8 --save r5.txt
echo "silverbox_ct_duffing: models and simulated arrows in $work" >&2

#!/usr/bin/env bash
# Sets panelbass up on a Debian 12 machine (as root), builds it in Release, then runs
#   run   `panelbass serve` on the embedded virtual transducer: the API and the web UI at
#         http://127.0.0.1:8080/, with an excitation, identification and LQ design at start-up, or
#   test  the whole test suite (ctest, in parallel; the browser test included), or
#   setup only the packages and the web UI's set-up, nothing built (CI installs everything first).
# Idempotent: packages already installed are not touched, and the build is incremental.
set -euo pipefail
cd "$(dirname "$0")/.."

usage() { echo "usage: bash scripts/bootstrap.sh run|test|setup" >&2; exit 2; }
[ $# -eq 1 ] || usage
case "$1" in run|test|setup) ;; *) usage ;; esac

packages=(
  build-essential clang cmake ninja-build pkg-config
  libeigen3-dev nlohmann-json3-dev libcli11-dev libsndfile1-dev liblbfgs-dev
  libgtest-dev libasound2-dev libcpp-httplib-dev libsamplerate0-dev
  gnuplot-nox
  jackd2 libasound2-plugins libjack-jackd2-dev
  curl jq
  prometheus  # promtool: tests/api/promtool_test.cpp checks GET /metrics with it
  systemd     # systemd-analyze: ctest packaging.unit_verify checks the service's unit with it
  libsoxr-dev # bench/rate_bridge_bench: libsoxr's streaming hold-back beside the bridge's own converters
)
bash scripts/install_packages.sh "${packages[@]}"

# The web UI's packages (npm) and Debian's Chromium for the browser test.
bash scripts/web_setup.sh
[ "$1" = setup ] && exit 0

jobs=$(nproc)
# A new build folder gets Ninja (it keeps both cores busy across targets: a fresh Release build took 8 min 53 s
# with Ninja against about 11 min with Make here) and clang (Debian 12's clang 14 compiles the Release build in
# 1576 CPU s against GCC 12's 1921, docs/development.md; the sanitizer builds use it too); a folder configured
# before keeps both.
new_folder=(); [ -f build/CMakeCache.txt ] || new_folder=(-G Ninja -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++)
cmake -S . -B build "${new_folder[@]}" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$jobs"

case "$1" in
  run)
    echo "bootstrap: starting panelbass serve (Ctrl-C to stop); open the address it prints" >&2
    exec build/bin/panelbass serve --store build/store
    ;;
  test)
    ctest --test-dir build --output-on-failure -j"$jobs"
    ;;
esac

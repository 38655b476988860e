#!/usr/bin/env bash
# The engine tests under AddressSanitizer + UBSan (the real-time path's memory and undefined-behaviour
# check that CI runs after the main tests): configures build-asan (-O1 without debug info, to keep the instrumented Eigen code quick to compile; PANELBASS_SANITIZE=ON),
# builds engine_tests only, and runs them with ctest. Any sanitizer report fails the test that caused it.
set -euo pipefail
cd "$(dirname "$0")/.."

jobs=$(nproc)
started=$(date +%s)
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=Sanitize -DCMAKE_CXX_FLAGS_SANITIZE="-O1" -DPANELBASS_SANITIZE=ON >/dev/null
cmake --build build-asan -j"$jobs" --target engine_tests
built=$(date +%s)

# halt_on_error: a UBSan finding fails the test instead of scrolling past; leaks are reported at exit.
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# Only engine_tests is built: ctest's placeholders for the other layers' executables are left out.
ctest --test-dir build-asan --output-on-failure -j2 -E '_NOT_BUILT$'
finished=$(date +%s)
echo "sanitize: build $((built - started)) s, tests $((finished - built)) s" >&2

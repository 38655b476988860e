#!/usr/bin/env python3
"""Sets two builds' engine_bench figures side by side: the table of issue #33 with the old and the new.

Runs OLD and NEW engine_bench binaries alternately (so a shared machine's load falls on both alike),
ROUNDS times each, keeps each figure's best (lowest) over the rounds, and prints a markdown table of the
median-block figures of engine_bench's tables.

Example (the old build: this bench compiled against main's libraries, see docs/engine.md):
  bench/engine_compare.py --old /tmp/engine_bench_main --new build/bin/engine_bench --seconds 10 --rounds 3
"""
import argparse
import subprocess
import sys


# The figures compared, each the median column of the engine_bench table row whose name starts so. Read from
# the tables rather than the summary line: a build whose table gained rows (whose summary indices went
# stale, as main's did when the mirror filter row was added) still compares like for like.
ROWS = {
    "band_pass_stage": "band-pass stage alone",
    "band_pass": "band-pass (Butterworth",
    "full_chain": "+ NARX feedback, model mode",
    "device48_bridge": "48 kHz: decimate → identity",
    "device48_full": "48 kHz: decimate → full chain (model mode)",
}


def summary(binary, seconds, runs):
    """The figures of one engine_bench run (ROWS' medians, the bridge's latency in ms), as a dict of floats."""
    out = subprocess.run([binary, str(seconds), str(runs)], check=True, capture_output=True, text=True).stdout
    figures = {}
    for line in out.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        for key, prefix in ROWS.items():
            if key not in figures and cells[0].startswith(prefix):
                figures[key] = float(cells[1])
                if key == "device48_bridge":
                    figures["latency48_ms"] = float(cells[-1].split("(")[1].split()[0])
    missing = [k for k in ROWS if k not in figures]
    if missing:
        sys.exit(f"{binary}: no table row for {', '.join(ROWS[k] for k in missing)}")
    return figures


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--old", required=True, help="engine_bench of the old build")
    parser.add_argument("--new", required=True, help="engine_bench of the new build")
    parser.add_argument("--seconds", type=float, default=10.0, help="seconds of audio per run (default 10)")
    parser.add_argument("--runs", type=int, default=3, help="runs per figure inside engine_bench (default 3)")
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds of the two binaries (default 3)")
    args = parser.parse_args()
    best = {"old": {}, "new": {}}
    for _ in range(args.rounds):
        for name in ("old", "new"):
            for key, value in summary(getattr(args, name), args.seconds, args.runs).items():
                best[name][key] = min(value, best[name].get(key, value))
    old, new = best["old"], best["new"]

    def rtf(ns, rate):
        return 1e9 / (rate * ns)

    rows = [
        ("full chain at 3000 Hz (band-pass, 8th-order feedforward, NARX 17-17-1 feedback, limiter), ns/sample",
         old["full_chain"], new["full_chain"], 3000.0, "≤ 100 ns/sample"),
        ("band-pass alone in the chain (Butterworth 2 + 2, the chain's slots and limiter around it), ns/sample",
         old["band_pass"], new["band_pass"], 3000.0, "a few ns"),
        ("band-pass stage alone (its two second-order sections, no chain), ns/sample",
         old["band_pass_stage"], new["band_pass_stage"], 3000.0, "a few ns"),
        ("48 kHz device path, 64-frame periods: decimate → full chain → interpolate, ns/frame",
         old["device48_full"], new["device48_full"], 48000.0, "≥ 500× real time"),
        ("the rate bridge alone at 48 kHz, ns/frame",
         old["device48_bridge"], new["device48_bridge"], 48000.0, "(item 1 of the issue)"),
    ]
    print(f"engine_bench {args.seconds:g} {args.runs}, {args.rounds} alternating rounds, best of all; "
          "median block (period) times\n")
    print("| path | old | new | goal |")
    print("|---|---|---|---|")
    for name, o, n, rate, goal in rows:
        print(f"| {name} | {o:.1f} ({rtf(o, rate):.0f}×) | {n:.1f} ({rtf(n, rate):.0f}×) | {goal} |")
    print(f"\nadded resampling latency at 48 kHz: old {old['latency48_ms']:.2f} ms, new {new['latency48_ms']:.2f} ms")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Reads `panelbass harmonics --data REC --model M` results (JSON objects, one after another) on stdin and
prints, per fundamental, the recording's and the model's harmonics H2.. (level in dB and phase in degrees,
against the fundamental) and how much of the recording's distortion a canceller designed on the model would
remove: `cancellable_db` from the complex difference of the harmonics, and beside it the levels-only bound
`cancellable_magnitude_db` (harmonics right in level but wrong in phase still reach it). The last line is the
smallest cancellable_db over the fundamentals."""
import json
import sys


def db(value):
    return "inf" if value is None else f"{value:.1f}"


def cell(row, order):
    level, phase = row["harmonics"][f"H{order}_db"], row["phases"][f"H{order}_deg"]
    return "-" if level is None else f"{level:.1f}@{phase:.0f}"


decoder = json.JSONDecoder()
text, position, smallest = sys.stdin.read(), 0, []
while True:
    while position < len(text) and text[position].isspace():
        position += 1
    if position == len(text):
        break
    result, position = decoder.raw_decode(text, position)
    for rec, mod, cut in zip(result["recording_rows"], result["model_rows"], result["cancellable"]):
        orders = sorted(int(k[1:-3]) for k in rec["harmonics"])
        cells = ", ".join(f"{cell(rec, h)} / {cell(mod, h)}" for h in orders)
        print(f"  {rec['frequency_hz']:g} Hz at drive {rec['amplitude']:.4f}: H2.. recording / model dB@deg {cells};"
              f" cancellable {db(cut['cancellable_db'])} dB (levels alone <= {db(cut['cancellable_magnitude_db'])})")
    value = result["smallest_cancellable_db"]
    smallest.append(float("inf") if value is None else value)
if not smallest:
    sys.exit("harmonics_bound.py: no harmonics results on stdin")
print(f"{min(smallest):.2f}")

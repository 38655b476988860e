#!/usr/bin/env python3
"""Reads `panelbass harmonics --data REC --model M` results (JSON objects, one after another) on stdin and
prints, per fundamental, the recording's and the model's harmonics H2.. and the most a canceller designed on
the model can remove there: |H_rec - H_model| >= ||H_rec| - |H_model||, so at least
sum (|H_rec| - |H_model|)^2 of the recording's sum |H_rec|^2 is left. The last line is the smallest of those
bounds over the fundamentals, in dB."""
import json
import math
import sys

decoder = json.JSONDecoder()
text, position, bounds = sys.stdin.read(), 0, []
while True:
    while position < len(text) and text[position].isspace():
        position += 1
    if position == len(text):
        break
    result, position = decoder.raw_decode(text, position)
    for rec, mod in zip(result["recording_rows"], result["model_rows"]):
        pairs = [(rec["harmonics"][k], mod["harmonics"][k]) for k in sorted(rec["harmonics"])
                 if rec["harmonics"][k] is not None and mod["harmonics"][k] is not None]
        total = sum(10 ** (r / 10) for r, _ in pairs)
        left = sum((10 ** (r / 20) - 10 ** (m / 20)) ** 2 for r, m in pairs)
        bounds.append(10 * math.log10(total / left) if left > 0 else math.inf)
        cells = ", ".join(f"{r:.1f}/{m:.1f}" for r, m in pairs)
        print(f"  {rec['frequency_hz']:g} Hz at drive {rec['amplitude']:.4f}: H2.. recording/model dB {cells};"
              f" cancellable <= {bounds[-1]:.1f} dB")
if not bounds:
    sys.exit("harmonics_bound.py: no harmonics results on stdin")
print(f"{min(bounds):.2f}")

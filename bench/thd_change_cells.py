#!/usr/bin/env python3
"""Reads an `evaluate` result of a chain with feedback (rows: plant, band-pass + feedforward, + feedback) and
prints the table cells the control benches share: the THD change by the feedback at each probe on the
transducer, the same on the design's own plant model (what the design expected), the worst of each, and the
chain's largest drive, as `| a | b | c | d |` (dB; the caller adds the row's leading cells)."""
import json
import math
import sys

rows = json.load(open(sys.argv[1]))["rows"]


def change(key):
    return [20 * math.log10(c[key] / b[key]) for b, c in zip(rows[1]["probes"], rows[2]["probes"])]


real, model = change("thd_pct"), change("model_thd_pct")
cells = lambda d: " / ".join(f"{x:+.1f}" for x in d)
print(f" {cells(real)} | {cells(model)} | {max(real):+.1f} / {max(model):+.1f} | {rows[2]['max_drive']:.3f} |")

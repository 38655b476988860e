#!/usr/bin/env python3
"""Issue #36: where in a test record a free run's error lies. RMSE of y_sim − y over consecutive segments.

Usage: python3 bench/sim_segment_rmse.py SIM.csv B0 B1 ... Bn
SIM.csv is what `panelbass validate --model M.json --data DATA --init B0 --sim-out SIM.csv` writes; prints the
RMSE over [B0, B1), [B1, B2) … [B(n-1), Bn) and over [B0, Bn), in the data's units ×1000 (mV for volts).
Standard library only.
"""
import math
import sys

from mean_of_free_runs import columns


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    y, sim = columns(sys.argv[1])
    bounds = [int(b) for b in sys.argv[2:]]
    if bounds != sorted(set(bounds)) or bounds[0] < 0 or bounds[-1] > len(y):
        sys.exit(f"sim_segment_rmse: bounds must increase within [0, {len(y)}], got {bounds}")
    segments = list(zip(bounds, bounds[1:])) + [(bounds[0], bounds[-1])]
    for a, b in segments:
        rmse = math.sqrt(sum((sim[k] - y[k]) ** 2 for k in range(a, b)) / (b - a))
        print(f"[{a}, {b}): {1000 * rmse:.3f}")


if __name__ == "__main__":
    main()

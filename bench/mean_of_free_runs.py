#!/usr/bin/env python3
"""Issue #36: would averaging models' free runs beat the best of them? A measurement, not a model kind.

Usage: python3 bench/mean_of_free_runs.py INIT SIM.csv [SIM.csv ...]
Each SIM.csv is what `panelbass validate --model M.json --data DATA --init INIT --sim-out SIM.csv` writes for one
model (any kind) on the same data: columns u, y, y_sim. Prints each file's [2A] J of y_sim over k >= INIT (the
J_sim that validate printed), then the J of the mean of those free runs. Standard library only.
"""
import csv
import sys


def columns(path):
    """The measured output and the free run of one --sim-out file."""
    rows = list(csv.DictReader(open(path)))
    if not rows or "y_sim" not in rows[0]:
        sys.exit(f"mean_of_free_runs: {path}: expected the columns of validate --sim-out (u, y, y_sim, y_pred)")
    return [float(r["y"]) for r in rows], [float(r["y_sim"]) for r in rows]


def j_percent(y_model, y, start):
    """[2A] J = sum (y_model - y)^2 / sum y^2 over k >= start, in percent."""
    return 100.0 * sum((a - b) ** 2 for a, b in zip(y_model[start:], y[start:])) / sum(v * v for v in y[start:])


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    init = int(sys.argv[1])
    y, runs = None, []
    for path in sys.argv[2:]:
        measured, sim = columns(path)
        if y is not None and measured != y:
            sys.exit(f"mean_of_free_runs: {path}: its measured y differs from {sys.argv[2]}'s: not the same data")
        y = measured
        runs.append(sim)
        print(f"{path}: J {j_percent(sim, y, init):.4f} %")
    mean = [sum(values) / len(values) for values in zip(*runs)]
    print(f"mean of {len(runs)} free runs: J {j_percent(mean, y, init):.4f} %")


if __name__ == "__main__":
    main()

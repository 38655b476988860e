#!/usr/bin/env python3
"""Issue #36: would averaging NARX models' free runs beat the best of them? A measurement, not a model kind.

Usage: python3 bench/narx_mean.py DATA.csv INIT MODEL.json [MODEL.json ...]
Prints, for each NARX model file (one hidden tanh layer, as `identify narx --hidden N` writes), the [2A] J of
its free run on DATA (columns u, y; the first INIT measured outputs set the state, as `validate --init`),
then the J of the mean of those free runs. Each model's figure equals `validate --init INIT`'s J_sim (the
check that this re-implementation of the model's simulation, [5G]/[5H] and fig. 5.6, is the same model).
Standard library only; about 3 s per model and 5000 samples.
"""
import csv
import json
import math
import sys


def load(path):
    """A NARX model file's structure, weights and scaling."""
    m = json.load(open(path))
    if m.get("kind") != "narx":
        sys.exit(f"narx_mean: {path}: expected a NARX model file, got kind {m.get('kind')!r}")
    p = m["params"]
    if len(p["hidden"]) != 1:
        sys.exit(f"narx_mean: {path}: only one hidden layer is supported, got {p['hidden']}")
    return p["na"], p["nb"], p["nk"], p["hidden"][0], p["theta"], m["scaling"]


def simulate(model, u, y, init):
    """[5H] free run ŷ(k) = F(ŷ(k−1..k−na), u(k−nk..k−nk−nb)) in raw units; ŷ(k) = y(k) for k < init."""
    na, nb, nk, hidden, theta, s = model
    inputs = na + nb + 1
    us = [(v - s["u_offset"]) / s["u_scale"] for v in u]
    out = [(v - s["y_offset"]) / s["y_scale"] for v in y[:init]] + [0.0] * (len(u) - init)
    w = [theta[h * inputs:(h + 1) * inputs] for h in range(hidden)]  # row-major hidden × inputs
    b = theta[hidden * inputs:hidden * (inputs + 1)]
    w_out = theta[hidden * (inputs + 1):hidden * (inputs + 2)]
    b_out = theta[hidden * (inputs + 2)]
    for k in range(init, len(u)):
        # [5G] x = [ŷ(k−1)..ŷ(k−na), u(k−nk)..u(k−nk−nb)], samples before the record 0
        x = [out[k - 1 - i] if k - 1 - i >= 0 else 0.0 for i in range(na)]
        x += [us[k - nk - j] if k - nk - j >= 0 else 0.0 for j in range(nb + 1)]
        # fig. 5.6: F = w_out·tanh(W·x + b) + b_out
        out[k] = sum(w_out[h] * math.tanh(sum(wi * xi for wi, xi in zip(w[h], x)) + b[h]) for h in range(hidden)) + b_out
    return [v * s["y_scale"] + s["y_offset"] for v in out]


def j_percent(y_model, y, start):
    """[2A] J = Σ(ŷ − y)² / Σ y² over k ≥ start, in percent."""
    return 100.0 * sum((a - b) ** 2 for a, b in zip(y_model[start:], y[start:])) / sum(v * v for v in y[start:])


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    rows = list(csv.DictReader(open(sys.argv[1])))
    u = [float(r["u"]) for r in rows]
    y = [float(r["y"]) for r in rows]
    init = int(sys.argv[2])
    runs = []
    for path in sys.argv[3:]:
        runs.append(simulate(load(path), u, y, init))
        print(f"{path}: J {j_percent(runs[-1], y, init):.4f} %")
    mean = [sum(values) / len(values) for values in zip(*runs)]
    print(f"mean of {len(runs)} free runs: J {j_percent(mean, y, init):.4f} %")


if __name__ == "__main__":
    main()

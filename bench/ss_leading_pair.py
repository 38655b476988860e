#!/usr/bin/env python3
"""Eigenvalues of the leading 2×2 block of an ss model's A (what `--poly-states 2` makes nonlinear):
magnitude and frequency in Hz. Usage: python3 bench/ss_leading_pair.py MODEL.json ..."""
import cmath
import json
import math
import sys

for path in sys.argv[1:]:
    model = json.load(open(path))
    n, theta = model["params"]["states"], model["params"]["theta"]
    # θ starts with A, column-major
    a00, a10, a01, a11 = theta[0], theta[1], theta[n], theta[n + 1]
    trace, det = a00 + a11, a00 * a11 - a01 * a10
    root = cmath.sqrt(trace * trace / 4 - det)
    poles = [trace / 2 + root, trace / 2 - root]
    print(path, "nx", n, "; ".join("|%.4f| %.1f Hz" % (abs(p), abs(cmath.phase(p)) * model["fs"] / (2 * math.pi)) for p in poles))

#!/usr/bin/python3
"""An independent computation of kcrig's K&C sheet figures with NumPy.

Usage: kc_gradients_numpy.py RUN.CSV KC.CSV

Reads the run log (CSV and its JSON sidecar) with the csv and json modules,
segments it from the sidecar's excitation times (rising ramp [0, tf],
falling return [tf + hold, end]), fits with numpy.linalg.lstsq:
  - a common gradient with one intercept per branch, whose difference is
    the loop width at zero force,
  - one line per branch,
computes ordinary least squares' standard errors and the loop area (the
trapezoid rule, -closed integral of r df over rising, falling and back),
and compares each with the rows
of kcrig's kc.csv for this log. Prints the largest relative difference and
exits 1 when it exceeds 1e-9.
"""
import csv
import json
import math
import pathlib
import sys

import numpy as np

CHANNELS = ["x", "y", "z", "toe", "camber", "caster"]


def display(channel):
    """SI -> display (mm, deg)."""
    return 1e3 if channel < 3 else 180.0 / math.pi


def read_log(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    sidecar = json.loads(pathlib.Path(path).with_suffix(".json").read_text())
    return rows, sidecar


def ols(x, y):
    beta, _, _, _ = np.linalg.lstsq(x, y, rcond=None)
    residual = y - x @ beta
    dof = x.shape[0] - x.shape[1]
    # (X^T X)^-1 from the pseudo-inverse (SVD): forming X^T X would square
    # the columns' condition (N beside ones).
    pinv = np.linalg.pinv(x)
    inverse = pinv @ pinv.T
    se = np.sqrt(residual @ residual / dof * np.diag(inverse))
    return beta, se, inverse, residual @ residual / dof


def figures(rows, sidecar):
    excitation = sidecar["excitation"]
    phi = excitation["phi_rad"]
    tf = excitation["tf_s"]
    turn = tf + excitation.get("hold_s", 0.0)
    end = turn + excitation.get("return_s", 0.0)
    t = np.array([float(r["t"]) for r in rows])
    t = t - t[0]
    force = np.array([float(r["Fx"]) * math.cos(phi) +
                      float(r["Fy"]) * math.sin(phi) for r in rows])
    rising = (t >= -1e-9) & (t <= tf + 1e-9)
    falling = (t >= turn - 1e-9) & (t <= end + 1e-9) & (end > turn)
    out = {}
    for c, name in enumerate(CHANNELS):
        r = np.array([float(row[name]) for row in rows])
        per_kn = display(c) * 1e3
        x = np.column_stack([rising.astype(float), falling.astype(float),
                             force])
        keep = rising | falling
        beta, se, _, _ = ols(x[keep], r[keep])
        out[(name, "gradient")] = (beta[2] * per_kn, se[2] * per_kn)
        w = np.array([-1.0, 1.0, 0.0])
        _, _, inverse, s2 = ols(x[keep], r[keep])
        out[(name, "loop_width")] = ((beta[1] - beta[0]) * display(c),
                                     math.sqrt(s2 * w @ inverse @ w) *
                                     display(c))
        for branch, label in ((rising, "rising_gradient"),
                              (falling, "falling_gradient")):
            xb = np.column_stack([np.ones(branch.sum()), force[branch]])
            b, s, _, _ = ols(xb, r[branch])
            out[(name, label)] = (b[1] * per_kn, s[1] * per_kn)
        # The closed loop: rising, then falling, back to the start.
        path = np.concatenate([np.flatnonzero(rising), np.flatnonzero(falling),
                               np.flatnonzero(rising)[:1]])
        area = -np.trapz(r[path], force[path])
        out[(name, "loop_area")] = (area * display(c) * 1e-3, None)
    return out


def main():
    log, kc = sys.argv[1], sys.argv[2]
    rows, sidecar = read_log(log)
    expected = figures(rows, sidecar)
    with open(kc, newline="") as f:
        sheet = [r for r in csv.DictReader(f) if r["log"] == log]
    worst, worst_what = 0.0, ""
    compared = 0
    for row in sheet:
        key = (row["channel"], row["figure"])
        if key not in expected:
            continue
        value, se = expected[key]
        pairs = [(float(row["rig"]), value)]
        if se is not None:
            pairs.append((float(row["rig_standard_error"]), se))
        for k, (got, want) in enumerate(pairs):
            scale = max(abs(want), 1e-300)
            if abs(got - want) / scale > worst:
                worst = abs(got - want) / scale
                worst_what = " ".join(key) + (" standard error" if k else "")
            compared += 1
    print(f"{compared} figures compared, largest relative difference "
          f"{worst:.3g} ({worst_what})")
    if compared < 6 * 5 * 2 - 6:
        print("too few figures in the sheet")
        return 1
    return 0 if worst <= 1e-9 else 1


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/python3
"""The independent generator agrees with `kcrig simulate` without effects.

Usage: independent_rig_agreement.py KCRIG CONFIG_DIR WORK_DIR

For two designs, the clean model, a wrong spring rate and a moved hard point
(the names of --set mean the same in both), runs `kcrig simulate` at a plant
step of 1e-5 s (its first-order discretisation error is then well below the
noise) and tests/peers/independent_rig.py, and compares the six channels in
noise units (the config's sigmas). Fails when any channel differs by more
than 0.05 sigma anywhere, or when kcrig's difference does not shrink with its
step (at 1e-4 s it must be larger: the residual difference is kcrig's own
discretisation, not a modelling disagreement).
"""
import math
import pathlib
import subprocess
import sys

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
RAMP = ["--duration", "2", "--hold", "0.3", "--return", "1.7"]
CASES = [
    ("clean 85deg/-0.45", ["--phi", "85", "--z", "-0.45"]),
    ("clean 20deg/-0.1", ["--phi", "20", "--z", "-0.1"]),
    ("k_spring=1.4e5", ["--phi", "50", "--z", "-0.3", "--set",
                        "k_spring=1.4e5"]),
    ("O1.z=0.121", ["--phi", "50", "--z", "-0.3", "--set", "O1.z=0.121"]),
]
LIMIT = 0.05  # sigma


def run(command):
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        sys.exit(f"{' '.join(command)}: exit {result.returncode}\n"
                 f"{result.stderr}")


def channels(path):
    return np.loadtxt(path, delimiter=",", skiprows=1)[:, 4:]


def main():
    kcrig, config, work = sys.argv[1], sys.argv[2], pathlib.Path(sys.argv[3])
    work.mkdir(parents=True, exist_ok=True)
    sigma = np.array([2e-5] * 3 + [math.radians(0.01)] * 3)
    failed = False
    for index, (name, args) in enumerate(CASES):
        independent = work / f"independent_{index}.csv"
        run(["/usr/bin/python3", str(HERE / "independent_rig.py"),
             "--config", config, *RAMP, *args, "--out", str(independent)])
        reference = channels(independent)
        differences = {}
        for step in ("1e-5", "1e-4"):
            path = work / f"kcrig_{index}_{step}.csv"
            run([kcrig, "simulate", "--config", config, *RAMP, *args,
                 "--plant-step", step, "--out", str(path)])
            differences[step] = (np.abs(channels(path) - reference) /
                                 sigma).max(axis=0)
        fine, coarse = differences["1e-5"], differences["1e-4"]
        print(f"{name:20s} max |kcrig - independent| / sigma at 1e-5 s: "
              + " ".join(f"{d:.4f}" for d in fine)
              + f"  (at 1e-4 s: {coarse.max():.4f})")
        if fine.max() > LIMIT or not coarse.max() > fine.max():
            failed = True
    if failed:
        sys.exit(f"FAIL: a channel differs by more than {LIMIT} sigma, or "
                 "kcrig's difference does not shrink with its step")
    print("PASS")


if __name__ == "__main__":
    main()

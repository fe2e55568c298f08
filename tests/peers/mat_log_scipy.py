#!/usr/bin/python3
"""kcrig's MAT-file run logs against SciPy's reference reader and writer.

  mat_log_scipy.py check RUN.CSV RUN.MAT
      Reads RUN.MAT with scipy.io.loadmat and compares every column of
      RUN.CSV (and its sidecar RUN.JSON) with it: numbers bit for bit, the
      phases as strings, the sidecar's excitation and sigmas. Exit 1 on any
      difference.
  mat_log_scipy.py write RUN.CSV OUT.MAT [--nan VARIABLE]
      Writes RUN.CSV (+ sidecar) as a MAT-file with scipy.io.savemat, the
      way a MATLAB or Python user would hand kcrig a log; --nan puts a NaN
      into VARIABLE (a corrupt log kcrig must refuse).
"""
import csv
import json
import math
import pathlib
import sys

import numpy as np
import scipy.io as sio


def read_csv(path):
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        rows = list(reader)
    columns = {name: [row[i] for row in rows] for i, name in enumerate(header)}
    sidecar = pathlib.Path(path).with_suffix(".json").read_text()
    return header, columns, sidecar


def check(csv_path, mat_path):
    header, columns, sidecar = read_csv(csv_path)
    mat = sio.loadmat(mat_path)
    problems = []
    for name in header:
        if name not in mat:
            problems.append(f"{name}: missing in the MAT-file")
            continue
        if name == "phase":
            # A char matrix, one blank-padded name per row.
            got = [str(row).rstrip() for row in mat[name]]
            if got != columns[name]:
                problems.append("phase: differs")
            continue
        got = mat[name]
        if got.shape != (len(columns[name]), 1):
            problems.append(f"{name}: shape {got.shape}")
            continue
        want = np.array([float(v) for v in columns[name]])
        if not np.array_equal(got[:, 0], want):
            problems.append(f"{name}: values differ")
    written = json.loads(str(mat["sidecar"][0]))
    expected = json.loads(sidecar)
    for key in ("excitation", "measurement_sigma", "rate_hz", "samples"):
        if written.get(key) != expected.get(key):
            problems.append(f"sidecar.{key}: {written.get(key)} != "
                            f"{expected.get(key)}")
    extra = sorted(k for k in mat if not k.startswith("__")
                   and k not in header and k != "sidecar")
    if extra:
        problems.append(f"variables not in the CSV: {extra}")
    for p in problems:
        print(p)
    print(f"{len(header)} columns of {len(columns[header[0]])} samples "
          f"compared: {'equal' if not problems else 'DIFFERENT'}")
    return 1 if problems else 0


def write(csv_path, mat_path, nan=None):
    header, columns, sidecar = read_csv(csv_path)
    variables = {}
    for name in header:
        if name == "phase":
            # A cell array of the names, as MATLAB's cellstr.
            cells = np.empty((len(columns[name]), 1), dtype=object)
            for i, text in enumerate(columns[name]):
                cells[i, 0] = text
            variables[name] = cells
        else:
            values = np.array([float(v) for v in columns[name]])
            if name == nan:
                values[len(values) // 2] = math.nan
            variables[name] = values.reshape(-1, 1)
    variables["sidecar"] = sidecar
    sio.savemat(mat_path, variables, do_compression=True)
    print(f"wrote {mat_path} with scipy.io.savemat")
    return 0


def main():
    if len(sys.argv) >= 4 and sys.argv[1] == "check":
        return check(sys.argv[2], sys.argv[3])
    if len(sys.argv) >= 4 and sys.argv[1] == "write":
        nan = sys.argv[5] if len(sys.argv) >= 6 and sys.argv[4] == "--nan" \
            else None
        return write(sys.argv[2], sys.argv[3], nan)
    print(__doc__)
    return 2


if __name__ == "__main__":
    sys.exit(main())

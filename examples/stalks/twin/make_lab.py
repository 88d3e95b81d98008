#!/usr/bin/env python3
"""Twin experiment, step 1: make the "lab" curves.

Runs shear.toml as it is (its [[bond]] values are the hidden truth), then writes three
"replicate" lab curves to lab/twin_shear.csv: the simulated force times a per-specimen scale
(1 +- 3 %, as specimens differ) plus measurement noise (Gaussian, 1.5 % of the peak per point;
clipped at zero), resampled every 0.02 mm as a testing machine logs. Seeded, so the file is the same on every
machine with the same demcal. Usage (from the repository root):

    python3 examples/stalks/twin/make_lab.py [path/to/demcal]
"""
import csv
import json
import os
import random
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
DEMCAL = sys.argv[1] if len(sys.argv) > 1 else "demcal"
SCALES = [0.97, 1.0, 1.03]
NOISE = 0.015
STEP_M = 2e-5


def simulate(out):
    done = subprocess.run(
        [DEMCAL, "test", os.path.join(HERE, "shear.toml"), "--json", "--out", out],
        check=True, capture_output=True, text=True)
    result = json.loads(done.stdout.strip().splitlines()[-1])
    with open(result["curve_csv"]) as f:
        rows = [(float(r["displacement_m"]), float(r["force_n"])) for r in csv.DictReader(f)]
    return result, rows


def at(rows, x):
    for (x0, f0), (x1, f1) in zip(rows, rows[1:]):
        if x0 <= x <= x1:
            return f0 + (f1 - f0) * (x - x0) / (x1 - x0) if x1 > x0 else f0
    return rows[-1][1]


def main():
    with tempfile.TemporaryDirectory() as out:
        result, rows = simulate(out)
    peak = result["peak_force_n"]
    rng = random.Random(2026)
    end = rows[-1][0]
    points = int(end / STEP_M)
    os.makedirs(os.path.join(HERE, "lab"), exist_ok=True)
    path = os.path.join(HERE, "lab", "twin_shear.csv")
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["displacement_mm"] + [f"force_{k + 1}_n" for k in range(len(SCALES))])
        for i in range(points + 1):
            x = i * STEP_M
            clean = at(rows, x)
            w.writerow([f"{x * 1e3:.3f}"] + [
                f"{max(0.0, s * clean + rng.gauss(0.0, NOISE * peak)):.3f}" for s in SCALES])
    print(f"wrote {path}: {points + 1} points x {len(SCALES)} replicates; "
          f"true curve peak {peak:.2f} N at {result['displacement_at_peak_m'] * 1e3:.3f} mm, "
          f"{result['particles']} spheres, {result['bonds']} bonds")


if __name__ == "__main__":
    main()

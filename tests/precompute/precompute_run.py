"""Running modal-precompute from a test: a .prm text written into its own folder, the program run on
it with that folder as its output, and the report read back."""
import argparse
import json
import os
import shutil
import subprocess

import numpy as np


def run_precompute(binary, folder, prm_text, prm_name="scene.prm"):
    """Returns (report.json as a dict, what the program wrote to stderr); raises if it fails."""
    os.makedirs(folder, exist_ok=True)
    prm = os.path.join(folder, prm_name)
    with open(prm, "w") as f:
        f.write(prm_text)
    done = subprocess.run([binary, prm, "--output-dir", folder, "--quiet"], check=True,
                          stderr=subprocess.PIPE, text=True)
    with open(os.path.join(folder, "report.json")) as f:
        return json.load(f), done.stderr


class Checks:
    """Each check prints its value against its limit; ok is False once one fails."""

    def __init__(self):
        self.ok = True

    def below(self, name, value, limit):
        passed = value <= limit
        self.ok &= passed
        print(f"{name:64s} {value:12.3e}  (<= {limit:.2g}) {'ok' if passed else 'FAILED'}")

    def relative(self, name, value, reference, tolerance, unit="Hz"):
        """|value - reference| / |reference| <= tolerance, both printed in the name."""
        self.below(f"{name}: {value:.3f} {unit} vs {reference:.3f}", abs(value - reference) / abs(reference), tolerance)


def binary_and_fresh_workdir(mpirun_help=None):
    """The arguments of a precompute test: --binary and --workdir, the latter emptied and created
    (and an optional --mpirun, when mpirun_help says what the test does with it)."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--binary", required=True)
    parser.add_argument("--workdir", required=True)
    if mpirun_help:
        parser.add_argument("--mpirun", help=mpirun_help)
    args = parser.parse_args()
    shutil.rmtree(args.workdir, ignore_errors=True)
    os.makedirs(args.workdir)
    return args


def largest_principal_angle(a, b):
    """Between the column spaces of a and b: sin = ||(I - Qa Qa^T) Qb||_2 (accurate for tiny angles)."""
    qa, _ = np.linalg.qr(a)
    qb, _ = np.linalg.qr(b)
    return float(np.arcsin(min(1.0, np.linalg.norm(qb - qa @ (qa.T @ qb), 2))))

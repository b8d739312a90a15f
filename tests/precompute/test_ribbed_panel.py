#!/usr/bin/python3
"""Regression test of the default scene (parameters/ribbed_panel.prm): its first frequencies, its
self-checks, its outputs and the report's required keys.

Reference frequencies were taken from a run on 2026-11-22 (P2, 6 mm coarse size, ~99k DoFs in the
global space). gmsh meshes are not bit-reproducible (node counts move by ~0.1 %), so frequencies are
compared within 1 %; the three spaces (global, rib_a, rib_b) mesh the same part and must agree with
each other within 1 % too."""
import argparse
import json
import os
import shutil
import subprocess
import sys

from precompute_run import Checks

HERE = os.path.dirname(os.path.abspath(__file__))
TOP = os.path.dirname(os.path.dirname(HERE))
REFERENCE_HZ = [85.08, 120.72, 160.24, 161.77, 255.71, 290.89]
REQUIRED_SPACE_KEYS = ["name", "n_vertices", "n_dofs", "degree", "frequencies_hz", "dropped_modes",
                       "orthonormality_error", "max_relative_residual", "validation"]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--binary", required=True)
    parser.add_argument("--workdir", required=True)
    parser.add_argument("--keep", action="store_true", help="reuse the meshes of an earlier run in workdir")
    args = parser.parse_args()
    if not args.keep:
        shutil.rmtree(args.workdir, ignore_errors=True)
    subprocess.run([args.binary, os.path.join(TOP, "parameters", "ribbed_panel.prm"), "--output-dir", args.workdir],
                   check=True)
    report = json.load(open(os.path.join(args.workdir, "report.json")))
    expect = Checks()

    for name in ["ribbed_panel.h5", "ribbed_panel.mrt", "used_parameters.prm", "report.json"]:
        expect(os.path.getsize(os.path.join(args.workdir, name)) > 0, f"{name} written")
    for key in ["meshing", "assembly", "eigensolve", "total"]:
        expect(key in report["timings_s"], f"timings_s.{key} = {report['timings_s'].get(key)}")
    expect([s["name"] for s in report["spaces"]] == ["global", "rib_a", "rib_b"], "spaces global, rib_a, rib_b")
    for s in report["spaces"]:
        n = s["name"]
        expect(all(k in s for k in REQUIRED_SPACE_KEYS), f"{n}: required keys present")
        f = s["frequencies_hz"][: len(REFERENCE_HZ)]
        worst = max(abs(a - b) / b for a, b in zip(sorted(f), REFERENCE_HZ))
        expect(worst < 0.01, f"{n}: first frequencies {[round(x, 2) for x in f]} within 1 % of the reference ({100 * worst:.3f} %)")
        expect(s["mesh"]["min_quality"] > 0.05, f"{n}: min mesh quality {s['mesh']['min_quality']:.3f}")
        expect(s["orthonormality_error"] < 1e-10, f"{n}: orthonormality error {s['orthonormality_error']:.1e}")
        expect(s["max_relative_residual"] < 1e-6, f"{n}: eigen-residual {s['max_relative_residual']:.1e}")
        corrected = max(c["contact_rel_error_corrected"] for c in s["validation"])
        modal = min(c["contact_rel_error_modal"] for c in s["validation"])
        expect(corrected <= 1e-8, f"{n}: corrected contact error {corrected:.1e} <= 1e-8")
        expect(modal > 1e-3, f"{n}: modal-only contact error is honest (>= {modal:.2e})")
    return expect.exit_code()


if __name__ == "__main__":
    sys.exit(main())

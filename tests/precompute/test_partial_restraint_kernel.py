#!/usr/bin/python3
"""Partially restrained parts in the kernel: the block of test_patch_convergence.py (block.geo, 40 x 40
x 10 mm) held so that 1, 2 or 3 rigid-body motions stay free, one mesh for all.

Asserted, for each support set:
* the precompute finds the expected number of free motions and stores them at 0 Hz;
* `modal-rt verify` replays every validation case through the kernel, in the frame that accelerates
  along the free motions only (inertia relief, realtime/src/self_check.cc), and matches the
  precompute's full static FE answer to its float64 tolerance (1e-8).
"""
import os
import subprocess
import sys

from precompute_run import Checks, binary_and_fresh_workdir, run_precompute, test_prm

CASES = [  # supports, free motions
    ("plane 0 0 0 0 0 1 : fix z; nodes -20 -20 0 -20 -20 0 : clamp", 1),  # a corner pin on a table
    ("surface clamp : fix z; nodes -20 -20 0 -20 -20 0 : fix x", 2),       # a slide along y
    ("surface clamp : roller", 3),                                         # resting on a flat face
    ("box -20 -20 0 20 20 0 : fix rt in cylinder 0 0 0 0 0 1", 3),         # held in z only, cylindrical frame
]


def scene(supports):
    return test_prm("partially_restrained_block.prm", "block.geo", {"Geometry/Supports": supports})


args = binary_and_fresh_workdir(required=["--modal-rt"])
checks = Checks()
first = None
for k, (supports, n_free) in enumerate(CASES):
    folder = os.path.join(args.workdir, f"case{k}")
    report, _ = run_precompute(args.binary, folder, scene(supports), meshes_from=first)  # one mesh for all
    first = first or folder
    space = report["spaces"][0]
    rigid = space["rigid_body_modes"]
    print(f"'{supports}': {rigid['count']} free ({rigid['free_motions']})")
    checks.below(f"case {k}: free motions |{n_free} - count|", abs(rigid["count"] - n_free), 0)
    checks.below(f"case {k}: stored rigid-body frequencies [Hz]", max(space["frequencies_hz"][:n_free]), 0.0)
    done = subprocess.run([args.modal_rt, "verify", "--basis", os.path.join(folder, "block.mrt")],
                          capture_output=True, text=True)
    print(done.stdout.strip().splitlines()[-1] if done.stdout.strip() else done.stderr)
    checks.below(f"case {k}: modal-rt verify exit code", done.returncode, 0)
sys.exit(checks.exit_code())

#!/usr/bin/python3
"""Two hands on two regions stay exact: on two_hands_small_scene.prm (the small scene, two VOIs), HIP 0
presses the 'left' VOI's top from 1 s, HIP 1 the 'right' VOI's top from 2 s, both held to 4 s
(two_hands_small_scene_session.csv). No scenario holds both, so the kernel takes the global space;
with 'Global candidates in VOIs' (the default) the global space corrects those vertices too.
Asserted:

* while both HIPs are pressed (trace.csv, 2.5-4 s), both are in the global space (space 0) and
  flagged MODALRT_HIP_CORRECTED: no contact falls to the modes alone;
* each press (presses.csv) ends in the global space, its static stiffness is the full-FE one
  (full_fe 1); its difference from 1 / (n^T G n) of the precompute's fresh full static solve at
  that vertex in the global space is printed, not asserted: the press's load point is the proxy's
  point on a triangle (here 0.4 mm from the vertex, whose weight there is 0.71), and on this coarse
  block the compliance changes by 5-15 % over that distance;
* the two-contact answer: both HIPs in contact at the felt time, multi_full_fe 1 (every pair's cross
  compliance stored: the points are 'Exact pair points'), and the precompute's two-contact check of
  that pair in the global space (one full static FE solve of both loads at once, report.json
  two_contact_checks 'named') within 1e-8 of the corrected answer, at the HIPs' own vertices.
"""
import argparse
import csv
import os
import subprocess
import sys

import numpy as np

import mrt_reader
from precompute_run import Checks, run_precompute, test_prm

HERE = os.path.dirname(os.path.abspath(__file__))
VALIDATION_CASES, VALIDATION_RESPONSE = 26, 27
MODALRT_HIP_CORRECTED = 1 << 3
GLOBAL = 0
TOLERANCE = 1e-8
BOTH_PRESSED_S = (2.5, 4.0)


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def full_fe_compliance(sections, space, vertex):
    """G [m/N] of the full static solve at the vertex in the space: its responses in x, y, z."""
    cases = sections[(VALIDATION_CASES, space, mrt_reader.SCENE_WIDE)].reshape(-1, 2)
    responses = sections[(VALIDATION_RESPONSE, space, mrt_reader.SCENE_WIDE)].reshape(-1, 3)
    columns = {int(d): responses[k] for k, (v, d) in enumerate(cases) if int(v) == vertex}
    return np.column_stack([columns[d] for d in range(3)]) if len(columns) == 3 else None


def check_trace(check, trace):
    both = [r for r in trace if BOTH_PRESSED_S[0] <= float(r["time"]) <= BOTH_PRESSED_S[1]]
    check(len(both) > 0, f"trace rows between {BOTH_PRESSED_S[0]} and {BOTH_PRESSED_S[1]} s")
    for h in (0, 1):
        in_contact = all(r[f"hip{h}_contact"] == "1" for r in both)
        spaces = {int(r[f"hip{h}_space"]) for r in both}
        corrected = all(int(r[f"hip{h}_flags"]) & MODALRT_HIP_CORRECTED for r in both)
        check(in_contact, f"HIP {h} in contact while both are pressed")
        check(spaces == {GLOBAL}, f"HIP {h} in the global space while both are pressed", f"spaces {spaces}")
        check(corrected, f"HIP {h} corrected (MODALRT_HIP_CORRECTED) on every row while both are pressed")


def check_presses(check, presses, sections):
    check(len(presses) == 2, "one press per HIP", f"{len(presses)} presses")
    for p in presses:
        h, vertex = int(p["hip"]), int(p["vertex"])
        print(f"press of HIP {h}: space {p['space_name']}, vertex {vertex}, static stiffness "
              f"{float(p['static_stiffness_n_per_m']) / 1e3:.4f} N/mm (full_fe {p['full_fe']}), felt contacts "
              f"{p['felt_contacts']}, two-contact static stiffness {float(p['multi_static_stiffness_n_per_m']) / 1e3:.4f} "
              f"N/mm (multi_full_fe {p['multi_full_fe']}) {p['multi_note']}")
        check(int(p["space"]) == GLOBAL, f"HIP {h}'s press ends in the global space")
        check(p["full_fe"] == "1", f"HIP {h}'s static stiffness is full FE, not the modes alone")
        check(p["felt_contacts"] == "2" and p["multi_full_fe"] == "1",
              f"HIP {h}'s two-contact static stiffness is the full-FE answer (multi_full_fe 1)", p["multi_note"])
        g = full_fe_compliance(sections, GLOBAL, vertex)
        if check(g is not None, f"HIP {h}'s vertex {vertex} has a full static solve in the global space"):
            n = np.array([float(p[k]) for k in ("nx", "ny", "nz")])
            exact = 1.0 / (n @ g @ n)
            # Printed, not asserted: the press's static stiffness is taken at its load point, the
            # proxy's point on a triangle, not at this vertex (see the module's docstring).
            print(f"HIP {h}: static stiffness vs 1 / (n^T G n) of the vertex's full solve: relative "
                  f"{abs(float(p['static_stiffness_n_per_m']) - exact) / exact:.3e} (not asserted)")


def check_named_pair(check, report, presses):
    space = report["spaces"][GLOBAL]
    named = [c for c in space.get("two_contact_checks", []) if c["named"]]
    if not check(len(named) == 1, "the global space's two-contact check of the exact pair"):
        return
    hands = sorted(int(p["vertex"]) for p in presses)
    check(sorted(named[0]["vertices"]) == hands, "that check is at the HIPs' own vertices",
          f"check {named[0]['vertices']}, HIPs {hands}")
    check.below("global space: two-contact corrected vs one full static FE solve",
                named[0]["rel_error_corrected"], TOLERANCE)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--binary", required=True)
    parser.add_argument("--modal-rt", required=True)
    parser.add_argument("--workdir", required=True)
    args = parser.parse_args()
    report, _ = run_precompute(args.binary, args.workdir, test_prm("two_hands_small_scene.prm", "block.geo"))
    basis = os.path.join(args.workdir, "two_hands_block.mrt")
    output = os.path.join(args.workdir, "session")
    subprocess.run([args.modal_rt, "run", "--basis", basis, "--session",
                    os.path.join(HERE, "two_hands_small_scene_session.csv"), "--output-dir", output,
                    "--trace-rate", "1000", "--no-plot", "--quiet"], check=True)
    _, sections = mrt_reader.read(basis)
    presses = rows(os.path.join(output, "presses.csv"))
    check = Checks()
    check_trace(check, rows(os.path.join(output, "trace.csv")))
    check_presses(check, presses, sections)
    check_named_pair(check, report, presses)
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())

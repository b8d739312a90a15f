#!/usr/bin/python3
"""The README's second example (parameters/bracket.prm): a STEP bracket in mm held by a bolt clamp, a
slotted bolt (fix yz) and an elastic mount under its base.

Asserted:
* its default log (no --quiet) is under 67 lines, without gmsh's progress, with our summaries;
* each support catches what it should: the mount's faces add up to the base's underside (60 x 40 mm
  less two 3 mm holes, within 1 %: the holes are polygons), both bolt boxes catch faces and nodes;
* nothing is left free (0 rigid-body modes), the corrected contact responses equal the full static
  solves (relative error <= 1e-8);
* the mount is a spring, between no mount and a rigid one: f1(bolts only) < f1(elastic mount) <
  f1(base clamped), for the same meshes.
"""
import json
import math
import os
import re
import subprocess
import sys

from precompute_run import Checks, binary_and_fresh_workdir, run_precompute

check = Checks()


def run(binary, prm_text, folder, meshes_from=None):
    """report.json of a run; meshes_from: the same meshes (gmsh is not bit-reproducible)."""
    return run_precompute(binary, folder, prm_text, "bracket.prm", meshes_from)[0]


args = binary_and_fresh_workdir(required=["--prm"])
with open(args.prm) as f:
    text = f.read().replace("bracket/bracket.step", os.path.join(os.path.dirname(os.path.abspath(args.prm)),
                                                                  "bracket", "bracket.step"))
supports = re.search(r"set Supports\s*=\s*(.*?)\s*(#|\n)", text).group(1)
bolts = "; ".join(supports.split(";")[:2])

# The example as a user runs it, without --quiet: gmsh's progress lines are off by default, ours stay
# (with gmsh's progress the log is about 254 lines, about 200 of them gmsh's).
example = os.path.join(args.workdir, "example")
os.makedirs(example)
with open(os.path.join(example, "bracket.prm"), "w") as f:
    f.write(text)
done = subprocess.run([args.binary, os.path.join(example, "bracket.prm"), "--output-dir", example],
                      capture_output=True, text=True)
log = (done.stdout + done.stderr).splitlines()
check(done.returncode == 0, "the example runs")
# One summary line per phase and space (two spaces here; the validity map's phase added two lines:
# 61; the far field's two and a row of the timer's table: 64), against the ~200 progress lines
# gmsh would add.
check(len(log) < 67, f"its default log has {len(log)} lines (< 67)")
check(not any(line.startswith("Info") for line in log), "no gmsh 'Info' line in it")
for summary in ("[geometry] volume", "[global] support 1", "[global] kept", "[flange_top] kept"):
    check(any(line.startswith(summary) for line in log), f"it has the summary line '{summary} ...'")
with open(os.path.join(example, "report.json")) as f:
    report = json.load(f)
for space in report["spaces"]:
    caught = [tuple(map(float, m)) for m in re.findall(r": (\d+) mesh faces, ([\d.e+-]+) m\^2, (\d+) nodes", space["supports"])]
    check(len(caught) == 3 and all(c[0] > 0 and c[2] > 0 for c in caught),
          f"{space['name']}: every support catches faces and nodes ({caught})")
    underside = (60 * 40 - 2 * math.pi * 3 ** 2) * 1e-6
    check(abs(caught[2][1] / underside - 1) < 0.01,
          f"{space['name']}: the mount's area {caught[2][1]:.6g} m^2 = the base's underside {underside:.6g} m^2 (1 %)")
    check(space["rigid_body_modes"]["count"] == 0, f"{space['name']}: nothing left free")
    if space["validation"]:
        worst = max(c["contact_rel_error_corrected"] for c in space["validation"])
        check(worst <= 1e-8, f"{space['name']}: corrected contact = full static FE ({len(space['validation'])} "
                             f"cases, worst relative error {worst:.2e} <= 1e-8)")
check(any(space["validation"] for space in report["spaces"]), "the flange's top is validated")

bolts_only = run(args.binary, text.replace(supports, bolts), os.path.join(args.workdir, "bolts_only"), example)
rigid = run(args.binary, text.replace(supports, bolts + "; normal 0 0 -1 1 : clamp"), os.path.join(args.workdir, "rigid"),
            example)
f1 = [r["spaces"][0]["frequencies_hz"][0] for r in (bolts_only, report, rigid)]
check(f1[0] < f1[1] < f1[2], f"f1: bolts only {f1[0]:.1f} Hz < elastic mount {f1[1]:.1f} Hz < clamped base {f1[2]:.1f} Hz")

sys.exit(check.exit_code())

#!/usr/bin/python3
"""Bad input to modal-precompute: each case must exit non-zero with one message naming the culprit,
and leave the results already in the output folder untouched."""
import os
import shutil
import subprocess
import sys

from precompute_run import binary_and_fresh_workdir

HERE = os.path.dirname(os.path.abspath(__file__))

# An inverted tet: two tets sharing a face, the second one's vertex order mirrored (MSH 2.2 ASCII).
INVERTED_MSH = """$MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
3
2 2 "clamp"
2 3 "free"
3 1 "part"
$EndPhysicalNames
$Nodes
5
1 0 0 0
2 1 0 0
3 0 1 0
4 0 0 1
5 0 0 -1
$EndNodes
$Elements
8
1 2 2 2 1 1 2 4
2 2 2 3 1 2 3 4
3 2 2 3 1 1 3 4
4 2 2 3 1 1 2 5
5 2 2 3 1 2 3 5
6 2 2 3 1 1 3 5
7 4 2 1 1 1 2 3 4
8 4 2 1 1 1 2 3 5
$EndElements
"""

BASE = open(os.path.join(HERE, "cantilever.prm")).read()


def scene_with(*changes):
    """The cantilever scene with extra subsections appended (later 'set' lines win)."""
    return BASE + "\n" + "\n".join(changes) + "\n"


def section(name, *lines):
    return f"subsection {name}\n" + "\n".join(f"  {l}" for l in lines) + "\nend"


CASES = [
    # (name, .prm text, words the message must contain)
    ("unknown parameter", scene_with(section("Material", "set Colour = red")), ["Colour"]),
    ("value out of range", scene_with(section("Meshing", "set Element degree = 3")), ["Element degree"]),
    ("missing geometry file", scene_with(section("Geometry", "set Source = no_such_part.step")), ["no_such_part.step"]),
    ("clamp group that does not exist", scene_with(section("Geometry", "set Clamp groups = bolts")), ["bolts"]),
    ("E <= 0", scene_with(section("Material", "set Young's modulus = 0")), ["Young's modulus"]),
    ("nu >= 0.5", scene_with(section("Material", "set Poisson's ratio = 0.5")), ["Poisson's ratio"]),
    ("nu <= -1", scene_with(section("Material", "set Poisson's ratio = -1")), ["Poisson's ratio"]),
    # Every value out of its range is told in one form: file, line, entry, value, range, unit.
    ("density <= 0", scene_with(section("Material", "set Density = 0")),
     [".prm, line ", "'Material/Density' = 0: must be a number > 0 (unit: kg/m^3)."]),
    ("negative density", scene_with(section("Material", "set Density = -1")),
     ["negative_density.prm, line ", "'Material/Density' = -1: must be a number > 0 (unit: kg/m^3)."]),
    ("degree 3", scene_with(section("Meshing", "set Element degree = 3")),
     ["'Meshing/Element degree' = 3: must be an integer in [1, 2]."]),
    ("misspelt entry", scene_with(section("Material", "set Youngs modulus = 7e10")),
     ["line ", "subsection 'Material' has no entry 'Youngs modulus'. Did you mean 'Young's modulus'?"]),
    ("misspelt subsection", scene_with(section("Materials", "set Density = 1000")),
     ["line ", "has no subsection 'Materials'. Did you mean 'Material'?"]),
    ("unknown cut-off rule", scene_with(section("Modes", "set Cut-off rule = fast")),
     ["'Modes/Cut-off rule' = fast: must be one of none, display, haptic."]),
    # A support that names an empty physical group, which gmsh loads without a word (one that no
    # support names is only warned about: test_messages.py).
    ("support naming an empty physical group",
     scene_with(section("Geometry", "set Source = empty_group.geo", "set Supports = surface wall : clamp")),
     ["Group 'wall'", "empty_group.geo", "the physical surface 'wall' holds no surface", "select another group"]),
    # The groups listed are the user's; 'free' is said to be the program's.
    ("group listing without the program's", scene_with(section("Geometry", "set Source = clamp_only.geo",
                                                               "set Supports = surface bolts : clamp")),
     ["surfaces: 'clamp'; the program adds 'free'"]),
    ("r = 0", scene_with(section("Modes", "set Maximum number of modes = 0", "set Minimum number of modes = 0")),
     ["Maximum number of modes"]),
    ("cut-off below the first frequency",
     scene_with(section("Modes", "set Cut-off rule = display", "set Minimum number of modes = 0")), ["Cut-off"]),
    ("VOI outside the part", scene_with(section("Scenario 1", "set Name = far_away", "set Box lower corner = 500, 500, 500",
                                                "set Box upper corner = 510, 510, 510", "set Fine size = 1")),
     ["far_away"]),
    ("STEP that gmsh cannot read", scene_with(section("Geometry", "set Source = broken.step")), ["broken.step"]),
    ("free-floating part without a negative shift", scene_with(section("Geometry", "set Clamp groups =")),
     ["free-floating", "Modes/Shift"]),
    ("free-floating part with no elastic mode",
     scene_with(section("Geometry", "set Clamp groups ="),
                section("Modes", "set Shift = -10", "set Maximum number of modes = 6", "set Minimum number of modes = 6")),
     ["free-floating", "Maximum number of modes"]),
    ("eigensolver that cannot converge", scene_with(section("Modes", "set Tolerance = 1e-16")),
     ["did not converge", "of 8 modes", "Tolerance"]),
    ("unknown eigensolver", scene_with(section("Modes", "set Eigensolver = lobpcg")), ["Eigensolver", "lobpcg-amg"]),
    ("lobpcg-amg with a positive shift", scene_with(section("Modes", "set Eigensolver = lobpcg-amg", "set Shift = 50")),
     ["lobpcg-amg", "Modes/Shift", "50 Hz"]),
    ("inverted tet", scene_with(section("Geometry", "set Source = inverted.msh")), ["inverted"]),
    ("exact pair with one point", scene_with(section("Contact", "set Exact pair points = 0, 0, 10")),
     ["Exact pair points", "0, 0, 10"]),
    ("exact pair point off the part", scene_with(section("Contact", "set Exact pair points = 0, 0, 10 : 0, 0, 90")),
     ["Exact pair points", "0, 0, 90", "Exact pair reach"]),
    ("exact pair reach 0 with a single-vertex load",
     scene_with(section("Contact", "set Exact pair points = 0, 0, 10 : 5, 0, 10", "set Patch radius = 0")),
     ["Exact pair reach", "Patch radius"]),
    ("exact pair without cross compliance",
     scene_with(section("Contact", "set Exact pair points = 0, 0, 10 : 5, 0, 10", "set Cross compliance = false")),
     ["Exact pair points", "Cross compliance"]),
    ("missing subsection end", BASE + "\nsubsection Material\n  set Density = 1000\n", ["subsection", "missing_subsection_end.prm"]),
]

# Bad supports ('Geometry/Supports', docs/supports.md). The wording is not fixed: the words each message must
# contain are all here, in one place, to adjust.
SUPPORT_WORDS = {
    "support group that does not exist": ["bolts"],
    "support box that catches nothing": ["catches no"],
    "unknown restraint": ["glue"],
    "unknown selection": ["sphere"],
    "support entry without ':'": ["surface clamp clamp"],
    "symmetry on a non-planar selection": ["symmetry", "plan"],
    "supports leaving motions free, shift >= 0": ["translation", "rotation", "y", "z", "Modes/Shift"],
    "elastic support, negative stiffness": ["elastic", "-1e+12"],
    "elastic support on nodes (no area)": ["elastic", "nodes 0 0 0 0 10 10"],
}
SUPPORTS = {
    "support group that does not exist": "surface bolts : clamp",
    "support box that catches nothing": "box 500 500 500 510 510 510 : clamp",
    "unknown restraint": "surface clamp : glue",
    "unknown selection": "sphere 0 0 0 1 : clamp",
    "support entry without ':'": "surface clamp clamp",
    # 'free' is five faces of the bar: not one plane.
    "symmetry on a non-planar selection": "surface clamp : clamp; surface free : symmetry",
    # u_x = 0 on the face x = 0 leaves translation y, translation z and rotation about x free.
    "supports leaving motions free, shift >= 0": "surface clamp : fix x",
    "elastic support, negative stiffness": "surface clamp : elastic -1e+12 1e+12",
    # The FE nodes of the face x = 0: points have no normal and no area to spread a foundation over.
    "elastic support on nodes (no area)": "nodes 0 0 0 0 10 10 : elastic 1e+12 1e+12",
}
CASES += [(name, scene_with(section("Geometry", f"set Supports = {SUPPORTS[name]}")), words)
          for name, words in SUPPORT_WORDS.items()]


def main():
    args = binary_and_fresh_workdir()
    shutil.copy(os.path.join(HERE, "cantilever.geo"), args.workdir)
    with open(os.path.join(args.workdir, "inverted.msh"), "w") as f:
        f.write(INVERTED_MSH)
    box = 'SetFactory("OpenCASCADE");\nBox(1) = {0, 0, 0, 200, 10, 10};\nPhysical Volume("part", 1) = {1};\n'
    with open(os.path.join(args.workdir, "empty_group.geo"), "w") as f:
        f.write(box + 'Physical Surface("wall") = {};\n')
    with open(os.path.join(args.workdir, "clamp_only.geo"), "w") as f:
        f.write(box + 'Physical Surface("clamp", 2) = {1};\n')
    with open(os.path.join(args.workdir, "broken.step"), "w") as f:
        f.write("ISO-10303-21;\nHEADER;\nthis is not a part\nEND-ISO-10303-21;\n")
    results = os.path.join(args.workdir, "results")
    os.makedirs(results)
    earlier = {"report.json": '{"earlier": true}\n', "cantilever.mrt": "earlier basis\n"}
    for name, text in earlier.items():
        with open(os.path.join(results, name), "w") as f:
            f.write(text)

    failures = 0
    for name, prm_text, words in CASES:
        prm = os.path.join(args.workdir, name.replace(" ", "_").replace("<", "le").replace(">", "ge") + ".prm")
        with open(prm, "w") as f:
            f.write(prm_text)
        run = subprocess.run([args.binary, prm, "--output-dir", results, "--quiet"], capture_output=True, text=True)
        message = run.stdout + run.stderr
        problems = []
        if run.returncode == 0:
            problems.append("exit code 0")
        problems += [f"message lacks '{w}'" for w in words if w not in message]
        for file, text in earlier.items():
            if open(os.path.join(results, file)).read() != text:
                problems.append(f"earlier {file} was changed")
        status = "ok" if not problems else "FAILED: " + "; ".join(problems)
        print(f"{name:42s} exit {run.returncode}  {status}")
        if problems:
            print("   message was:", message.strip().replace("\n", "\n   "))
            failures += 1
    print(f"{len(CASES) - failures} passed, {failures} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

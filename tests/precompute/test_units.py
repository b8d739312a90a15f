#!/usr/bin/python3
"""Units, selections and defaults of a STEP part (docs/supports.md).

The test makes its own STEP files with gmsh (OpenCASCADE): a steel bar 200 x 10 x 10 mm, once written
as gmsh writes it (coordinates in mm, header SI_UNIT(.MILLI.,.METRE.)), once with the coordinates in
metres and the header saying metres. Both must give the same part: the same bounding box in metres,
mass (7850 kg/m^3 x 2e-5 m^3 = 0.157 kg) and first bending frequency (Euler-Bernoulli 203.9 Hz),
whichever unit the file is in (before this, gmsh read both in mm and the metre file gave a part 1e9
times too heavy). A 'Length unit' that contradicts the header is refused; a clamp box drawn at the
exact coordinates of the face x = 0 catches it; an empty clamp box, an unknown group are refused by
--validate naming them; 4 modes are accepted with the default minimum.
"""
import json
import os
import re
import subprocess
import sys

from precompute_run import Checks, binary_and_fresh_workdir, test_prm

DENSITY, VOLUME = 7850.0, 0.2 * 0.01 * 0.01
EULER_BERNOULLI_F1 = 203.9  # Hz, E = 200 GPa (test_cantilever.py's reference)
check = Checks()


def write_step(folder, name, size, unit_entity):
    """A box size x size/20 x size/20 written by gmsh, its length unit entity replaced by unit_entity."""
    geo = os.path.join(folder, name + ".geo")
    with open(geo, "w") as f:
        f.write(f'SetFactory("OpenCASCADE");\nBox(1) = {{0, 0, 0, {size}, {size / 20}, {size / 20}}};\n')
    step = os.path.join(folder, name + ".step")
    subprocess.run(["gmsh", geo, "-0", "-o", step], check=True, stdout=subprocess.DEVNULL)
    with open(step) as f:
        text = f.read()
    assert "SI_UNIT(.MILLI.,.METRE.)" in text, "gmsh wrote no millimetre unit entity"
    with open(step, "w") as f:
        f.write(text.replace("SI_UNIT(.MILLI.,.METRE.)", unit_entity))
    return step


def scene(step, length_unit, entries=None):
    """bar.prm on `step`, its lengths in the file's unit (mm or m), then `entries`."""
    size = 0.2 if length_unit == 1 else 200.0
    return test_prm("bar.prm", entries={
        "Geometry/Source": step, "Geometry/Length unit": length_unit,
        "Geometry/Clamp boxes": f"0, 0, 0, 0, {size / 20}, {size / 20}", "Meshing/Coarse size": size / 80,
        "Contact/Patch radius": size / 250, "Contact/Validation points": f"{size}, {size / 40}, {size / 40}",
        **(entries or {})})


def run(folder, name, text, *options):
    prm = os.path.join(folder, name + ".prm")
    with open(prm, "w") as f:
        f.write(text)
    out_dir = os.path.join(folder, name)
    done = subprocess.run([ARGS.binary, prm, "--output-dir", out_dir, *options], capture_output=True, text=True)
    return done.returncode, done.stdout + done.stderr, out_dir


def number_after(pattern, text):
    match = re.search(pattern + r"\s*([-+0-9.eE]+)", text)
    return float(match.group(1)) if match else float("nan")


ARGS = binary_and_fresh_workdir()
work = ARGS.workdir
step_mm = write_step(work, "bar_mm", 200, "SI_UNIT(.MILLI.,.METRE.)")
step_m = write_step(work, "bar_m", 0.2, "SI_UNIT($,.METRE.)")

# --validate of each: the same part in metres, its mass, and the exact-coordinate clamp box's face.
for step, unit, label in ((step_mm, 0.001, "mm"), (step_m, 1, "m")):
    code, out, _ = run(work, "validate_" + label, scene(step, unit), "--validate")
    print(out)
    check(code == 0, f"{label} file with Length unit = {unit} is valid")
    check("extent 0.2 x 0.01 x 0.01 m" in out, f"{label} file: bounding box 0.2 x 0.01 x 0.01 m")
    mass = number_after(r"mass", out)
    check(abs(mass - DENSITY * VOLUME) < 1e-6 * DENSITY * VOLUME, f"{label} file: mass {mass} kg = 0.157 kg")
    check("Clamp boxes' entry 1" in out and ": 1 CAD surface, area 0.0001 m^2" in out,
          f"{label} file: the clamp box at the face's exact coordinates caught the face x = 0 (1e-4 m^2)")

# A Length unit that contradicts the file's header is refused, both named.
code, out, _ = run(work, "contradicting", scene(step_m, 0.001, {"Geometry/Clamp boxes": "0, 0, 0, 0, 10, 10"}),
                   "--validate")
check(code != 0 and "declares its length unit as metre" in out and "'Geometry/Length unit' = 0.001" in out,
      "Length unit 0.001 on a metre STEP refused naming both: " + out.strip().splitlines()[-2])

# The default patch radius (2) on a part in metres: a 2 m patch on a 0.2 m bar is warned about.
code, out, _ = run(work, "big_patch", scene(step_m, 1, {"Contact/Patch radius": 2}),
                   "--validate")
check(code == 0 and "Warning: 'Contact/Patch radius' = 2 geometry units (2 m) exceeds a tenth of the part's largest "
      "extent" in out, "a patch radius over a tenth of the largest extent is warned about")
# A run with it: its patches cover the whole bar, far over the documented 64 display vertices.
code, out, _ = run(work, "big_patch_run", scene(step_m, 1, {"Modes/Maximum number of modes": 4,
                                                        "Contact/Patch radius": 2}), "--quiet")
held = number_after("Warning: a contact patch holds", out)
check(code == 0 and held > 64 and "(more than 64)" in out,
      f"a patch over 64 display vertices is warned about in a run (it holds {held:.0f})")

# A clamp box that catches nothing is refused, naming it and the nearest face.
code, out, _ = run(work, "empty_box", scene(step_m, 1, {"Geometry/Clamp boxes": "0.1, 0, 0, 0.1, 0.01, 0.01"}),
                   "--validate")
check(code != 0 and "'Geometry/Clamp boxes' entry 1" in out and "catches no boundary face" in out
      and "the nearest is face" in out, "empty clamp box refused naming it and the nearest face")

# VOIs at --validate: one at the free end reports the faces it meets; one buried inside the bar, away
# from every face, is refused naming the nearest face.
def voi(name, lower, upper):
    """A VOI with the default fine size (1.5), larger than the coarse size 0.0025: it must follow it."""
    return {"Scenario 1/Name": name, "Scenario 1/Box lower corner": lower, "Scenario 1/Box upper corner": upper,
            "Scenario 1/Transition": 0.01}


code, out, _ = run(work, "voi_end", scene(step_m, 1, voi("tip", "0.19, -0.001, -0.001", "0.21, 0.011, 0.011")),
                   "--validate")
check(code == 0 and "VOI 'tip'" in out and "meets 5 CAD surfaces" in out,
      "a VOI at the free end meets the end face and the 4 side faces (with the default fine size)")
code, out, _ = run(work, "voi_buried",
                   scene(step_m, 1, voi("buried", "0.05, 0.004, 0.004", "0.06, 0.006, 0.006")), "--validate")
check(code != 0 and "VOI 'buried'" in out and "the nearest is face" in out,
      "a VOI that meets no boundary face refused by --validate naming the nearest face")

# A group name that is not a physical surface is refused by --validate.
code, out, _ = run(work, "no_group", scene(step_m, 1, {"Geometry/Clamp boxes": "", "Geometry/Clamp groups": "ss"}),
                   "--validate")
check(code != 0 and "Group 'ss'" in out and "is not a physical surface" in out,
      "unknown clamp group refused by --validate")

# Full runs, 4 modes (fewer than the default minimum of 10): the same frequencies in both units.
first = {}
for step, unit, label in ((step_mm, 0.001, "mm"), (step_m, 1, "m")):
    code, out, out_dir = run(work, "run_" + label, scene(step, unit, {"Modes/Maximum number of modes": 4}),
                             "--quiet")
    check(code == 0, f"{label} file: a run with 4 modes and the default minimum succeeds" +
          ("" if code == 0 else ": " + out[-500:]))
    if code == 0:
        with open(os.path.join(out_dir, "report.json")) as f:
            report = json.load(f)
        frequencies = report["spaces"][0]["frequencies_hz"]
        check(len(frequencies) == 4, f"{label} file: 4 modes kept")
        first[label] = frequencies[0]
        check(abs(frequencies[0] / EULER_BERNOULLI_F1 - 1) < 0.03,
              f"{label} file: first frequency {frequencies[0]:.2f} Hz within 3 % of Euler-Bernoulli's 203.9 Hz")
if len(first) == 2:
    check(abs(first["m"] / first["mm"] - 1) < 0.01,
          f"first frequency of the metre file {first['m']:.3f} Hz = the millimetre file's {first['mm']:.3f} Hz (1 %)")

# A .msh input (the metre run's own mesh): its box, mass and clamp group from the mesh itself.
msh = os.path.join(work, "run_m", "mesh_global.msh")
if os.path.exists(msh):
    code, out, _ = run(work, "msh", scene(msh, 1, {"Geometry/Clamp boxes": "", "Geometry/Clamp groups": "clamp"}),
                       "--validate")
    check(code == 0 and "extent 0.2 x 0.01 x 0.01 m" in out and "Group 'clamp' (a physical surface): 1 surface, area 0.0001 m^2" in out
          and abs(number_after("mass", out) - DENSITY * VOLUME) < 1e-6,
          "a .msh input: bounding box, mass and the clamp group's area from the mesh")

sys.exit(check.exit_code())

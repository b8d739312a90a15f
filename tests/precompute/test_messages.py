#!/usr/bin/python3
"""What a user reads (docs/reliability.md): the lines and warnings a run or --validate prints
on the cantilever (200 x 10 x 10 mm steel, tests/precompute/cantilever.prm), each asserted word for word.

* mode selection says why each count: the haptic cut-off and the floor, in the parameters' names;
  an over-damped kept mode is warned about, naming the damping parameters;
* --validate refuses supports that leave rigid-body motions free with the run's own message, and
  counts CAD surfaces where the run counts mesh faces;
* plausibility that depends on the unit: a part in metres read as millimetres is warned about (its
  size, its mass, its first frequency), a coarse size larger than the part is refused before meshing,
  a patch radius is warned about only when it is large against the part;
* a shift above the first frequency is explained in the run's words, without CHOLMOD's raw line;
* a .geo group that holds nothing and that no support names is loaded with one warning naming it and
  the file, and left out of the meshes (a support that names one: test_bad_input.py).
"""
import os
import shutil
import subprocess
import sys

from precompute_run import Checks, binary_and_fresh_workdir

HERE = os.path.dirname(os.path.abspath(__file__))
BASE = open(os.path.join(HERE, "cantilever.prm")).read()
check = Checks()


def section(name, *lines):
    return f"subsection {name}\n" + "\n".join(f"  {l}" for l in lines) + "\nend\n"


def run(args, name, *sections, options=()):
    """(exit code, stdout + stderr) of modal-precompute on the cantilever with extra subsections."""
    folder = os.path.join(args.workdir, name)
    os.makedirs(folder, exist_ok=True)
    for geo in ("cantilever.geo", "cantilever_in_metres.geo", "cantilever_with_wall.geo"):
        shutil.copy(os.path.join(args.workdir, geo), folder)
    prm = os.path.join(folder, name + ".prm")
    with open(prm, "w") as f:
        f.write(BASE + "\n" + "".join(sections))
    done = subprocess.run([args.binary, prm, "--output-dir", folder, *options], capture_output=True, text=True)
    return done.returncode, done.stdout + done.stderr


def mode_selection(args):
    code, out = run(args, "selection", section("Meshing", "set Coarse size = 5"),
                    section("Modes", "set Maximum number of modes = 12", "set Minimum number of modes = 10",
                            "set Cut-off rule = haptic"), section("Damping", "set Rayleigh beta = 1e-4"),
                    options=("--quiet",))
    check(code == 0, "the cantilever with the haptic cut-off runs", out)
    # 'Maximum number of modes' = 12, but the 10th mode already lies above the cut-off: the eigensolve
    # stops at the floor's 10 (CutOffStop), so none is computed only to be dropped.
    check("[global] kept 10 modes: 2 below the 500 Hz cut-off ('Modes/Cut-off rule' = haptic: half 'Modes/Haptic "
          "rate'), raised to the floor of 10 ('Modes/Minimum number of modes')\n" in out,
          "the selection says why 10 were kept, and no mode was computed only to be dropped (also with --quiet)", out)
    check("Warning: space 'global': mode " in out and "above 0.5: so damped a mode is not felt as a vibration" in out
          and "'Damping/Rayleigh beta' = 0.0001 s" in out,
          "a kept mode damped above 0.5 by Rayleigh beta = 1e-4 s is warned about, naming it", out)


def free_motions_predicted(args):
    support = section("Geometry", "set Supports = box -1 -1 -1 1 11 11 : fix z")
    code, validate = run(args, "fix_z_validate", support, options=("--validate",))
    check(code != 0 and "The supports ('Geometry/Supports') leave 4 rigid-body motions free (" in validate
          and "set 'Modes/Shift' below zero" in validate, "--validate refuses 'fix z' on the clamped face", validate)
    code, ran = run(args, "fix_z_run", support, section("Meshing", "set Coarse size = 5"), options=("--quiet",))
    told = validate[validate.find("('Geometry/Supports') leave"):].split(" Hz")[0]
    check(code != 0 and told in ran, f"the run refuses it in the same words ('{told[:60]}...')", ran)
    code, out = run(args, "surfaces_validate", section("Geometry", "set Supports = box -1 -1 -1 1 11 11 : clamp"),
                    options=("--validate",))
    check(code == 0 and "meets 5 CAD surfaces (the run selects the mesh faces or nodes inside)" in out
          and "the supports would leave 0 rigid-body motions free" in out,
          "--validate counts CAD surfaces and predicts a clamped cantilever held", out)


def unit_plausibility(args):
    metres = section("Geometry", "set Source = cantilever_in_metres.geo")
    sizes = section("Meshing", "set Coarse size = 0.005")
    contact = section("Contact", "set Patch radius = 0.004", "set Validation points = 0.2, 0.005, 0.005")
    modes = section("Modes", "set Maximum number of modes = 4", "set Minimum number of modes = 4")
    code, out = run(args, "metres_as_mm", metres, sizes, contact, modes, options=("--quiet",))
    check("Warning: the part measures 0.0002 m across: is 'Geometry/Length unit' = 0.001 m right?" in out,
          "a part in metres read as mm: its size is warned about", out)
    check("Warning: the part's mass is 1.57e-10 kg" in out, "... and its mass", out)
    check("its first vibration frequency is" in out and "above 100 kHz: is 'Geometry/Length unit' = 0.001 m right?" in out,
          "... and its first frequency", out)
    code, out = run(args, "sizes_in_mm", metres, section("Geometry", "set Length unit = 1"), options=("--quiet",))
    check(code != 0 and "'Meshing/Coarse size' = 2.5 geometry units (2.5 m) is larger than the part's largest "
          "extent, 0.2 geometry units (0.2 m)" in out and not os.path.exists(
              os.path.join(args.workdir, "sizes_in_mm", "mesh_global.msh")),
          "a part in metres with sizes left in mm is refused before meshing", out)
    code, out = run(args, "patch_ok", options=("--validate",))
    check(code == 0 and "Patch radius" not in out, "a 4 mm patch on a 200 mm part is not warned about", out)
    code, out = run(args, "patch_large", section("Contact", "set Patch radius = 30"), options=("--validate",))
    check("Warning: 'Contact/Patch radius' = 30 geometry units (0.03 m) exceeds a tenth of the part's largest extent"
          in out, "a 30 mm patch on a 200 mm part is", out)


def shift_above_first_frequency(args):
    """A shift above the first frequency: the run's own explanation, without CHOLMOD's raw
    'CHOLMOD error: matrix not positive definite' line before it."""
    code, out = run(args, "shift_above_f1", section("Meshing", "set Coarse size = 5"),
                    section("Modes", "set Shift = 1e6"), options=("--quiet",))
    check(code != 0 and "'Modes/Shift' lies above the first eigenfrequency" in out,
          "a shift above the first frequency is refused in the run's words", out)
    check("CHOLMOD error" not in out and "CHOLMOD warning" not in out, "... without CHOLMOD's own line", out)


def empty_group_warned(args):
    """A .geo group that holds nothing and that no support names ('Physical Surface("wall") = {};',
    which gmsh loads without a word): loaded, warned about once, naming the group and the file, and
    left out of the meshes."""
    def warnings(out):
        """The lines of the warning, the file named by the path the run resolved."""
        return [line for line in out.splitlines() if line.startswith("Warning: geometry file '/") and line.endswith(
            "/cantilever_with_wall.geo': the physical surface 'wall' holds no surface (gmsh loads 'Physical "
            "Surface(\"wall\") = {};' without a word); it is left out of the meshes (no support names it).")]

    code, out = run(args, "empty_group_validate", section("Geometry", "set Source = cantilever_with_wall.geo"),
                    options=("--validate",))
    check(code == 0 and len(warnings(out)) == 1, "--validate loads a .geo with an empty group, warning once", out)
    code, out = run(args, "empty_group_meshed", section("Geometry", "set Source = cantilever_with_wall.geo"),
                    section("Meshing", "set Coarse size = 5"), options=("--mesh-only",))
    meshes = [name for name in os.listdir(os.path.join(args.workdir, "empty_group_meshed")) if name.endswith(".msh")]
    check(code == 0 and len(warnings(out)) == 1 and meshes, "--mesh-only meshes it, warning once", out)
    check(not any('"wall"' in open(os.path.join(args.workdir, "empty_group_meshed", name)).read() for name in meshes),
          "no mesh names the empty group")


def main():
    args = binary_and_fresh_workdir()
    shutil.copy(os.path.join(HERE, "cantilever.geo"), args.workdir)
    with open(os.path.join(HERE, "cantilever.geo")) as f:
        geo = f.read()
    with open(os.path.join(args.workdir, "cantilever_in_metres.geo"), "w") as f:
        f.write(geo.replace("Box(1) = {0, 0, 0, 200, 10, 10};", "Box(1) = {0, 0, 0, 0.2, 0.01, 0.01};"))
    with open(os.path.join(args.workdir, "cantilever_with_wall.geo"), "w") as f:
        f.write(geo + 'Physical Surface("wall") = {};\n')
    mode_selection(args)
    free_motions_predicted(args)
    unit_plausibility(args)
    shift_above_first_frequency(args)
    empty_group_warned(args)
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())

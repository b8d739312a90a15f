#!/usr/bin/python3
"""An installed modal-rt finds its plot script where it was installed, not in the source tree.

Installs the build into a temporary prefix (cmake --install), moves the prefix elsewhere (the lookup
is relative to the program, so a moved prefix must still work), marks the installed copy of
plot_force_displacement.py so that a run by it leaves a file, then plays a short press on the small
scene's basis with the installed modal-rt. Asserted: the installed scripts and modal-study's
bench-basis-cost exist, the run wrote force_displacement.png (a PNG) and the installed script drew
it. Without matplotlib the run must say that it skipped the plot, naming matplotlib (not a missing
script)."""
import argparse
import os
import shutil
import subprocess
import sys

import mrt_reader

DISPLAY_VERTICES = 1
MARKER = "plotted_by_installed_script"


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--cmake", required=True)
    parser.add_argument("--build-dir", required=True)
    parser.add_argument("--basis", required=True)
    parser.add_argument("--workdir", required=True)
    args = parser.parse_args()
    shutil.rmtree(args.workdir, ignore_errors=True)
    os.makedirs(args.workdir)

    installed = os.path.join(args.workdir, "installed")
    subprocess.run([args.cmake, "--install", args.build_dir, "--prefix", installed], check=True,
                   stdout=subprocess.DEVNULL)
    prefix = os.path.join(args.workdir, "moved")
    shutil.move(installed, prefix)
    scripts = os.path.join(prefix, "share", "modal-haptics", "scripts")
    failures = [f"{name} not installed in {scripts}" for name in ("plot_force_displacement.py", "study_report.py")
                if not os.path.isfile(os.path.join(scripts, name))]
    helpers = os.path.join(prefix, "libexec", "modal-haptics")
    if not os.access(os.path.join(helpers, "bench-basis-cost"), os.X_OK):
        failures.append(f"bench-basis-cost (modal-study's kernel timing) not installed in {helpers}")
    if failures:
        print("\n".join("FAILED: " + f for f in failures))
        return 1
    installed_script = os.path.join(scripts, "plot_force_displacement.py")
    text = open(installed_script).read()
    with open(installed_script, "w") as f:
        f.write(f"import os, sys\nopen(os.path.join(sys.argv[1], {MARKER!r}), 'w').close()\n" + text)

    _, sections = mrt_reader.read(args.basis)
    vertex = sections[(DISPLAY_VERTICES, mrt_reader.SCENE_WIDE, mrt_reader.SCENE_WIDE)].reshape(-1, 3)[0]
    session = os.path.join(args.workdir, "press.csv")
    with open(session, "w") as f:
        f.write("time,hip,event,x,y,z\n"
                f"0,0,target,{vertex[0]!r},{vertex[1]!r},{vertex[2]!r}\n"
                "0,0,force,0,0,0\n0.1,0,force,0,0,-1\n0.3,-,end\n")
    output = os.path.join(args.workdir, "run")
    run = subprocess.run([os.path.join(prefix, "bin", "modal-rt"), "run", "--basis", args.basis, "--session", session,
                          "--output-dir", output, "--mode", "admittance", "--device", "probe"],
                         capture_output=True, text=True)
    print(run.stdout + run.stderr)
    matplotlib = subprocess.run(["/usr/bin/python3", "-c", "import matplotlib"], capture_output=True).returncode == 0
    png = os.path.join(output, "force_displacement.png")
    checks = {"the installed modal-rt ran": run.returncode == 0}
    if matplotlib:
        checks["force_displacement.png is a PNG"] = (os.path.isfile(png) and
                                                     open(png, "rb").read(8) == b"\x89PNG\r\n\x1a\n")
        checks["the installed script drew it"] = os.path.isfile(os.path.join(output, MARKER))
    else:
        checks["the run says matplotlib is missing"] = "matplotlib is missing" in run.stdout + run.stderr
    for what, ok in checks.items():
        print(("ok     " if ok else "FAILED ") + what)
    return 0 if all(checks.values()) else 1


if __name__ == "__main__":
    sys.exit(main())

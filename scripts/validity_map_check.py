#!/usr/bin/python3
"""The validity map against full nonlinear solves away from the named validation contacts.

The map (Contact/Validity estimate) holds, at every corrected contact, the forces where the linear
felt compliance departs by 1, 5, 10 % from the nonlinear one, from the modal second-order estimate.
This script picks random display vertices of each region where the map has a value (a fixed seed),
runs the precompute again on the earlier run's meshes with those vertices as `Validation points` and
`Validity analysis = true` (one full nonlinear solve each), and prints, per contact, the map's
forces (the estimate of the earlier run), the full solve's and the estimate's relative error.

  scripts/validity_map_check.py --binary build/bin/modal-precompute \\
      --prm parameters/ribbed_panel.prm --earlier results/ribbed_panel --workdir /tmp/vmc

--earlier: an output folder of the same .prm (its .h5, meshes and used_parameters.prm are read).
"""
import argparse
import glob
import json
import os
import re
import shutil
import subprocess
import sys

import h5py
import numpy as np

DEPARTURES = ("1_percent", "5_percent", "10_percent")
NOT_REACHED = 1e29  # the map's 1e30


def arguments():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--binary", required=True)
    parser.add_argument("--prm", required=True)
    parser.add_argument("--earlier", required=True, help="an output folder of the same .prm")
    parser.add_argument("--workdir", required=True, help="a fresh folder for the new run")
    parser.add_argument("--per-region", type=int, default=3, help="random contacts per region")
    parser.add_argument("--seed", type=int, default=38)
    return parser.parse_args()


def length_unit(folder):
    """'Geometry/Length unit' of the earlier run [m per geometry unit]."""
    text = open(os.path.join(folder, "used_parameters.prm")).read()
    return float(re.search(r"^\s*set Length unit\s*=\s*([^\s#]+)", text, re.M).group(1))


def pick_contacts(h5_path, per_region, seed):
    """(vertex, position [m], map forces [N] x 3) per picked vertex, per_region of each region."""
    random = np.random.default_rng(seed)
    picked = []
    with h5py.File(h5_path, "r") as h5:
        x = h5["display_surface/vertices"][:]
        region = h5["display_surface/region"][:]
        for g in h5["spaces"].values():
            if "validity_force" not in g:
                continue
            own = np.flatnonzero((region == g.attrs["index"]) & (g["validity_force"][:, 0] > 0))
            for v in random.choice(own, min(per_region, len(own)), replace=False):
                picked.append((int(v), x[v], g["validity_force"][v]))
    return picked


def with_contact_lines(prm_text, lines):
    """The .prm with 'lines' set in its Contact subsection (added when it has none)."""
    out, inside, added = [], False, False
    for line in prm_text.splitlines(keepends=True):
        key = line.strip()
        if key == "subsection Contact":
            out.append(line)
            out.extend(f"  {entry}\n" for entry in lines)
            inside, added = True, True
            continue
        if inside and key.startswith(tuple(f"set {e.split('=')[0].strip()[4:]}" for e in lines)):
            continue  # replaced by the line above
        if inside and key == "end":
            inside = False
        out.append(line)
    if not added:
        out.append("subsection Contact\n" + "".join(f"  {entry}\n" for entry in lines) + "end\n")
    return "".join(out)


def main():
    args = arguments()
    h5_path = glob.glob(os.path.join(args.earlier, "*.h5"))[0]
    unit = length_unit(args.earlier)
    contacts = pick_contacts(h5_path, args.per_region, args.seed)
    points = "; ".join(", ".join(f"{c / unit:.12g}" for c in x) for _, x, _ in contacts)
    os.makedirs(args.workdir)
    for mesh in glob.glob(os.path.join(args.earlier, "*.msh")) + glob.glob(os.path.join(args.earlier, "*.key")):
        shutil.copy(mesh, args.workdir)
    prm = os.path.join(args.workdir, "scene.prm")
    text = open(args.prm).read()
    source_dir = os.path.dirname(os.path.abspath(args.prm))
    text = re.sub(r"(set Source\s*=\s*)(?!builtin:)(\S+)", lambda m: m.group(1) + os.path.join(source_dir, m.group(2)), text)
    open(prm, "w").write(with_contact_lines(text, [f"set Validation points = {points}", "set Validity analysis = true"]))
    run = subprocess.run([args.binary, prm, "--output-dir", args.workdir], capture_output=True, text=True)
    if run.returncode != 0:
        sys.stderr.write(run.stdout[-3000:] + run.stderr[-3000:])
        return run.returncode
    report = json.load(open(os.path.join(args.workdir, "report.json")))
    curves = {(c["vertex"]): (s["name"], c) for s in report["spaces"] for c in s.get("validity", [])}
    print("| space | vertex | position [mm] | map F1 / F5 / F10 [N] | full solve [N] | map's error | full solve [s] |")
    print("|---|---|---|---|---|---|---|")
    for v, x, forces in contacts:
        if v not in curves:
            print(f"| – | {v} | {', '.join(f'{1e3 * c:.1f}' for c in x)} | no full solve (not a validity contact) |")
            continue
        name, curve = curves[v]
        full = [curve["validity_force_n"][d] for d in DEPARTURES]
        reached = [f is not None and f < NOT_REACHED and f <= curve["force_reached_n"] for f in full]
        error = [f"{m / f - 1:+.0%}" if ok and m < NOT_REACHED else "–" for m, f, ok in zip(forces, full, reached)]
        shown = lambda values: " / ".join("not reached" if f is None or f >= NOT_REACHED else f"{f:.3g}" for f in values)
        print(f"| {name} | {v} | {', '.join(f'{1e3 * c:.1f}' for c in x)} | {shown(forces)} | {shown(full)} "
              f"| {' / '.join(error)} | {curve['seconds']:.1f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())

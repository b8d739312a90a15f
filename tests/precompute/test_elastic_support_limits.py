#!/usr/bin/python3
"""Elastic supports between their limits (docs/supports.md): the block of block.geo (40 x 40 x 10 mm steel,
its bottom face z = 0 named 'clamp') on an elastic foundation 'surface clamp : elastic KN KT'.

Every run is on one mesh (gmsh run once on block.geo, 5 mm, passed as a .msh).

Asserted:
* stiff limit: with KN = KT = 1e4 and 1e6 x E / thickness [N/m^3] the frequencies approach the clamped
  block's ('surface clamp : clamp'): the largest relative difference over the 8 lowest modes is below
  1e-5 at 1e6 x E / t (measured 8e-7), and falls as 1 / K: the difference at 1e6 is below 0.05 x the
  one at 1e4 (measured 0.01);
* soft limit: with KN = KT = 1e-9 x E / t the six lowest modes (the block riding on the soft
  foundation, ~2-3 Hz) lie below 1e-3 of the 7th (17 kHz), modes 7-12 equal the free block's elastic
  modes ('Clamp groups =' empty, no supports, shift -2000 Hz) within 1e-4 relative (measured 1e-8),
  and the six low ones equal a rigid block's on that foundation within 1e-4 (rigid_block_on_foundation);
* the free block has 6 rigid-body modes.
"""
import math
import os
import subprocess
import sys

import numpy as np
import scipy.linalg

from precompute_run import Checks, binary_and_fresh_workdir, run_precompute, test_prm

HERE = os.path.dirname(os.path.abspath(__file__))
E, NU, RHO = 2e11, 0.3, 7850.0  # as elastic_block.prm sets them
SIDE, THICKNESS = 0.04, 0.01    # m
N_MODES = 12
MESH = None        # the block's mesh, written by main()


def scene(name, supports, modes, shift=0.0, clamp_groups=None):
    """elastic_block.prm on MESH (made once by gmsh from block.geo)."""
    entries = {"Scene/Name": name, "Geometry/Source": MESH, "Geometry/Supports": supports,
               "Modes/Maximum number of modes": modes, "Modes/Minimum number of modes": modes, "Modes/Shift": shift}
    if clamp_groups is not None:
        entries["Geometry/Clamp groups"] = clamp_groups
    return test_prm("elastic_block.prm", entries=entries)


def frequencies(binary, workdir, name, *scene_args, **scene_kwargs):
    report, _ = run_precompute(binary, os.path.join(workdir, name), scene(name, *scene_args, **scene_kwargs))
    space = report["spaces"][0]
    f = np.array(space["frequencies_hz"])
    print(f"{name}: rigid-body modes {space['rigid_body_modes']['count']}, f [Hz] {np.round(f, 3).tolist()}")
    return f, space


def rigid_block_on_foundation(kn, kt):
    """The six frequencies [Hz] of the rigid block on a Winkler foundation under its face z = 0
    (normal kn, tangential kt per area): z translation sqrt(kn A / m); spin about z
    sqrt(kt I_p / J_z) (I_p = a^4 / 6 the face's polar moment, J_z = m a^2 / 6); and twice (x and y)
    sliding u of the centre of mass coupled with rocking theta about it: the face moves by
    u - theta t / 2 tangentially and theta x normally, so K = [[kt A, -kt A t/2], [-kt A t/2,
    kt A t^2/4 + kn I]], M = diag(m, J_c), I = a^4 / 12, J_c = m (a^2 + t^2) / 12."""
    a, t = SIDE, THICKNESS
    area, mass = a * a, RHO * a * a * t
    stiffness = np.array([[kt * area, -kt * area * t / 2], [-kt * area * t / 2, kt * area * t**2 / 4 + kn * a**4 / 12]])
    inertia = np.diag([mass, mass * (a * a + t * t) / 12])
    coupled = np.sqrt(scipy.linalg.eigh(stiffness, inertia, eigvals_only=True))
    omega = [math.sqrt(kn * area / mass), math.sqrt(kt * a**4 / 6 / (mass * a * a / 6))] + 2 * list(coupled)
    return np.sort(omega) / (2 * math.pi)


def main():
    args = binary_and_fresh_workdir()
    global MESH
    MESH = os.path.join(args.workdir, "block.msh")
    subprocess.run(["gmsh", os.path.join(HERE, "block.geo"), "-3", "-setnumber", "Mesh.MeshSizeMax", "5",
                    "-o", MESH], check=True, stdout=subprocess.DEVNULL)
    checks = Checks()
    scale = E / THICKNESS   # N/m^3

    clamped, _ = frequencies(args.binary, args.workdir, "clamped", "surface clamp : clamp", 8)
    errors = {}
    for factor in (1e4, 1e6):
        k = factor * scale
        f, _ = frequencies(args.binary, args.workdir, f"stiff_{int(math.log10(factor))}", f"surface clamp : elastic {k:g} {k:g}", 8)
        errors[factor] = float(np.max(np.abs(f - clamped) / clamped))
        print(f"  K = {factor:g} E/t = {k:.3g} N/m^3: max relative difference from clamped {errors[factor]:.3e}")
    checks.below("K = 1e6 E/t vs clamped, max relative difference", errors[1e6], 1e-5)
    checks.below("difference at 1e6 E/t / difference at 1e4 E/t", errors[1e6] / errors[1e4], 0.05)

    free, free_space = frequencies(args.binary, args.workdir, "free", "", N_MODES, shift=-2000.0, clamp_groups="")
    checks.below("free block: rigid-body modes (|6 - count|)", abs(free_space["rigid_body_modes"]["count"] - 6), 0)
    k = 1e-9 * scale
    soft, soft_space = frequencies(args.binary, args.workdir, "soft", f"surface clamp : elastic {k:g} {k:g}", N_MODES,
                                   shift=-2000.0)
    checks.below("soft: 6 lowest f / 7th f, max", float(np.max(np.abs(soft[:6])) / soft[6]), 1e-3)
    checks.below("soft modes 7-12 vs free elastic modes, max relative",
                 float(np.max(np.abs(soft[6:] - free[6:]) / free[6:])), 1e-4)

    rigid = rigid_block_on_foundation(k, k)
    print("  rigid block on the foundation [Hz]:", np.round(rigid, 4).tolist())
    print("  soft foundation's six lowest [Hz]:", np.round(soft[:6], 4).tolist(),
          f"(reported as rigid-body modes: {soft_space['rigid_body_modes']['count']})")
    checks.below("soft: 6 lowest vs rigid block on the foundation, max relative",
                 float(np.max(np.abs(soft[:6] - rigid) / rigid)), 1e-4)

    return checks.exit_code()


if __name__ == "__main__":
    sys.exit(main())

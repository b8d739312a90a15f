#!/usr/bin/python3
"""End to end: the small scene's basis, precomputed by modal-precompute, played by `modal-rt run`.

For each VOI space, a rigid probe (admittance) lands on one of the space's validation vertices and
pushes with a constant force into the part. Asserted from stats.json: the run switched to that
space, the HIP is in contact at that vertex, the settled felt displacement equals force times the
full static FE response stored in the basis (to 1e-5 relative: the kernel's verify tolerance for
float32 display modes), no allocation in the haptic thread and no non-finite output."""
import argparse
import json
import os
import subprocess
import sys

import numpy as np

import mrt_reader

FORCE_N = -2.0  # along z, into the top face
VALIDATION_CASES, VALIDATION_RESPONSE, SPACE_NAME, DISPLAY_VERTICES = 26, 27, 17, 1
TOLERANCE = 1e-5


def pressed_case(sections, space):
    """A validation vertex of the space pushed in z, and its full static response [m/N]."""
    cases = sections[(VALIDATION_CASES, space, mrt_reader.SCENE_WIDE)].reshape(-1, 2)
    responses = sections[(VALIDATION_RESPONSE, space, mrt_reader.SCENE_WIDE)].reshape(-1, 3)
    k = next(k for k, (vertex, direction) in enumerate(cases) if direction == 2)
    return int(cases[k][0]), responses[k]


def play(modal_rt, basis, workdir, name, position):
    session = os.path.join(workdir, f"{name}.csv")
    with open(session, "w") as f:
        f.write("time,hip,event,x,y,z\n"
                f"0,0,target,{position[0]!r},{position[1]!r},{position[2]!r}\n"
                "0,0,force,0,0,0\n"
                f"0.2,0,force,0,0,{FORCE_N!r}\n"
                "1.0,-,end\n")
    output = os.path.join(workdir, name)
    subprocess.run([modal_rt, "run", "--basis", basis, "--session", session, "--output-dir", output,
                    "--mode", "admittance", "--device", "probe", "--no-plot", "--quiet"], check=True)
    with open(os.path.join(output, "stats.json")) as f:
        return json.load(f)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--modal-rt", required=True)
    parser.add_argument("--basis", required=True)
    parser.add_argument("--workdir", required=True)
    args = parser.parse_args()
    os.makedirs(args.workdir, exist_ok=True)
    header, sections = mrt_reader.read(args.basis)
    vertices = sections[(DISPLAY_VERTICES, mrt_reader.SCENE_WIDE, mrt_reader.SCENE_WIDE)].reshape(-1, 3)

    failures = []
    for space in range(1, header["n_spaces"]):
        name = bytes(sections[(SPACE_NAME, space, mrt_reader.SCENE_WIDE)]).decode()
        vertex, response = pressed_case(sections, space)
        stats = play(args.modal_rt, args.basis, args.workdir, name, vertices[vertex])
        final = stats["final"][0]
        felt = np.array(final["position"]) - vertices[vertex]
        expected = FORCE_N * response
        error = np.linalg.norm(felt - expected) / np.linalg.norm(expected)
        print(f"space {space} '{name}', vertex {vertex}: felt displacement {felt} m, full FE {expected} m, "
              f"relative error {error:.2e}; switches {stats['switches']}, allocations after start "
              f"{stats['allocations_after_start']}, non-finite outputs {stats['non_finite_outputs']}")
        checks = {
            "in contact at the validation vertex": final["in_contact"] == 1 and final["active_vertex"] == vertex,
            "switched to the VOI's space": final["space"] == space and stats["switches"] >= 1,
            f"settled displacement within {TOLERANCE} of full FE": error <= TOLERANCE,
            "no allocation after start": stats["allocations_after_start"] == 0,
            "no non-finite output": stats["non_finite_outputs"] == 0,
            "every tick ran": stats["ticks"] == round(stats["rate_hz"] * 1.0),
        }
        failures += [f"space '{name}': {what}" for what, ok in checks.items() if not ok]

    for failure in failures:
        print("FAILED:", failure)
    cases = header["n_spaces"] - 1
    failed = len({failure.split(":")[0] for failure in failures})
    print(f"{cases - failed} passed, {failed} failed")
    return 1 if failures or cases == 0 else 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/python3
"""Numerical stability across scales: one mesh of a 40 x 40 x 10 mm block (block.geo), given once in
mm and once in m, with materials from a gel (E = 1e3 Pa) to steel (E = 2e11 Pa).

Elasticity has no intrinsic scale: the frequencies of a part of size L obey f L / sqrt(E / rho) = const
and its compliances obey u E L / F = const. Every run must give the same dimensionless frequencies and
felt compliances to 1e-10 relative (the precompute works in SI whatever the input unit, and the
factorization and eigensolve must not lose digits when K is 1e-6 or 1e8 times another), and the
self-checks and the static correction must stay as good as at the nominal scale."""
import math
import os
import shutil
import sys

from precompute_run import binary_and_fresh_workdir, run_precompute, test_prm

HERE = os.path.dirname(os.path.abspath(__file__))
TOLERANCE = 1e-10

# (name, length unit [m] of the mesh file's numbers, mesh file, E [Pa], nu, density [kg/m^3])
CASES = [
    ("abs_mm", 1e-3, "block_mm.msh", 2.3e9, 0.35, 1050.),
    ("abs_m", 1.0, "block_m.msh", 2.3e9, 0.35, 1050.),
    ("gel_mm", 1e-3, "block_mm.msh", 1e3, 0.35, 1000.),
    ("steel_mm", 1e-3, "block_mm.msh", 2e11, 0.35, 7850.),
    ("steel_m", 1.0, "block_m.msh", 2e11, 0.35, 7850.),
]


def scene(source, length_unit, youngs_modulus, poissons_ratio, density):
    return test_prm("scale_invariance_block.prm", entries={
        "Geometry/Source": source, "Geometry/Length unit": length_unit, "Material/Young's modulus": youngs_modulus,
        "Material/Poisson's ratio": poissons_ratio, "Material/Density": density})


def scaled_msh(source, target, factor):
    """The same MSH 4.1 ASCII mesh with every coordinate (nodes and entity bounding boxes) times factor."""
    lines = open(source).read().split("\n")
    out, i = [], 0
    while i < len(lines):
        line = lines[i]
        out.append(line)
        i += 1
        if line == "$Entities":
            counts = [int(x) for x in lines[i].split()]
            out.append(lines[i])
            i += 1
            for dim, count in enumerate(counts):
                n_coordinates = 3 if dim == 0 else 6
                for _ in range(count):
                    fields = lines[i].split()
                    fields[1:1 + n_coordinates] = [repr(float(x) * factor) for x in fields[1:1 + n_coordinates]]
                    out.append(" ".join(fields))
                    i += 1
        elif line == "$Nodes":
            n_blocks = int(lines[i].split()[0])
            out.append(lines[i])
            i += 1
            for _ in range(n_blocks):
                header = lines[i].split()
                out.append(lines[i])
                i += 1
                parametric, n_nodes = int(header[2]), int(header[3])
                assert parametric == 0, "parametric nodes are not expected in a tet mesh"
                out.extend(lines[i:i + n_nodes])  # node tags
                i += n_nodes
                for _ in range(n_nodes):
                    out.append(" ".join(repr(float(x) * factor) for x in lines[i].split()))
                    i += 1
    with open(target, "w") as f:
        f.write("\n".join(out))


def dimensionless(report, size_m, youngs_modulus, density):
    """f L / sqrt(E / rho) of the global space's modes, and u E L / F of its validation cases."""
    space = report["spaces"][0]
    wave_speed = math.sqrt(youngs_modulus / density)
    frequencies = [f * size_m / wave_speed for f in space["frequencies_hz"]]
    compliances = [u * youngs_modulus * size_m for case in space["validation"]
                   for u in case["full_contact_response_m_per_n"]]
    return frequencies, compliances, space


def main():
    args = binary_and_fresh_workdir()

    # One mesh for every case (gmsh is not reproducible): meshed once from block.geo, then scaled.
    run_precompute(args.binary, os.path.join(args.workdir, "mesh"),
        scene(os.path.join(HERE, "block.geo"), 1e-3, 2.3e9, 0.35, 1050.))
    shutil.copy(os.path.join(args.workdir, "mesh", "mesh_global.msh"), os.path.join(args.workdir, "block_mm.msh"))
    scaled_msh(os.path.join(args.workdir, "block_mm.msh"), os.path.join(args.workdir, "block_m.msh"), 1e-3)

    failures = []
    reference = None
    for name, unit, mesh, E, nu, density in CASES:
        report, _ = run_precompute(args.binary, os.path.join(args.workdir, name),
                     scene(os.path.join(args.workdir, mesh), unit, E, nu, density))
        size_m = 40e-3  # the block's width, whatever unit its mesh is written in
        frequencies, compliances, space = dimensionless(report, size_m, E, density)
        corrected = max(c["contact_rel_error_corrected"] for c in space["validation"])
        print(f"{name:9s} f1 = {space['frequencies_hz'][0]:.6e} Hz, f1 L/c = {frequencies[0]:.15e}, "
              f"orthonormality {space['orthonormality_error']:.1e}, residual {space['max_relative_residual']:.1e}, "
              f"corrected contact error {corrected:.1e}")
        if space["orthonormality_error"] > 1e-10 or space["max_relative_residual"] > 1e-6 or corrected > 1e-8:
            failures.append(f"{name}: self-checks or static correction degraded")
        if reference is None:
            reference = (name, frequencies, compliances)
            continue
        worst_f = max(abs(a - b) / abs(b) for a, b in zip(frequencies, reference[1]))
        worst_u = max(abs(a - b) / max(abs(x) for x in reference[2]) for a, b in zip(compliances, reference[2]))
        print(f"          against {reference[0]}: dimensionless frequencies differ by {worst_f:.1e}, "
              f"compliances by {worst_u:.1e} (relative)")
        if worst_f > TOLERANCE or worst_u > TOLERANCE:
            failures.append(f"{name}: differs from {reference[0]} by {max(worst_f, worst_u):.1e} > {TOLERANCE}")

    for failure in failures:
        print("FAILED:", failure)
    failed_cases = len({failure.split(":")[0] for failure in failures})
    print(f"{len(CASES) - failed_cases} passed, {failed_cases} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

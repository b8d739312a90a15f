#!/usr/bin/python3
"""A symmetry plane (docs/supports.md): a part modelled whole and as a half with
'plane 0 0 0 1 0 0 : symmetry'.

The part: a steel bar 40 x 20 x 10 mm (x in [-20, 20], y in [0, 20], z in [0, 10]) clamped on its
face y = 0, symmetric about the plane x = 0. The test writes both meshes itself (MSH 2.2 ASCII): the
half x in [0, 20] as a structured grid of cubes split into six tets each (Kuhn's split, conforming
between cubes), the whole as the half plus its mirror image x -> -x, sharing the nodes on x = 0, so
that the whole mesh is exactly the mirror-union of the half (no interface triangles on x = 0 in the
whole; the half's x = 0 triangles form the group 'mirror'). Physical groups: volume 'part', surfaces
'clamp' (y = 0) and 'free' (the rest).

Asserted:
* the half (supports 'surface clamp : clamp; plane 0 0 0 1 0 0 : symmetry') and the whole
  ('surface clamp : clamp') run, neither with a rigid-body mode;
* every mode of the half equals the nearest mode of the whole to 1e-6 relative (the whole's
  symmetric modes: the same discrete problem restricted to u_x(0, y, z) = 0);
* the whole has modes the half does not have (its antisymmetric modes: at least 3 of its 12 lowest
  are farther than 1e-3 relative from every mode of the half);
* the half's mesh and the whole's differ by exactly the mirror (node count 2 n - n_plane);
* the whole with the older spelling 'Clamp groups = clamp' has the same frequencies (1e-10).
"""
import os
import sys

import numpy as np

from precompute_run import Checks, binary_and_fresh_workdir, run_precompute, test_prm

LX, LY, LZ = 20.0, 20.0, 10.0   # mm: the half's extent (the whole is x in [-LX, LX])
H = 2.5                         # mm: the cubes' edge
N_WHOLE, N_HALF = 12, 7         # modes computed

# Kuhn's split of the unit cube (corners numbered i + 2 j + 4 k) into six tets along the diagonal 0-7:
# the same split in every cube conforms across faces.
KUHN = [(0, 1, 3, 7), (0, 3, 2, 7), (0, 2, 6, 7), (0, 6, 4, 7), (0, 4, 5, 7), (0, 5, 1, 7)]


def half_mesh():
    """Nodes (n x 3) and tets (m x 4, positively oriented) of the half x in [0, LX]."""
    nx, ny, nz = (int(round(length / H)) for length in (LX, LY, LZ))
    grid = np.stack(np.meshgrid(np.linspace(0, LX, nx + 1), np.linspace(0, LY, ny + 1),
                                np.linspace(0, LZ, nz + 1), indexing="ij"), axis=-1)
    nodes = grid.reshape(-1, 3)
    index = np.arange(len(nodes)).reshape(nx + 1, ny + 1, nz + 1)
    tets = []
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                corner = [index[i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1)] for c in range(8)]
                tets += [[corner[v] for v in tet] for tet in KUHN]
    return nodes, orient(nodes, np.array(tets))


def orient(nodes, tets):
    a, b, c, d = (nodes[tets[:, v]] for v in range(4))
    negative = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) < 0
    tets[negative] = tets[negative][:, [0, 2, 1, 3]]
    return tets


def mirrored(nodes, tets):
    """The half plus its mirror x -> -x, the nodes on x = 0 shared."""
    on_plane = np.abs(nodes[:, 0]) < 1e-12
    image = np.full(len(nodes), -1)
    off = np.flatnonzero(~on_plane)
    image[on_plane] = np.flatnonzero(on_plane)
    image[off] = len(nodes) + np.arange(len(off))
    mirror_nodes = nodes[off] * np.array([-1.0, 1.0, 1.0])
    all_nodes = np.vstack([nodes, mirror_nodes])
    return all_nodes, orient(all_nodes, np.vstack([tets, image[tets]]))


def boundary_triangles(nodes, tets):
    """The faces of exactly one tet, oriented outwards."""
    count = {}
    for tet in tets:
        for skip in range(4):
            face = tuple(np.delete(tet, skip))
            key = tuple(sorted(face))
            count.setdefault(key, [0, face, tet[skip]])[0] += 1
    triangles = []
    for n, face, opposite in count.values():
        if n == 1:
            a, b, c = (nodes[v] for v in face)
            if np.dot(np.cross(b - a, c - a), nodes[opposite] - a) > 0:
                face = (face[0], face[2], face[1])
            triangles.append(face)
    return np.array(triangles)


def write_msh(path, nodes, tets):
    """MSH 2.2 ASCII: volume 'part' (1), surfaces 'clamp' (2: y = 0), 'free' (3), 'mirror' (4: x = 0)."""
    triangles = boundary_triangles(nodes, tets)
    centres = nodes[triangles].mean(axis=1)
    group = np.where(np.abs(centres[:, 1]) < 1e-9, 2, np.where(np.abs(centres[:, 0]) < 1e-9, 4, 3))
    lines = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat", "$PhysicalNames", "4",
             '2 2 "clamp"', '2 3 "free"', '2 4 "mirror"', '3 1 "part"', "$EndPhysicalNames",
             "$Nodes", str(len(nodes))]
    lines += [f"{i + 1} {x!r} {y!r} {z!r}" for i, (x, y, z) in enumerate(nodes.tolist())]
    lines += ["$EndNodes", "$Elements", str(len(triangles) + len(tets))]
    n = 0
    for g, tri in zip(group, triangles):
        n += 1
        lines.append(f"{n} 2 2 {g} {g} " + " ".join(str(v + 1) for v in tri))
    for tet in tets:
        n += 1
        lines.append(f"{n} 4 2 1 1 " + " ".join(str(v + 1) for v in tet))
    lines.append("$EndElements")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    return {g: int(np.sum(group == g)) for g in (2, 3, 4)}


def scene(name, msh, supports, modes, clamp_groups=None):
    entries = {"Scene/Name": name, "Geometry/Source": msh, "Geometry/Supports": supports,
               "Modes/Maximum number of modes": modes, "Modes/Minimum number of modes": modes}
    if clamp_groups is not None:
        entries["Geometry/Clamp groups"] = clamp_groups
    return test_prm("symmetry_block.prm", entries=entries)


def main():
    args = binary_and_fresh_workdir()
    nodes, tets = half_mesh()
    whole_nodes, whole_tets = mirrored(nodes, tets)
    half_msh, whole_msh = (os.path.join(args.workdir, f"{name}.msh") for name in ("half", "whole"))
    half_groups = write_msh(half_msh, nodes, tets)
    whole_groups = write_msh(whole_msh, whole_nodes, whole_tets)
    checks = Checks()
    n_plane = int(np.sum(np.abs(nodes[:, 0]) < 1e-12))
    print(f"half: {len(nodes)} nodes, {len(tets)} tets, boundary triangles {half_groups}; "
          f"whole: {len(whole_nodes)} nodes, {len(whole_tets)} tets, {whole_groups}")
    checks.below("whole mesh nodes vs 2 n - n_plane (difference)", abs(len(whole_nodes) - (2 * len(nodes) - n_plane)), 0)
    checks.below("symmetry-plane triangles in the whole mesh", whole_groups[4], 0)

    half, _ = run_precompute(args.binary, os.path.join(args.workdir, "half"),
                             scene("half", half_msh, "surface clamp : clamp; plane 0 0 0 1 0 0 : symmetry", N_HALF))
    whole, _ = run_precompute(args.binary, os.path.join(args.workdir, "whole"),
                              scene("whole", whole_msh, "surface clamp : clamp", N_WHOLE))
    fh = np.array(half["spaces"][0]["frequencies_hz"])
    fw = np.array(whole["spaces"][0]["frequencies_hz"])
    print("half  [Hz]:", np.round(fh, 4).tolist())
    print("whole [Hz]:", np.round(fw, 4).tolist())
    checks.below("rigid-body modes of the half", half["spaces"][0]["rigid_body_modes"]["count"], 0)
    checks.below("rigid-body modes of the whole", whole["spaces"][0]["rigid_body_modes"]["count"], 0)
    checks.below("half's highest mode within the whole's computed range (0 = yes)", 0 if fh[-1] <= fw[-1] * (1 + 1e-6) else 1, 0)
    for k, f in enumerate(fh):
        nearest = fw[np.argmin(np.abs(fw - f))]
        checks.below(f"half mode {k + 1} ({f:.4f} Hz) vs nearest whole mode ({nearest:.4f} Hz), rel.",
                     abs(f - nearest) / f, 1e-6)
    distance = np.array([np.min(np.abs(fh - f)) / f for f in fw])
    antisymmetric = int(np.sum(distance > 1e-3))
    print("whole modes absent from the half (antisymmetric):", np.round(fw[distance > 1e-3], 4).tolist())
    checks.below("whole modes absent from the half: 3 - count", max(0, 3 - antisymmetric), 0)

    # The older spelling of the same clamp ('Clamp groups = clamp', no Supports) gives the same modes.
    old = scene("whole_old", whole_msh, "", N_WHOLE, clamp_groups="clamp")
    fo = np.array(run_precompute(args.binary, os.path.join(args.workdir, "whole_old"), old)[0]["spaces"][0]["frequencies_hz"])
    checks.below("whole, 'Clamp groups = clamp' vs 'surface clamp : clamp', max rel.",
                 float(np.max(np.abs(fo - fw) / fw)), 1e-10)

    return checks.exit_code()


if __name__ == "__main__":
    sys.exit(main())

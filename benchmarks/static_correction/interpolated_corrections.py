#!/usr/bin/python3
"""Could a space correct fewer display vertices, at a documented density, and interpolate the rest?
Reads a run's .h5, in which every candidate of the space is corrected (the defaults), keeps a
Poisson-disk subset of the candidates at each radius, interpolates the residual compliance tensor
(the static correction, candidate_compliance) of every other candidate from its nearest kept ones on
the same side of the part, and prints how far the interpolated felt compliance is from the exact one.

  benchmarks/static_correction/interpolated_corrections.py RESULTS/ribbed_panel.h5 [SPACE] [RADII_MM]

Alike neighbours: kept candidates whose surface normal is within 25 degrees of the vertex's own (a
rib's top does not borrow from its side); the four nearest of them, weighted by 1 / distance^2. The
error is that of the compliance along the vertex's normal (the contract's area-weighted normal:
what a HIP pressing straight in feels), relative to the exact felt compliance (modes + correction),
and of the whole tensor (Frobenius norm, relative to the whole felt compliance's). 8 % is the
stiffness difference a person can tell apart."""
import os
import sys

import h5py
import numpy as np
from scipy.spatial import cKDTree

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tests", "precompute"))
from test_every_vertex_exact import vertex_normals  # noqa: E402  the contract's normals (mrt/surface_normals.h)

ALIKE = np.cos(np.radians(25.0))
NEIGHBOURS = 4


def poisson_disk(points, normals, radius, rng):
    """Candidates kept in random order unless an alike kept one lies within the radius."""
    grid, kept = {}, np.zeros(len(points), bool)
    for i in rng.permutation(len(points)):
        cell = tuple((points[i] // radius).astype(int))
        near = (j for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1)
                for j in grid.get((cell[0] + dx, cell[1] + dy, cell[2] + dz), ()))
        if not any(np.linalg.norm(points[j] - points[i]) < radius and normals[j] @ normals[i] > ALIKE for j in near):
            kept[i] = True
            grid.setdefault(cell, []).append(i)
    return np.flatnonzero(kept), np.flatnonzero(~kept)


def interpolation_weights(points, normals, kept, held):
    distance, nearest = cKDTree(points[kept]).query(points[held], k=4 * NEIGHBOURS)
    alike = np.einsum('hki,hi->hk', normals[kept[nearest]], normals[held]) > ALIKE
    first_alike = alike & (np.cumsum(alike, axis=1) <= NEIGHBOURS)
    weights = np.where(first_alike, 1.0 / np.maximum(distance, 1e-12) ** 2, 0.0)
    weights[weights.sum(axis=1) == 0, 0] = 1.0  # no alike one among the nearest: the nearest
    return weights / weights.sum(axis=1, keepdims=True), nearest


def main():
    path = sys.argv[1]
    space = sys.argv[2] if len(sys.argv) > 2 else "global"
    radii_mm = [float(r) for r in sys.argv[3].split(",")] if len(sys.argv) > 3 else [4.0, 6.0, 8.0, 12.0]
    with h5py.File(path, "r") as f:
        vertices = f["display_surface/vertices"][:]
        triangles = f["display_surface/triangles"][:]
        group = f["spaces/" + space]
        candidates = group["candidate_vertices"][:]
        residual = group["candidate_compliance"][:]
        modes = group["candidate_modes"][:]
        eigenvalues = group["eigenvalues"][:]
    felt = np.einsum('vir,r,vjr->vij', modes, 1.0 / eigenvalues, modes) + residual
    points = vertices[candidates]
    normals = vertex_normals(vertices, triangles)[candidates]
    rng = np.random.default_rng(1)
    print(f"{path}, space '{space}': {len(candidates)} corrected candidates")
    for radius_mm in radii_mm:
        kept, held = poisson_disk(points, normals, radius_mm * 1e-3, rng)
        weights, nearest = interpolation_weights(points, normals, kept, held)
        error = np.einsum('hk,hkij->hij', weights, residual[kept[nearest]]) - residual[held]
        n = normals[held]
        normal = np.abs(np.einsum('hi,hij,hj->h', n, error, n)) / np.einsum('hi,hij,hj->h', n, felt[held], n)
        whole = np.linalg.norm(error, axis=(1, 2)) / np.linalg.norm(felt[held], axis=(1, 2))
        print(f"  radius {radius_mm:g} mm: {len(kept)} corrected ({len(kept) / len(candidates):.2f} of them); "
              f"normal compliance error median {np.median(normal):.4f}, p90 {np.quantile(normal, 0.9):.3f}, "
              f"above 8 % at {np.mean(normal > 0.08):.3f} of the interpolated; "
              f"tensor error median {np.median(whole):.4f}, p90 {np.quantile(whole, 0.9):.3f}")


if __name__ == "__main__":
    main()

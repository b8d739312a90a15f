#!/usr/bin/python3
"""The .mrt basis file and the .h5 file of one run hold the same numbers (contract 2 of DESIGN.md):
every section of the .mrt equals its HDF5 dataset (exactly for doubles and integers; float32 modes
equal the doubles rounded to float32)."""
import argparse
import os
import sys

import h5py
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mrt_reader  # noqa: E402

SW = mrt_reader.SCENE_WIDE


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("results", help="a results folder with <scene>.mrt and <scene>.h5")
    parser.add_argument("--scene", required=True)
    args = parser.parse_args()
    header, s = mrt_reader.read(os.path.join(args.results, args.scene + ".mrt"))
    h5 = h5py.File(os.path.join(args.results, args.scene + ".h5"), "r")
    checks = []

    def same(name, mrt_values, h5_values, exact=True):
        a = np.asarray(mrt_values).ravel()
        b = np.asarray(h5_values).ravel()
        if a.dtype == np.float32:
            b = b.astype(np.float32)
        ok = a.shape == b.shape and (np.array_equal(a, b) if exact else np.allclose(a, b, rtol=0, atol=0))
        checks.append((name, ok))

    d = h5["display_surface"]
    same("display vertices", s[(1, SW, SW)], d["vertices"])
    same("display triangles", s[(2, SW, SW)], d["triangles"])
    same("display region", s[(3, SW, SW)], d["region"])
    same("patch offsets", s[(4, SW, SW)], d["patch_offsets"])
    same("patch vertices", s[(5, SW, SW)], d["patch_vertices"])
    same("patch weights", s[(6, SW, SW)], d["patch_weights"])
    spaces = sorted(h5["spaces"].values(), key=lambda g: g.attrs["index"])
    assert len(spaces) == header["n_spaces"]
    for g in spaces:
        k = int(g.attrs["index"])
        name = bytes(s[(17, k, SW)]).decode()
        same(f"{name}: name", np.frombuffer(name.encode(), np.uint8), np.frombuffer(g.name.split("/")[-1].encode(), np.uint8))
        r, nc, nval, ncross = s[(16, k, SW)]
        same(f"{name}: eigenvalues", s[(18, k, SW)], g["eigenvalues"])
        same(f"{name}: damping", s[(19, k, SW)], g["damping_ratios"])
        same(f"{name}: display modes", s[(20, k, SW)], g["display_modes"])
        same(f"{name}: participation", s[(25, k, SW)], g["participation"])
        if nc:
            same(f"{name}: candidates", s[(21, k, SW)], g["candidate_vertices"])
            same(f"{name}: candidate modes", s[(22, k, SW)], g["candidate_modes"])
            same(f"{name}: candidate compliance", s[(23, k, SW)], g["candidate_compliance"])
        if (28, k, SW) in s:
            same(f"{name}: cross offsets", s[(28, k, SW)], g["cross_offsets"])
            same(f"{name}: cross neighbours", s[(29, k, SW)], g["cross_neighbours"])
            same(f"{name}: cross blocks", s[(30, k, SW)], g["cross_blocks"])
        same(f"{name}: felt stiffness", s[(31, k, SW)], g["felt_stiffness"])
        if (33, k, SW) in s or "validity_force" in g:
            same(f"{name}: validity map", s.get((33, k, SW), []), g["validity_force"] if "validity_force" in g else [])
        if nval:
            same(f"{name}: validation cases", s[(26, k, SW)], g["validation_cases"])
            same(f"{name}: validation response", s[(27, k, SW)], g["validation_response"])
    for key, values in s.items():
        if key[0] == 32:
            to = bytes(s[(17, key[1], SW)]).decode()
            source = bytes(s[(17, key[2], SW)]).decode()
            same(f"transfer {to} <- {source}", values, h5["transfer"][f"{to}__from__{source}"])
    failed = [name for name, ok in checks if not ok]
    for name in failed:
        print("differs:", name)
    print(f"{len(checks) - len(failed)} passed, {len(failed)} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

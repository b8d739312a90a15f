#!/usr/bin/python3
"""Every display vertex a hand can reach is exact: on the small scene with the default
candidates (every display vertex of each region a corrected contact), at 20 random display vertices
inside each VOI and 20 outside (global space):

* the corrected felt compliance along x, y and z equals a fresh full static FE solve of that patch
  load (1e-8 relative; the random vertices are given as validation points, so the precompute solves
  each afresh, and `modal-rt verify` checks the kernel's own answer against those solves);
* the felt-stiffness map's normal stiffness equals 1 / (n^T G n) of the full solve's compliance G
  along the display surface's outward normal (1e-8); report.json's softest and stiffest spots carry
  that normal and the axis it faces, which the summary prints;
* 10 random pairs of neighbouring candidates per space pressed together equal one full solve each
  (the kernel's formula with the stored cross compliance, 1e-8);
* the far field (check_far_field): never more than a candidate's own residual compliance, and 10
  random pairs farther apart pressed together are nearer the full solve with it than without;
* 'Exact pair points' (check_exact_pair): the two random vertices of one VOI farthest apart, given as
  a pair: every candidate within 'Exact pair reach' (by default twice 'Patch radius': 3 mm here) of
  one point is stored as a neighbour of
  every such candidate of the other, and the nearest two pressed together equal one full solve (1e-8)
  though the far field alone would couple them; scripts/summarize_report.py (scripts/demo's summary)
  prints that check.
The first run (no validation) gives the display surface and its regions; the second reuses its meshes.
"""
import os
import subprocess
import sys

import h5py
import numpy as np

from precompute_run import Checks, binary_and_fresh_workdir, run_precompute

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES_PER_REGION = 20
PAIRS_PER_SPACE = 10
DEFAULT_REACH_M = 2 * 1.5e-3  # twice small_scene.prm's 'Patch radius' (1.5 mm)


def scene_text(extra_contact):
    """small_scene.prm with the default candidates (every vertex) and the given Contact lines."""
    lines = []
    for line in open(os.path.join(HERE, "small_scene.prm")):
        if line.strip().startswith(("set Global candidate stride", "set Maximum candidates", "set Validation samples",
                                    "set Cross compliance radius")):
            continue
        if line.strip().startswith("set Source"):  # the scene's .prm is written into another folder
            line = f"  set Source = {os.path.join(HERE, 'block.geo')}\n"
        if line.strip() == "subsection Contact":
            lines.append(line)
            lines.extend(f"  {entry}\n" for entry in extra_contact)
            continue
        lines.append(line)
    return "".join(lines)


def vertex_normals(x, triangles):
    """The contract's normals (mrt/surface_normals.h): area-weighted, normalized."""
    n = np.zeros_like(x)
    face = np.cross(x[triangles[:, 1]] - x[triangles[:, 0]], x[triangles[:, 2]] - x[triangles[:, 0]])
    for k in range(3):
        np.add.at(n, triangles[:, k], face)
    return n / np.linalg.norm(n, axis=1)[:, None]


def axis_faced(n):
    """The coordinate axis nearest to a normal: '+z', '-x', ..."""
    axis = int(np.abs(n).argmax())
    return ("-" if n[axis] < 0 else "+") + "xyz"[axis]


def check_far_field(space, g, expect):
    """Two candidates without a stored block, coupled by the far field's factor Z (FAR_COMPLIANCE):
    what the factor leaves out of each candidate's own residual compliance, C_aa - Z_a Z_a^T, is
    positive semi-definite (the Nystrom approximation never overshoots, so a pair's compliance stays
    positive definite), and far pairs pressed together (one full solve each) are nearer the full FE
    answer with it than with the modes alone."""
    far = space.get("far_field")
    expect(far is not None, f"{space['name']}: report.json has its far field")
    if far is None:
        return
    if far["rank"] == 0:  # not kept: the precompute's rule, and it says why
        expect(far["rms_error"] >= 0.5 * far["rms_modes_alone"] and "left_out" in far,
               f"{space['name']}: far field not kept, its sampled rms error {far['rms_error']:.3f} is not below half "
               f"of the modes alone's {far['rms_modes_alone']:.3f}")
        return
    C = g["candidate_compliance"][:]
    Z = g["far_compliance"][:]
    left = C - np.einsum("aik,ajk->aij", Z, Z)
    worst = min(np.linalg.eigvalsh(0.5 * (E + E.T)).min() / np.linalg.norm(c, 2) for E, c in zip(left, C))
    expect(Z.shape == (len(C), 3, far["rank"]) and worst >= -1e-9,
           f"{space['name']}: C_aa - Z_a Z_a^T >= 0 at every candidate (rank {far['rank']}; smallest eigenvalue "
           f"{worst:.1e} of |C_aa|)")
    expect(far["rms_error"] < 0.5 * far["rms_modes_alone"],
           f"{space['name']}: sampled pairs' residual coupling error, rms {far['rms_error']:.3f} with the far field "
           f"< half of {far['rms_modes_alone']:.3f} with the modes alone")
    pairs = [p for p in space["two_contact_checks"] if p["far"]]
    with_far = np.median([p["rel_error_corrected"] for p in pairs]) if pairs else np.inf
    without = np.median([p["rel_error_without_cross"] for p in pairs]) if pairs else 0.0
    expect(len(pairs) == PAIRS_PER_SPACE and with_far < without,
           f"{space['name']}: {len(pairs)} far pairs pressed together vs one full solve each: median error "
           f"{with_far:.3f} with the far field < {without:.3f} with the modes alone")


def check_exact_pair(space, g, x, ends, expect):
    """The cross rows of an exact pair (module docstring): the candidates within the default 'Exact
    pair reach' of each end, all linked; the nearest pair validated against one full solve."""
    candidates = g["candidate_vertices"][:]
    offsets, neighbours = g["cross_offsets"][:], g["cross_neighbours"][:]
    around = [np.flatnonzero(np.linalg.norm(x[candidates] - x[v], axis=1) <= DEFAULT_REACH_M) for v in ends]
    missing = sum(b not in neighbours[offsets[a]:offsets[a + 1]] for a in around[0] for b in around[1] if a != b)
    expect(len(around[0]) >= 3 and len(around[1]) >= 3 and missing == 0,
           f"{space['name']}: {len(around[0])} x {len(around[1])} candidates around the exact pair's two points "
           f"({1e3 * np.linalg.norm(x[ends[0]] - x[ends[1]]):.1f} mm apart) all stored as neighbours ({missing} missing)")
    named = [p for p in space["two_contact_checks"] if p["named"]]
    expect(len(named) == 1 and sorted(named[0]["vertices"]) == sorted(int(v) for v in ends)
           and not named[0]["far"] and named[0]["rel_error_corrected"] <= 1e-8,
           f"{space['name']}: the exact pair pressed together vs one full solve: "
           + (f"error {named[0]['rel_error_corrected']:.2e} <= 1e-8 (the modes alone between them "
              f"{named[0]['rel_error_without_cross']:.2e})" if named else "no check"))


def main():
    args = binary_and_fresh_workdir(required=("--modal-rt",))
    first = os.path.join(args.workdir, "surface")
    run_precompute(args.binary, first, scene_text(["set Validation samples = 0"]))
    with h5py.File(os.path.join(first, "small_block.h5"), "r") as h5:
        x = h5["display_surface/vertices"][:]
        region = h5["display_surface/region"][:]
        # Where a hand can press: not on the clamped bottom face (its compliance is round-off, the
        # map says 0 there).
        reachable = np.zeros(len(region), bool)
        for g in h5["spaces"].values():
            reachable |= (g["felt_stiffness"][:] > 0) & (region == g.attrs["index"])
    random = np.random.default_rng(36)
    picked = np.concatenate([random.choice(np.flatnonzero((region == s) & reachable), SAMPLES_PER_REGION,
                                           replace=False) for s in np.unique(region)])
    def mm(v):  # the scene is in mm
        return ", ".join(f"{1e3 * c:.12g}" for c in x[v])
    points = "; ".join(mm(v) for v in picked)
    # The exact pair: the two random vertices of the last VOI farthest apart (display vertices, so
    # each end's nearest candidate is that vertex).
    in_voi = picked[region[picked] == region.max()]
    distances = np.linalg.norm(x[in_voi][:, None] - x[in_voi][None], axis=2)
    ends = in_voi[list(np.unravel_index(distances.argmax(), distances.shape))]

    folder = os.path.join(args.workdir, "exact")
    report, _ = run_precompute(args.binary, folder, scene_text([
        "set Validation samples = 0", f"set Validation pairs = {PAIRS_PER_SPACE}", f"set Validation points = {points}",
        f"set Exact pair points = {mm(ends[0])} : {mm(ends[1])}"]),
        meshes_from=first)
    expect = Checks()

    with h5py.File(os.path.join(folder, "small_block.h5"), "r") as h5:
        triangles = h5["display_surface/triangles"][:]
        normals = vertex_normals(h5["display_surface/vertices"][:], triangles)
        for space in report["spaces"]:
            g = h5["spaces"][space["name"]]
            own = np.flatnonzero(region == space["index"])
            corrected = set(int(v) for v in g["candidate_vertices"][:])
            expect(set(int(v) for v in own) <= corrected,
                   f"{space['name']}: every one of its region's {len(own)} display vertices is a corrected contact")
            # The global space corrects the VOIs' vertices too ('Contact/Global candidates in VOIs', on by
            # default), so that two hands in two regions stay corrected there; a VOI's space only its own.
            wanted = len(region) if space["index"] == 0 else len(own)
            expect(len(corrected) == wanted,
                   f"{space['name']}: {len(corrected)} corrected contacts, {wanted} expected")
            cases, response = g["validation_cases"][:], g["validation_response"][:]
            worst_map, checked = 0.0, 0
            for v in picked[region[picked] == space["index"]]:
                columns = {int(d): response[k] for k, (vertex, d) in enumerate(cases) if vertex == v}
                G = np.column_stack([columns[d] for d in range(3)])
                k_full = 1.0 / (normals[v] @ G @ normals[v])
                worst_map = max(worst_map, abs(g["felt_stiffness"][v] - k_full) / k_full)
                checked += 1
            expect(checked == SAMPLES_PER_REGION,
                   f"{space['name']}: {checked} random vertices of its region validated in x, y and z")
            corrected = max(c["contact_rel_error_corrected"] for c in space["validation"])
            expect(corrected <= 1e-8, f"{space['name']}: corrected felt compliance vs full FE, worst {corrected:.2e} <= 1e-8")
            expect(worst_map <= 1e-8, f"{space['name']}: felt-stiffness map vs full FE normal stiffness, worst "
                                      f"{worst_map:.2e} <= 1e-8")
            pairs = [p for p in space["two_contact_checks"] if not p["far"] and not p["named"]]
            worst_pair = max((p["rel_error_corrected"] for p in pairs), default=np.inf)
            expect(len(pairs) == PAIRS_PER_SPACE and worst_pair <= 1e-8,
                   f"{space['name']}: {len(pairs)} pairs of neighbours pressed together vs one full solve each, worst "
                   f"{worst_pair:.2e} <= 1e-8 (up to {1e3 * max(p['distance_m'] for p in pairs):.2f} mm apart)")
            spots = space["felt_stiffness"]["softest"] + space["felt_stiffness"]["stiffest"]
            wrong = [p["vertex"] for p in spots if np.abs(np.array(p["normal"]) - normals[p["vertex"]]).max() > 1e-12
                     or p["facing"] != axis_faced(normals[p["vertex"]])]
            expect(not wrong, f"{space['name']}: the map's softest and stiffest spots carry the contract's normal and "
                              f"the axis it faces (wrong at {wrong})")
            check_far_field(space, g, expect)
            if space["index"] == region.max():
                check_exact_pair(space, g, x, ends, expect)
    summary = subprocess.run([sys.executable, os.path.join(HERE, "..", "..", "scripts", "summarize_report.py"),
                              os.path.join(folder, "report.json")], capture_output=True, text=True)
    voi = next(space["name"] for space in report["spaces"] if space["index"] == region.max())
    named = [line for line in summary.stdout.splitlines() if line.startswith(f"exact pair points, {voi}: ")]
    expect(summary.returncode == 0 and len(named) == 1 and f"vertices {ends[0]} and {ends[1]}" in named[0],
           f"scripts/summarize_report.py prints the exact pair's check in '{voi}': {named}")
    felt = [line for line in summary.stdout.splitlines() if line.startswith("felt stiffness, ")]
    expect(len(felt) == len(report["spaces"]) and all(": pressed along -n)" in line for line in felt),
           f"scripts/summarize_report.py says which way each softest spot faces: {felt}")
    verify = subprocess.run([args.modal_rt, "verify", "--basis", os.path.join(folder, "small_block.mrt")],
                            capture_output=True, text=True)
    print(verify.stdout[-1500:])
    expect(verify.returncode == 0, "modal-rt verify: the kernel's felt compliance equals every full solve")
    return expect.exit_code()


if __name__ == "__main__":
    sys.exit(main())

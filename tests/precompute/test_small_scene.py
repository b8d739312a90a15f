#!/usr/bin/python3
"""Self-checks of a whole precompute run on a small scene (two VOIs + global):

* the eigenpairs check themselves: max |Phi^T M Phi - I| < 1e-10, max relative residual < 1e-8;
* every output exists (h5, mrt, report.json, used_parameters.prm, VTU/PVD per space);
* the static correction is exact: corrected contact error <= 1e-8 for every validated candidate
  and direction, for one contact and for two simultaneous contacts, while the modal-only error is
  honest (non-zero);
* the default block Krylov eigensolver and ARPACK give the same eigenvalues (relative 1e-9); ARPACK
  runs with a haptic cut-off above the global space's 9th mode (between two modes 2 % apart), a floor
  of 4 and at most 24 modes: it computes fewer than 24 (a first run of 8, then 8 more in their
  complement), keeps those below the cut-off, and its first 12 equal the block Krylov method's 12;
* transfer: the normal equations of a space onto itself give the identity; a field that lies in
  both spaces (the global space's first modes, smooth) is carried into each VOI space with < 5 % error;
* the BLAS: report.json names OpenBLAS's kernels, and on a CPU with AVX2 and FMA (unless the test's
  environment sets OPENBLAS_CORETYPE) they are not the generic Prescott ones OpenBLAS falls back to
  on a model it does not know (the program then restarts with the CPU's: docs/cluster.md);
  unless the environment sets OPENBLAS_THREAD_TIMEOUT, the running OpenBLAS read 20 (its idle
  workers' spin, set by the program in its own process: report.json's processes.blas_thread_timeout);
* the VOIs' meshes: with more than one core allowed (and gmsh on one thread, the default), a child
  process made at least one of them beside the global mesh (report.json's mesh.made_in_child_process;
  MPI_Init's own environment once made every run look launched by mpirun, and nothing was forked).
"""
import json
import os
import subprocess
import sys

import h5py
import numpy as np

from precompute_run import Checks, binary_and_fresh_workdir, copy_meshes, cut_off_between, cut_off_checks

HERE = os.path.dirname(os.path.abspath(__file__))


def transfer(phi_to, phi_from, area):
    w = np.repeat(area, 3)[:, None]
    return np.linalg.solve(phi_to.T @ (w * phi_to), phi_to.T @ (w * phi_from))


def main():
    args = binary_and_fresh_workdir()
    subprocess.run([args.binary, os.path.join(HERE, "small_scene.prm"), "--output-dir", args.workdir], check=True)
    report = json.load(open(os.path.join(args.workdir, "report.json")))
    expect = Checks()

    for name in ["small_block.h5", "small_block.mrt", "used_parameters.prm"] + \
            [f"modes_{s}.{e}" for s in ["global", "left", "right"] for e in ["vtu", "pvd"]]:
        expect(os.path.getsize(os.path.join(args.workdir, name)) > 0, f"{name} written")
    head = open(os.path.join(args.workdir, "modes_left.vtu"), "rb").read(4096)
    expect(b'format="appended"' in head and b"compressor" not in head,
           "the mode-shape VTU is not compressed ('Output/VTU compression' = none by default): appended raw")
    expect([s["name"] for s in report["spaces"]] == ["global", "left", "right"], "three spaces, global first")
    blas_kernels = report["processes"]["blas_kernels"]
    cpu_flags = set(open("/proc/cpuinfo").read().split())
    expect(blas_kernels != "", "report.json names the OpenBLAS kernels that ran")
    if {"avx2", "fma"} <= cpu_flags and "OPENBLAS_CORETYPE" not in os.environ:
        expect(blas_kernels != "Prescott", f"a CPU with AVX2 and FMA runs OpenBLAS's kernels for it, not "
               f"the generic fallback ({blas_kernels})")
    if "OPENBLAS_THREAD_TIMEOUT" not in os.environ:
        spin = report["processes"]["blas_thread_timeout"]
        expect(spin == 20, f"OpenBLAS's idle workers spin 2^20 cycles, set in the running process (read: {spin})")
    made_in_child = [s["mesh"]["made_in_child_process"] for s in report["spaces"]]
    if len(os.sched_getaffinity(0)) > 1:
        expect(not made_in_child[0] and any(made_in_child[1:]),
               f"a child process meshed a VOI beside the global mesh (made in a child: {made_in_child})")
    for s in report["spaces"]:
        n = s["name"]
        expect(s["orthonormality_error"] < 1e-10, f"{n}: orthonormality error {s['orthonormality_error']:.2e} < 1e-10")
        expect(s["max_relative_residual"] < 1e-8, f"{n}: eigen-residual {s['max_relative_residual']:.2e} < 1e-8")
        expect(len(s["validation"]) >= 3, f"{n}: {len(s['validation'])} validation cases")
        for c in s["validation"]:
            expect(c["contact_rel_error_corrected"] <= 1e-8,
                   f"{n}: vertex {c['vertex']} {c['direction']}: corrected {c['contact_rel_error_corrected']:.1e} <= 1e-8"
                   f" (modal-only {c['contact_rel_error_modal']:.2e})")
            expect(c["contact_rel_error_modal"] > 1e-4, f"{n}: modal-only error is honest (non-zero)")
            expect(c["solve_relative_residual"] < 1e-10, f"{n}: full solve residual {c['solve_relative_residual']:.1e}")
        expect(s.get("two_contact_rel_error_corrected", 1.0) <= 1e-8,
               f"{n}: two contacts, corrected error {s.get('two_contact_rel_error_corrected')} <= 1e-8")

    with h5py.File(os.path.join(args.workdir, "small_block.h5"), "r") as h5:
        area = h5["display_surface/vertex_area"][:]
        phi = {n: h5[f"spaces/{n}/display_modes"][:].reshape(len(area) * 3, -1) for n in ["global", "left", "right"]}
        for n, p in phi.items():
            identity_error = np.abs(transfer(p, p, area) - np.eye(p.shape[1])).max()
            expect(identity_error < 1e-8, f"T({n} <- {n}) = I to {identity_error:.1e}")
        w = np.repeat(area, 3)
        for n in ["left", "right"]:
            T = h5[f"transfer/{n}__from__global"][:]
            for i in range(3):
                carried = phi[n] @ T[:, i]
                original = phi["global"][:, i]
                error = np.sqrt(np.sum(w * (carried - original) ** 2) / np.sum(w * original**2))
                expect(error < 0.05, f"global mode {i + 1} carried into {n}: error {error:.2e} < 5 %")
    # The same scene with ARPACK instead of the block Krylov method, under a cut-off that its first run
    # does not decide: the same eigenvalues, and no more computed than the cut-off needs. The meshes
    # are copied so that the cache reuses them (gmsh does not mesh twice the same).
    arpack_dir = os.path.join(args.workdir, "arpack")
    copy_meshes(args.workdir, arpack_dir)
    prm = open(os.path.join(HERE, "small_scene.prm")).read().replace("block.geo", os.path.join(HERE, "block.geo"))
    cut_off = cut_off_between(report["spaces"][0]["computed_frequencies_hz"])
    prm += ("\nsubsection Modes\n  set Eigensolver = arpack\n" + "".join(f"  set {line}\n" for line in cut_off) +
            "end\nsubsection Output\n  set VTU modes = 0\nend\n")
    open(os.path.join(arpack_dir, "arpack.prm"), "w").write(prm)
    subprocess.run([args.binary, os.path.join(arpack_dir, "arpack.prm"), "--output-dir", arpack_dir, "--quiet"], check=True)
    arpack = json.load(open(os.path.join(arpack_dir, "report.json")))
    for ours, theirs in zip(report["spaces"], arpack["spaces"]):
        expect(len(theirs["computed_frequencies_hz"]) >= len(ours["computed_frequencies_hz"]),
               f"{ours['name']}: ARPACK computed {len(theirs['computed_frequencies_hz'])} modes, at least the block "
               f"Krylov method's {len(ours['computed_frequencies_hz'])} ({theirs['eigensolver']['method']})")
        for condition, what in cut_off_checks(theirs, ours["computed_frequencies_hz"], 5e-10):
            expect(condition, "ARPACK, " + what)

    return expect.exit_code()


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/python3
"""The eigensolver path without a factorization (Modes/Eigensolver = lobpcg-amg) against the direct
path (block Krylov over CHOLMOD) on the same meshes.

Cases: the steel cantilever of cantilever.prm in P2 and in P1 (clamped), and the free beam of
free_beam.prm (six free rigid-body motions, Shift = -100 Hz), and the P2 cantilever's modes by three
LOBPCG runs of at most 3 modes (Modes/LOBPCG modes per run). For each:
* every computed frequency equal to the direct path's to 1e-8 relative (the rigid ones: both 0);
* the self-checks: max |Phi^T M Phi - I| <= 1e-10 and max ||K phi - lambda M phi|| / ||lambda M phi||
  <= 1e-5 (LOBPCG tolerance 1e-6; the eigenvalue error is about its square);
* every validation case's full static FE response (AMG-preconditioned CG, or its refinement against K
  with the shift) equal to the direct path's to 1e-8, and the corrected contact error <= 1e-8;
* the report names the method, and for P2 the preconditioner's vertex (P1) space.
Under a haptic cut-off above the P1 cantilever's 9th mode (a floor of 4, at most 24 modes) LOBPCG stops
once the cut-off decides the count: fewer than 24 computed (a first run of 8, a second in their
complement ended by the count's decision), those below the cut-off kept, equal to the direct path's.
And 'auto' with a factor memory limit below the cantilever's factor switches to lobpcg-amg, saying so,
and with the default limit factorizes; serially, with a limit below CHOLMOD's factor but above MUMPS's
in-core data with its factor on disk (the P2 cantilever at 2.5 mm), 'auto' and 'block-krylov' (with
'Factor storage = auto') hand the space to MUMPS on the one process, its factor on disk: frequencies
equal to CHOLMOD's to 1e-8, the self-checks, the factor files removed; a run killed (SIGKILL) while
its factor is on disk leaves its own subdirectory there, which the next run removes, saying so; the free beam with 'Factor storage = disk' exits non-zero naming it.
With --mpirun: the P2 cantilever (in one run and in three) under mpirun -np 2 (LOBPCG + AMG on the distributed path's Trilinos
matrices, its static solves one block CG per block of loads) against the same direct run, with the
same limits; and 'auto' there, decided by MUMPS's analysis, both ways.
"""
import os
import shutil
import subprocess
import sys
import time

from precompute_run import Checks, binary_and_fresh_workdir, copy_meshes, cut_off_between, cut_off_checks, \
    run_precompute
from test_mpi_np1_vs_np2 import mpi_command, mpi_environment

HERE = os.path.dirname(os.path.abspath(__file__))


def scene_text(prm_file, modes_lines, degree=2):
    """The test's .prm with extra Modes entries and the element degree."""
    with open(os.path.join(HERE, prm_file)) as f:
        text = f.read()
    text = text.replace("subsection Modes\n", "subsection Modes\n" + "".join(f"  set {line}\n" for line in modes_lines))
    # 5 mm, two tets across the section (the prm's 2.5 mm take ten times as long): the comparison
    # with the direct path does not need the resolution.
    text = text.replace("set Coarse size = 2.5", "set Coarse size = 5")
    # The end face's validation point alone is corrected, as before every display vertex became a
    # candidate by default: without a factor each load is a block CG solve.
    text = text.replace("subsection Contact\n", "subsection Contact\n  set Global candidate stride = 0\n")
    return text.replace("subsection Meshing\n", f"subsection Meshing\n  set Element degree = {degree}\n")


def space(report):
    return report["spaces"][0]


def run_pair(binary, workdir, name, prm_file, degree, checks, mpirun=None, amg_lines=()):
    """The direct path, then LOBPCG + AMG (with amg_lines among its Modes entries) on a copy of its
    meshes (meshing is not repeatable); with mpirun, the latter on 2 processes."""
    direct_dir, amg_dir = os.path.join(workdir, name + "_direct"), os.path.join(workdir, name + "_amg")
    for folder in (direct_dir, amg_dir):
        os.makedirs(folder)
        shutil.copy(os.path.join(HERE, "cantilever.geo"), folder)
    direct, _ = run_precompute(binary, direct_dir,
                               scene_text(prm_file, ["Eigensolver = block-krylov"], degree))
    amg, _ = run_precompute(binary, amg_dir, scene_text(prm_file, ["Eigensolver = lobpcg-amg", *amg_lines], degree),
                            meshes_from=direct_dir, launcher=mpi_command(mpirun, 2) if mpirun else (),
                            env=mpi_environment() if mpirun else None)
    d, a = space(direct), space(amg)
    print(f"--- {name}: {a['n_dofs']} DoFs (P{degree}), {len(a['computed_frequencies_hz'])} modes, "
          f"{a['rigid_body_modes']['count']} free motions")
    checks.below("the same mesh (DoFs differ by)", abs(a["n_dofs"] - d["n_dofs"]), 0)
    worst = max(abs(fa - fd) / max(abs(fd), 1e-300) if fd != 0 else abs(fa)
                for fa, fd in zip(a["computed_frequencies_hz"], d["computed_frequencies_hz"]))
    checks.below("frequencies vs the direct path (max relative difference)", worst, 1e-8)
    checks.below("max |Phi^T M Phi - I|", a["orthonormality_error"], 1e-10)
    checks.below("max ||K phi - lambda M phi|| / ||lambda M phi||", a["max_relative_residual"], 1e-5)
    for va, vd in zip(a["validation"], d["validation"]):
        ra, rd = va["full_contact_response_m_per_n"], vd["full_contact_response_m_per_n"]
        scale = max(abs(x) for x in rd)
        checks.below(f"full static response at vertex {va['vertex']} {va['direction']} vs direct",
                     max(abs(x - y) for x, y in zip(ra, rd)) / scale, 1e-8)
        checks.below(f"corrected contact error at vertex {va['vertex']} {va['direction']}",
                     va["contact_rel_error_corrected"], 1e-8)
    method = a["eigensolver"]["method"]
    checks.below("the report names LOBPCG (0: it does)", 0 if "LOBPCG" in method else 1, 0)
    if amg_lines:
        checks.below("the report says: 3 LOBPCG runs of at most 3 modes (0: it does)",
                     0 if "3 runs of at most 3 modes" in method else 1, 0)
    # P2 is preconditioned on its vertex (P1) space under Chebyshev smoothing, P1 by ML directly.
    on_vertex_space = "on the vertex (P1) space" in method
    checks.below(f"P{degree}: the AMG works {'on the vertex space' if degree > 1 else 'on the space'} (0: it does)",
                 0 if on_vertex_space == (degree > 1) else 1, 0)
    return amg_dir


def serial_hands_over_to_mumps_on_disk(args, checks):
    """A serial run past CHOLMOD's factor, where MUMPS's out-of-core data fits: the P2 cantilever at
    2.5 mm (38k DoFs: CHOLMOD's factor 0.09 GB, MUMPS's in-core data 0.12 GB, 0.03 GB with its factor
    on disk) under a limit of 0.05 GB, with 'Eigensolver = auto' and with 'block-krylov' named (both
    with 'Factor storage = auto', the default), against CHOLMOD's block Krylov run on its meshes."""
    fine = lambda lines: scene_text("cantilever.prm", lines).replace("set Coarse size = 5", "set Coarse size = 2.5")
    direct_dir = os.path.join(args.workdir, "fine_direct")
    os.makedirs(direct_dir)
    shutil.copy(os.path.join(HERE, "cantilever.geo"), direct_dir)
    direct, _ = run_precompute(args.binary, direct_dir, fine(["Eigensolver = block-krylov"]))
    factor_files = os.path.join(args.workdir, "factor_files")
    os.makedirs(factor_files)
    for eigensolver in ["auto", "block-krylov"]:
        folder = os.path.join(args.workdir, f"fine_{eigensolver}_limit")
        os.makedirs(folder)
        shutil.copy(os.path.join(HERE, "cantilever.geo"), folder)
        handed, _ = run_precompute(args.binary, folder, fine([f"Eigensolver = {eigensolver}", "Factor memory limit = 0.05",
                                                              f"Factor directory = {factor_files}"]),
                                   meshes_from=direct_dir)
        d, a = space(direct), space(handed)
        method = a["eigensolver"]["method"]
        print(f"--- {eigensolver}, serial, {a['n_dofs']} DoFs, factor memory limit 0.05 GB: {method}")
        for words in ["factor on disk", "MUMPS on one process", "CHOLMOD's analysis predicts"]:
            checks.below(f"the method says '{words}' (0: it does)", 0 if words in method else 1, 0)
        worst = max(abs(fa - fd) / fd for fa, fd in zip(a["computed_frequencies_hz"], d["computed_frequencies_hz"]))
        checks.below("frequencies, MUMPS on disk vs CHOLMOD (max relative difference)", worst, 1e-8)
        checks.below("max |Phi^T M Phi - I|", a["orthonormality_error"], 1e-10)
        # Block Krylov stops on the residual of the shift-invert operator (1e-10 of the Ritz value); in
        # K and M that residual is multiplied by up to ||K - sigma M|| / lambda, so rounding (MUMPS's and
        # BLAS's threads) moves it between runs: 1.4e-8 to 3.8e-7 here. A mode that did not converge is
        # off by 1e-3 or more; the bound is the other parts' 1e-5, and the frequencies above hold 1e-8.
        checks.below("max ||K phi - lambda M phi|| / ||lambda M phi||", a["max_relative_residual"], 1e-5)
    checks.below("MUMPS's factor files left", len(os.listdir(factor_files)), 0)
    killed_runs_factor_files_removed_by_the_next(args, checks, fine, direct_dir, factor_files)


def killed_runs_factor_files_removed_by_the_next(args, checks, fine, direct_dir, factor_files):
    """A run killed (SIGKILL, as the out-of-memory killer does) while its factor is on disk leaves
    its own subdirectory of the factor directory; the next run on the host removes it and says so."""
    folder = os.path.join(args.workdir, "fine_killed")
    os.makedirs(folder)
    shutil.copy(os.path.join(HERE, "cantilever.geo"), folder)
    copy_meshes(direct_dir, folder)
    prm = os.path.join(folder, "scene.prm")
    open(prm, "w").write(fine(["Factor storage = disk", f"Factor directory = {factor_files}"]))
    run = subprocess.Popen([args.binary, prm, "--output-dir", folder, "--quiet"], stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL)
    written = []
    deadline = time.time() + 120
    while not written and run.poll() is None and time.time() < deadline:
        written = [os.path.join(d, f) for d, _, files in os.walk(factor_files) for f in files]
        time.sleep(0.02)
    run.kill()
    run.wait()
    left = os.listdir(factor_files)
    print(f"--- killed while its factor was on disk: {len(written)} files written, {left} left")
    checks.below("the killed run left its factor subdirectory (0: it did)", 0 if written and left else 1, 0)
    _, stderr = run_precompute(args.binary, folder, fine(["Factor storage = disk", f"Factor directory = {factor_files}"]))
    checks.below("the next run removed it, saying so (0: it did)",
                 0 if not os.listdir(factor_files) and "Note: removed" in stderr else 1, 0)


def free_part_refused_on_disk(args, checks):
    """A part with free rigid-body motions stays on CHOLMOD: MUMPS's path does not take it."""
    free_dir = os.path.join(args.workdir, "free_beam_disk")
    os.makedirs(free_dir)
    shutil.copy(os.path.join(HERE, "cantilever.geo"), free_dir)
    prm = os.path.join(free_dir, "scene.prm")
    open(prm, "w").write(scene_text("free_beam.prm", ["Factor storage = disk"]))
    done = subprocess.run([args.binary, prm, "--output-dir", free_dir, "--quiet"], capture_output=True, text=True)
    print(f"--- free beam, serial, 'Factor storage = disk': exit {done.returncode}")
    checks.below("free beam on disk refused, naming 'Factor storage = disk' (0: it is)",
                 0 if done.returncode != 0 and "Factor storage = disk" in done.stderr else 1, 0)


def cut_off_decides(args, checks):
    """The P1 cantilever under a haptic cut-off above its 9th mode (cut_off_between), a floor of 4 and
    at most 24 modes: LOBPCG's first run seeks 8, a second one in their complement stops once its
    converged lowest decide the count; fewer than 24 computed, those below the cut-off kept, equal
    to the direct path's 16 modes (no cut-off) to 1e-8."""
    direct_dir, amg_dir = (os.path.join(args.workdir, "cut_off_" + name) for name in ("direct", "amg"))
    for folder in (direct_dir, amg_dir):
        os.makedirs(folder)
        shutil.copy(os.path.join(HERE, "cantilever.geo"), folder)
    more = lambda lines: "subsection Modes\n" + "".join(f"  set {line}\n" for line in lines) + "end\n"
    direct, _ = run_precompute(args.binary, direct_dir, scene_text("cantilever.prm", ["Eigensolver = block-krylov"], 1) +
                               more(["Maximum number of modes = 16", "Minimum number of modes = 16"]))
    reference = space(direct)["computed_frequencies_hz"]
    amg, _ = run_precompute(args.binary, amg_dir, scene_text("cantilever.prm", ["Eigensolver = lobpcg-amg"], 1) +
                            more(cut_off_between(reference)), meshes_from=direct_dir)
    print(f"--- cantilever P1, cut-off {space(amg)['cut_off_hz']:.1f} Hz: {space(amg)['eigensolver']['method']}")
    for condition, what in cut_off_checks(space(amg), reference, 1e-8):
        checks.below(what + " (0: it does)", 0 if condition else 1, 0)


def main():
    args = binary_and_fresh_workdir(mpirun_help="also run LOBPCG + AMG under mpirun -np 2")
    checks = Checks()
    cantilever_dir = run_pair(args.binary, args.workdir, "cantilever_p2", "cantilever.prm", 2, checks)
    run_pair(args.binary, args.workdir, "cantilever_p1", "cantilever.prm", 1, checks)
    run_pair(args.binary, args.workdir, "free_beam_p2", "free_beam.prm", 2, checks)
    # The 8 modes by three LOBPCG runs (3, 3, 2), each in the complement of the modes found before.
    three_runs = ["LOBPCG modes per run = 3"]
    run_pair(args.binary, args.workdir, "cantilever_p2_three_runs", "cantilever.prm", 2, checks, amg_lines=three_runs)
    if args.mpirun:
        run_pair(args.binary, args.workdir, "cantilever_p2_np2", "cantilever.prm", 2, checks, mpirun=args.mpirun)
        run_pair(args.binary, args.workdir, "cantilever_p2_np2_three_runs", "cantilever.prm", 2, checks,
                 mpirun=args.mpirun, amg_lines=three_runs)

    # auto: a limit below the cantilever's factor switches to the path without one; the default keeps it.
    np2 = (mpi_command(args.mpirun, 2), mpi_environment()) if args.mpirun else None
    for label, launch in [("serial", ((), None))] + ([("mpirun -np 2", np2)] if np2 else []):
        for limit, expected, why in [("0.001", "LOBPCG", "over the limit 0.001 GB"),
                                     ("0", "block Krylov", "fits the limit")]:
            auto_dir = os.path.join(args.workdir, f"auto_{label.replace(' ', '_')}_{limit}")
            shutil.copytree(cantilever_dir, auto_dir)  # its .geo and meshes
            auto, _ = run_precompute(args.binary, auto_dir, scene_text("cantilever.prm", [
                "Eigensolver = auto", f"Factor memory limit = {limit}"]), launcher=launch[0], env=launch[1])
            method = space(auto)["eigensolver"]["method"]
            print(f"--- auto, {label}, factor memory limit {limit} GB: {method}")
            checks.below(f"auto chose {expected} (0: it did)", 0 if method.startswith(expected) else 1, 0)
            checks.below("auto said why, in the report (0: it did)", 0 if why in method else 1, 0)
    cut_off_decides(args, checks)
    serial_hands_over_to_mumps_on_disk(args, checks)
    free_part_refused_on_disk(args, checks)
    sys.exit(checks.exit_code())


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""Scenarios as separate jobs (docs/cluster.md): the small scene meshed once
(`--mesh-only`), then run whole in one run and as one job per scenario (`--scenario NAME`) merged
(`--merge`), all on the same meshes (copied: gmsh is not bit-reproducible). The merged files must
be those of the one run:

* the .h5: the same groups, datasets, shapes and attributes; eigenvalues to 1e-12 relative, every
  other floating-point dataset (modes, compliances, transfer matrices, validation) to `tolerance` of
  its largest entry, integer datasets equal;
* the .mrt: the same sections, the same tolerances (the validity forces through their rates 1/F,
  see precompute_run.validity_rates);
* report.json: equal (numbers to `tolerance`) but for times, memory and process counts; the .vtu
  files in the output folder are the jobs' ones.

Done twice: serial jobs against a serial run (tolerance 1e-12, and the .mrt byte for byte: the
serial path is deterministic), and (with --mpirun) jobs under `mpirun -np 2` against a run under
`mpirun -np 2` (the distributed path numbers DoFs differently from the serial one, so each is
compared with its own kind). Two whole runs under mpirun -np 2 already differ in the last digits
(MUMPS's solves are not bit-reproducible there), and the block Krylov eigensolver amplifies that
to the level of its tolerance ('Modes/Tolerance' 1e-10 on the Ritz residuals): measured, 1.6e-9 of
29 in the modes, 3e-10 relative in the validation's corrected field errors, and now and then one
block more or less before the stop (4e-9 against 2.6e-10 in the largest eigen-residual). So that
comparison allows 1e-8 of the largest entry, 1e-8 absolute for the report's round-off-level figures
(residuals, corrected errors), and the eigensolver's counts of solved vectors and MUMPS's workspace
relaxation (a factorization redone with more workspace, named in the method) may differ; the
modes' signs are fixed by the eigensolver (a positive product with its random start column), so
they do not flip between runs.

Bad inputs exit non-zero with a message naming what is wrong, and a refused merge writes nothing:
a missing scenario, a duplicated scenario, a partial result of another scene, other parameters, a
file that is no partial result, an unknown scenario, a job without meshes.
"""
import json
import os
import re
import shutil
import subprocess
import sys

import h5py
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mrt_reader  # noqa: E402
from precompute_run import Checks, binary_and_fresh_workdir, copy_meshes, validity_rates  # noqa: E402
from test_mpi_np1_vs_np2 import mpi_command, mpi_environment  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
SCENE = "small_block"
SCENARIOS = ["global", "left", "right"]
EIGENVALUES_RELATIVE = 1e-12
# Report figures at round-off level: compared to an absolute 1e-9 where runs are not bit-reproducible.
# The far field's errors too: on the small scene's VOIs its rank holds the whole residual (1e-15).
ROUND_OFF_LEVEL = {"orthonormality_error", "max_relative_residual", "contact_rel_error_corrected",
                   "solve_relative_residual", "two_contact_rel_error_corrected", "rel_error_corrected",
                   "median_error", "p95_error", "max_error", "rms_error"}
# Report entries that measure the run rather than the results (and every time in seconds, "*_s").
RUN_DEPENDENT = {"processes", "seconds", "seconds_per_load", "reused", "h5_bytes", "parameter_file"}
# The eigensolver's counts, which depend on where round-off puts its stop when runs are not bit-reproducible.
ITERATION_COUNTS = {"operator_applications", "solved_vectors"}

expect = Checks()


def scene_prm(folder, extra=""):
    """The small scene with its geometry found from `folder`, plus `extra` parameters."""
    os.makedirs(folder, exist_ok=True)
    text = open(os.path.join(HERE, "small_scene.prm")).read().replace("block.geo", os.path.join(HERE, "block.geo"))
    path = os.path.join(folder, "scene.prm")
    open(path, "w").write(text + extra)
    return path


def precompute(command, prm, folder, *options, timeout=300):
    subprocess.run(command + [prm, "--output-dir", folder, "--quiet", *options], check=True,
                   env=mpi_environment(), timeout=timeout, stdout=subprocess.DEVNULL)


def refused(command, what, *words):
    """The command exits non-zero and its message names every one of `words`."""
    done = subprocess.run(command, capture_output=True, text=True, env=mpi_environment(), timeout=120)
    named = all(word in done.stderr for word in words)
    expect(done.returncode != 0 and named, f"{what}: exit {done.returncode}, message names {words}"
           + ("" if named else f"\n{done.stderr}"))


def close(a, b, relative):
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape:
        return False, f"shapes {a.shape} vs {b.shape}"
    if a.size == 0 or not np.issubdtype(a.dtype, np.floating):
        return bool(np.array_equal(a, b)), "equal" if np.array_equal(a, b) else "differ"
    scale = float(np.max(np.abs(b)))
    difference = float(np.max(np.abs(a - b)))
    return difference <= relative * scale, f"{difference:.1e} of {scale:.1e}"


def far_field_product(factor, rows):
    """Z Z^T of the far field's factor Z (rows x rank): what the kernel reads (Z_a Z_b^T). Z itself is
    defined up to a rotation, which round-off picks where eigenvalues of the factor's core lie close."""
    z = np.asarray(factor, dtype=float).reshape(rows, -1)
    return z @ z.T


def validity_map_forces(report):
    """Every force [N] of each space's validity_map in report.json, in order (one array per space),
    and the report without them (they are compared as rates)."""
    forces = []
    for space in report["spaces"]:
        numbers = []
        def collect(node):
            if isinstance(node, dict):
                for key in sorted(node):
                    if key.endswith("_n"):
                        numbers.extend(np.ravel(node[key]).tolist())
                    else:
                        collect(node[key])
            elif isinstance(node, list):
                for item in node:
                    collect(item)
        collect(space.get("validity_map", {}))
        forces.append(np.array(numbers))
        if "validity_map" in space:
            space["validity_map"] = {k: v for k, v in space["validity_map"].items()
                                     if k in ("n_contacts", "n_estimated_contacts")}
    return forces


def compare_h5(merged, whole, label, tolerance):
    with h5py.File(merged, "r") as m, h5py.File(whole, "r") as w:
        names = {}
        for f, out in [(m, "m"), (w, "w")]:
            found = []
            f.visititems(lambda name, obj: found.append((name, type(obj).__name__)))
            names[out] = sorted(found)
        expect(names["m"] == names["w"], f"{label} .h5: the same {len(names['w'])} groups and datasets")
        worst = {}
        for name, kind in names["w"]:
            if (name, kind) not in names["m"]:
                continue
            attributes_m = {k: np.asarray(v).tolist() for k, v in m[name].attrs.items()}
            attributes_w = {k: np.asarray(v).tolist() for k, v in w[name].attrs.items()}
            if attributes_m != attributes_w:
                expect(False, f"{label} .h5 {name}: attributes {attributes_m} vs {attributes_w}")
            if kind != "Dataset":
                continue
            a, b = m[name][()], w[name][()]
            if name.endswith("/eigenvalues"):  # every eigenvalue to 1e-12 relative
                ok = a.shape == b.shape and bool(np.all(np.abs(a - b) <= EIGENVALUES_RELATIVE * np.abs(b)))
                detail = f"max relative {np.max(np.abs(a - b) / np.abs(b)):.1e}" if a.shape == b.shape else "shapes"
            elif name.endswith("/validity_force"):
                ok, detail = close(validity_rates(a), validity_rates(b), tolerance)
                detail = "rates " + detail
            elif name.endswith("/far_compliance"):
                rows = int(np.prod(b.shape[:-1]))
                ok, detail = close(far_field_product(a, rows), far_field_product(b, rows), tolerance)
                detail = "Z Z^T " + detail
            else:
                ok, detail = close(a, b, tolerance)
            if not ok:
                expect(False, f"{label} .h5 {name}: {detail} > {tolerance:g}")
            worst[name] = detail
        top = {k: np.asarray(v).tolist() for k, v in m.attrs.items()} == \
            {k: np.asarray(v).tolist() for k, v in w.attrs.items()}
        expect(top, f"{label} .h5: the same file attributes")
    for key in ["eigenvalues", "modes_at_vertices", "display_modes", "candidate_compliance", "cross_blocks",
                "validation_response"]:
        print(f"        {key}: " + ", ".join(f"{name.split('/')[1]} {detail}" for name, detail in worst.items()
                                            if name.endswith("/" + key)))
    transfers = {k: v for k, v in worst.items() if "__from__" in k}
    expect(len(transfers) == 6, f"{label} .h5: 6 transfer matrices compared ({', '.join(transfers.values())})")


def compare_mrt(merged, whole, label, tolerance):
    header_m, sections_m = mrt_reader.read(merged)
    header_w, sections_w = mrt_reader.read(whole)
    expect(header_m == header_w, f"{label} .mrt: the same header")
    expect(sorted(sections_m) == sorted(sections_w), f"{label} .mrt: the same {len(sections_w)} sections")
    bad = []
    for key in sections_w:
        if key in sections_m:
            kind = mrt_reader.KIND_NAMES.get(key[0], key[0])
            if kind == "EIGENVALUES":
                ok = bool(np.all(np.abs(sections_m[key] - sections_w[key]) <= EIGENVALUES_RELATIVE *
                                 np.abs(sections_w[key])))
                detail = "eigenvalues"
            elif kind == "VALIDITY_FORCE":
                ok, detail = close(validity_rates(sections_m[key]), validity_rates(sections_w[key]), tolerance)
            elif kind == "FAR_COMPLIANCE":  # 3 rows per candidate of the space
                candidates = next(k for k, name in mrt_reader.KIND_NAMES.items() if name == "CANDIDATE_VERTICES")
                rows = 3 * sections_w[(candidates,) + key[1:]].size
                ok, detail = close(far_field_product(sections_m[key], rows), far_field_product(sections_w[key], rows),
                                   tolerance)
            elif sections_w[key].dtype == np.float32:  # float32 modes: the doubles' difference, rounded
                ok, detail = close(sections_m[key], sections_w[key], max(tolerance, 2 * np.finfo(np.float32).eps))
            else:
                ok, detail = close(sections_m[key], sections_w[key], tolerance)
            if not ok:
                bad.append(f"{kind} {key[1:]}: {detail}")
    expect(not bad, f"{label} .mrt: every section equal to {tolerance:g} of its largest entry {bad or ''}")
    return open(merged, "rb").read() == open(whole, "rb").read()


def report_differences(a, b, tolerance, ignored, path=""):
    """Where two reports differ, but for the `ignored` keys; numbers to `tolerance` relative."""
    if isinstance(a, dict) and isinstance(b, dict):
        keys = {k for k in set(a) | set(b) if k not in ignored and not k.endswith("_s")}
        return [d for k in sorted(keys) for d in
                (report_differences(a[k], b[k], tolerance, ignored, f"{path}/{k}") if k in a and k in b
                 else [f"{path}/{k}"])]
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{path}: {len(a)} vs {len(b)} entries"]
        return [d for k, (x, y) in enumerate(zip(a, b))
                for d in report_differences(x, y, tolerance, ignored, f"{path}[{k}]")]
    if isinstance(a, float) or isinstance(b, float):
        key = path.split("/")[-1].split("[")[0]
        allowed = max(1e-9, tolerance) if key in ROUND_OFF_LEVEL else tolerance * abs(b)
        return [] if abs(a - b) <= allowed else [f"{path}: {a!r} vs {b!r}"]
    return [] if a == b else [f"{path}: {a!r} vs {b!r}"]


def without_workspace_relaxation(report):
    """MUMPS's dynamic scheduling at np = 2 now and then needs more workspace than its analysis said,
    and that factorization is redone with more (the method then says so): a property of the run."""
    for space in report["spaces"]:
        space["eigensolver"]["method"] = re.sub(r" \[workspace relaxed to \d+ %\]", "", space["eigensolver"]["method"])
    return report


def compare_reports(merged, whole, label, tolerance, bit_reproducible):
    m, w = json.load(open(merged)), json.load(open(whole))
    if not bit_reproducible:
        m, w = without_workspace_relaxation(m), without_workspace_relaxation(w)
    ignored = RUN_DEPENDENT | (set() if bit_reproducible else ITERATION_COUNTS)
    for space, (a, b) in zip(w["spaces"], zip(validity_map_forces(m), validity_map_forces(w))):
        ok, detail = close(validity_rates(a), validity_rates(b), tolerance)
        expect(ok, f"{label} report.json: {space['name']}'s validity_map forces as rates {detail} <= {tolerance:g}")
    differences = report_differences(m, w, tolerance, ignored)
    expect(not differences, f"{label} report.json: equal but for times, memory, process counts"
           f"{'' if bit_reproducible else ', solved vectors'} (numbers to {tolerance:g}) {differences[:5] or ''}")
    expect(m["processes"]["count"] == w["processes"]["count"], f"{label} report.json: processes.count "
           f"{m['processes']['count']} (the largest job's) = the one run's {w['processes']['count']}")


def run_and_merge(args, label, command, mesh_folder, tolerance, bit_reproducible):
    """The whole scene in one run and as jobs + merge, with `command` (serial or mpirun)."""
    whole = os.path.join(args.workdir, label, "whole")
    jobs = os.path.join(args.workdir, label, "jobs")
    for folder in (whole, jobs):
        copy_meshes(mesh_folder, folder)
    precompute(command + [args.binary], scene_prm(whole), whole)
    prm = scene_prm(jobs)
    for name in SCENARIOS:
        precompute(command + [args.binary], prm, jobs, "--scenario", name)
    precompute([args.binary], prm, jobs, "--merge")
    compare_h5(os.path.join(jobs, SCENE + ".h5"), os.path.join(whole, SCENE + ".h5"), label, tolerance)
    identical = compare_mrt(os.path.join(jobs, SCENE + ".mrt"), os.path.join(whole, SCENE + ".mrt"), label, tolerance)
    if bit_reproducible:
        expect(identical, f"{label} .mrt: byte for byte the one-run file")
    compare_reports(os.path.join(jobs, "report.json"), os.path.join(whole, "report.json"), label, tolerance,
                    bit_reproducible)
    for name in SCENARIOS:
        vtu = f"modes_{name}.vtu"
        copied = open(os.path.join(jobs, vtu), "rb").read() == open(os.path.join(jobs, "partial", vtu), "rb").read()
        expect(copied and os.path.exists(os.path.join(jobs, f"modes_{name}.pvd")),
               f"{label}: {vtu} and its .pvd in the output folder, the job's file")
    return jobs


def bad_inputs(args, mesh_folder, jobs):
    binary = args.binary
    bad = os.path.join(args.workdir, "bad")
    good_partials = os.path.join(jobs, "partial")

    def partial_set(name, files):
        folder = os.path.join(bad, name)
        os.makedirs(folder, exist_ok=True)
        for source, target in files:
            shutil.copy(source, os.path.join(folder, target))
        for scenario in SCENARIOS:
            shutil.copy(os.path.join(good_partials, f"modes_{scenario}.vtu"), folder)
        return folder

    # The merges write into a folder with the meshes and no results: a refused merge leaves it so.
    out = os.path.join(bad, "out")
    copy_meshes(mesh_folder, out)
    prm = scene_prm(out)
    good = {s: os.path.join(good_partials, s + ".partial") for s in SCENARIOS}

    missing = partial_set("missing", [(good["global"], "global.partial"), (good["left"], "left.partial")])
    refused([binary, prm, "--output-dir", out, "--merge", "--partial-dir", missing], "merge without 'right'",
            "'right'")
    duplicated = partial_set("duplicated", [(good[s], s + ".partial") for s in SCENARIOS] +
                             [(good["left"], "left_again.partial")])
    refused([binary, prm, "--output-dir", out, "--merge", "--partial-dir", duplicated], "merge with 'left' twice",
            "is in two partial results")

    # A job of another scene (same geometry and meshes, another name).
    other = os.path.join(bad, "other_scene")
    copy_meshes(mesh_folder, other)
    other_prm = scene_prm(other, "subsection Scene\n  set Name = other_block\nend\n")
    precompute([binary], other_prm, other, "--scenario", "left")
    foreign = partial_set("foreign", [(good["global"], "global.partial"), (good["right"], "right.partial"),
                                      (os.path.join(other, "partial", "left.partial"), "left.partial")])
    refused([binary, prm, "--output-dir", out, "--merge", "--partial-dir", foreign],
            "merge with a partial result of another scene", "of scene 'other_block'")

    changed_prm = scene_prm(os.path.join(bad, "changed"), "subsection Contact\n  set Validation samples = 4\nend\n")
    refused([binary, changed_prm, "--output-dir", out, "--merge", "--partial-dir", good_partials],
            "merge with other parameters", "global.partial' was computed from other parameters", "Validation samples",
            "= 3' where the scene has", "= 4'")

    junk = partial_set("junk", [(good[s], s + ".partial") for s in SCENARIOS])
    open(os.path.join(junk, "notes.partial"), "w").write("not a partial result\n")
    refused([binary, prm, "--output-dir", out, "--merge", "--partial-dir", junk], "merge with a foreign file",
            "notes.partial' is not a partial result")

    expect(not any(name.endswith((".h5", ".mrt", ".json", ".vtu", ".pvd")) or ".tmp." in name
                   for name in os.listdir(out)), f"refused merges wrote nothing into {out}")

    refused([binary, prm, "--output-dir", out, "--scenario", "middle"], "unknown scenario", "no scenario 'middle'")
    empty = os.path.join(bad, "no_meshes")
    refused([binary, scene_prm(empty), "--output-dir", empty, "--scenario", "left"], "job without meshes",
            "--mesh-only")


def main():
    args = binary_and_fresh_workdir("also compare jobs under mpirun -np 2 with a run under mpirun -np 2")

    meshes = os.path.join(args.workdir, "meshes")
    prm = scene_prm(meshes)
    listed = subprocess.run([args.binary, prm, "--list-scenarios"], check=True, capture_output=True, text=True)
    expect(listed.stdout.split() == SCENARIOS, f"--list-scenarios: {listed.stdout.split()}")
    precompute([args.binary], prm, meshes, "--mesh-only")

    serial_jobs = run_and_merge(args, "serial", [], meshes, 1e-12, True)
    if args.mpirun:
        run_and_merge(args, "np2", mpi_command(args.mpirun, 2), meshes, 1e-8, False)
    bad_inputs(args, meshes, serial_jobs)

    return expect.exit_code()


if __name__ == "__main__":
    sys.exit(main())

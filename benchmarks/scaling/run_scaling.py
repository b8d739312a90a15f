#!/usr/bin/python3
"""Scaling of the distributed precompute (docs/cluster.md, docs/performance.md): the FACTS plate of
the eigensolver benchmark (50 modes of its graded 'rib' space) run by `mpirun -np N modal-precompute
--distributed` for N = 1 and 2, interleaved and repeated, with each of MUMPS's two wrappers
('Modes/Distributed factorization': MUMPS's symmetric mode through its C interface, Trilinos Amesos' LU) and each eigensolver
over it ('Modes/Eigensolver': the block Krylov method, PARPACK); wall time per phase of the rib
space, total time, the largest peak memory of one process, speedup. One BLAS thread per process.
Writes a CSV.
  run_scaling.py --build build --out benchmarks/results/<host>/scaling.csv [--sizes 0.5,0.36] [--repeat 2]
                 [--factorizations mumps-cholesky,mumps-lu] [--eigensolvers block-krylov,arpack]
"""
import argparse
import csv
import json
import os
import statistics
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "eigensolver"))
sys.path.insert(0, os.path.join(HERE, "..", "..", "tests", "precompute"))
from run_benchmark import scene  # noqa: E402  the same plate, mesh sizes and mode count
from test_mpi_np1_vs_np2 import mpi_command, mpi_environment  # noqa: E402

PHASES = ["assembly", "eigensolve", "interpolation", "static_correction", "validation"]
EIGENSOLVE_PARTS = ["analyze", "factorize"]  # the rest of the eigensolve is its iteration (solves, products)


def run(build, folder, fine_size, processes, factorization, eigensolver):
    os.makedirs(folder, exist_ok=True)
    prm = os.path.join(folder, "facts_plate.prm")
    text = scene(fine_size, "cholmod", eigensolver).replace("set Export matrices = true", "set Export matrices = false")
    text = text.replace(f"set Eigensolver = {eigensolver}",
                        f"set Eigensolver = {eigensolver}\n  set Distributed factorization = {factorization}")
    open(prm, "w").write(text)
    command = mpi_command("mpirun", processes) + [os.path.join(build, "bin", "modal-precompute"), prm,
                                                   "--output-dir", folder, "--quiet", "--distributed"]
    env = mpi_environment()
    env["OPENBLAS_NUM_THREADS"] = "1"
    subprocess.run(command, check=True, env=env, stdout=subprocess.DEVNULL)
    report = json.load(open(os.path.join(folder, "report.json")))
    rib = [s for s in report["spaces"] if s["name"] == "rib"][0]
    row = dict(fine_size_mm=fine_size, n_dofs=rib["n_dofs"], processes=processes, factorization=factorization,
               eigensolver=eigensolver, factor_nonzeros=rib["eigensolver"]["factor_nonzeros"],
               total_s=report["timings_s"]["total"], max_peak_memory_mb=report["processes"]["max_peak_memory_mb"])
    for phase in PHASES:
        row[f"{phase}_s"] = rib["timings_s"].get(phase, 0.)
    # The eigensolve's own split, which the on-paper extrapolation (extrapolate.py) scales apart.
    for part in EIGENSOLVE_PARTS:
        row[f"eigensolve_{part}_s"] = rib["eigensolver"][f"{part}_s"]
    row["eigensolve_solves"] = rib["eigensolver"]["operator_applications"]
    return row


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", default="build")
    parser.add_argument("--out", required=True)
    parser.add_argument("--work", default="/tmp/modal-haptics-bench-scaling")
    parser.add_argument("--sizes", default="0.5,0.36", help="VOI fine sizes in mm (0.5 ~ 93k DoFs, 0.36 ~ 222k)")
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--factorizations", default="mumps-cholesky,mumps-lu",
                        help="'Modes/Distributed factorization' values, each run at np 1 and 2")
    parser.add_argument("--eigensolvers", default="block-krylov",
                        help="'Modes/Eigensolver' values over each factorization (block-krylov, arpack: PARPACK)")
    args = parser.parse_args()
    medians = []
    configurations = [(f, e) for f in args.factorizations.split(",") for e in args.eigensolvers.split(",")]
    for fine in (float(s) for s in args.sizes.split(",")):
        runs = {(c, p): [] for c in configurations for p in (1, 2)}
        for repetition in range(args.repeat):
            for configuration in configurations:
                for processes in (1, 2):  # interleaved: all see the same machine state
                    name = "_".join(configuration)
                    folder = os.path.join(args.work, f"fine_{fine}_{name}_np{processes}")
                    row = run(args.build, folder, fine, processes, *configuration)
                    runs[(configuration, processes)].append(row)
                    print(f"[{fine} mm, {row['n_dofs']} DoFs, {' + '.join(configuration)}, np {processes}, "
                          f"run {repetition + 1}] eigensolve {row['eigensolve_s']:.1f} s, total {row['total_s']:.1f} s, "
                          f"{row['max_peak_memory_mb']:.0f} MB per process", flush=True)
        for configuration in configurations:
            for processes in (1, 2):
                rows = runs[(configuration, processes)]
                median = dict(rows[0])
                for key in (["total_s", "max_peak_memory_mb"] + [f"{p}_s" for p in PHASES] +
                            [f"eigensolve_{p}_s" for p in EIGENSOLVE_PARTS]):
                    values = [r[key] for r in rows]
                    median[key] = statistics.median(values)
                    median[key.replace("_s", "") + "_min_max" if key.endswith("_s") else key + "_min_max"] = \
                        f"{min(values):.3g}..{max(values):.3g}"
                medians.append(median)
            one, two = medians[-2], medians[-1]
            for key in ("eigensolve_s", "total_s"):
                two[f"speedup_{key[:-2]}"] = one[key] / two[key]
            two["memory_per_process_vs_np1"] = two["max_peak_memory_mb"] / one["max_peak_memory_mb"]
            print(f"[{fine} mm, {' + '.join(configuration)}] np 2 against np 1: eigensolve {two['speedup_eigensolve']:.2f}x, "
                  f"total {two['speedup_total']:.2f}x, memory per process {100 * two['memory_per_process_vs_np1']:.0f} %")
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    fields = sorted({k for row in medians for k in row}, key=lambda k: (k not in medians[0], k))
    with open(args.out + ".tmp", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows(medians)
    os.replace(args.out + ".tmp", args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())

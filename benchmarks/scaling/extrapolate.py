#!/usr/bin/python3
"""On paper (docs/cluster.md): what the measured per-phase scaling predicts for 10 M and 100 M DoFs.

Reads the measured CSVs of benchmarks/results/<host>/ (scaling_block_krylov.csv: the distributed
precompute with today's direct path, MUMPS's symmetric mode and the block Krylov method, at 93k,
223k and 446k DoFs, np = 1 and 2, with the eigensolve's factorization timed apart;
eigensolver_lobpcg.csv: the path without a factorization beside the direct one, one run),
fits growth exponents t ~ n^e from them, and extrapolates each phase with the exponent theory
gives (stated beside the measured one) to the target sizes on a stated number of processes with a
stated parallel efficiency. Prints markdown tables.
  extrapolate.py [--results benchmarks/results/debian12-2core] [--efficiency 0.25] [--iterative-efficiency 0.5]
"""
import argparse
import csv
import math
import os
import re

HERE = os.path.dirname(os.path.abspath(__file__))
TARGETS = [(10e6, 256), (100e6, 2048)]  # (DoFs, MPI processes): 8 and 64 nodes of 32 cores
PHASES = ["assembly", "eigensolve", "interpolation", "static_correction", "validation"]


def exponent(points):
    """Least-squares slope of log t against log n."""
    xs = [math.log(n) for n, _ in points]
    ys = [math.log(t) for _, t in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)


def read_scaling(path):
    rows = {}
    numeric = re.compile(r"^[-+0-9.e]+$")
    for row in csv.DictReader(open(path)):
        rows[(int(row["processes"]), int(row["n_dofs"]))] = {k: float(v) for k, v in row.items()
                                                             if v and "min_max" not in k and numeric.match(v)}
    return rows


def read_paths(results):
    """{path: [(n, seconds, peak MB per process)]} of the eigensolve by LOBPCG + AMG (serial, and
    on 2 MPI ranks) and by the direct path (block Krylov + CHOLMOD), measured in one run
    (eigensolver_lobpcg*.csv)."""
    paths = {"lobpcg": [], "lobpcg2": [], "direct": []}
    for name in sorted(os.listdir(results)):
        if name.startswith("eigensolver_lobpcg") and name.endswith(".csv"):
            read_path_rows(os.path.join(results, name), paths)
    return {k: sorted(v) for k, v in paths.items()}


def read_path_rows(path, paths):
    for row in csv.DictReader(line for line in open(path) if not line.startswith("#")):
        if not row.get("seconds"):
            continue
        key = ("lobpcg2" if "distributed" in row["solver"] else "lobpcg") if "LOBPCG" in row["solver"] else \
            "direct" if "block Krylov" in row["solver"] and "MUMPS" not in row["solver"] else None
        if key:
            paths[key].append((int(row["n_dofs"]), float(row["seconds"]), float(row["peak_rss_mb_per_process"])))


def print_iterative_path(results, efficiency):
    """The on-paper tables redone with the measured exponents of the path without a factorization."""
    paths = read_paths(results)
    if len(paths["lobpcg"]) < 2:
        return
    print("\n### The path without a factorization (LOBPCG + AMG)\n")
    print("| path | sizes (DoFs) | e, time | e, peak memory | at the largest size |")
    print("|---|---|---|---|---|")
    fits = {}
    for key, label in [("lobpcg", "LOBPCG + AMG"), ("lobpcg2", "LOBPCG + AMG, 2 ranks (memory per rank)"),
                       ("direct", "block Krylov + CHOLMOD")]:
        points = paths[key]
        if len(points) < 2:
            continue
        e_t = exponent([(n, t) for n, t, _ in points])
        e_m = exponent([(n, m) for n, _, m in points])
        fits[key] = (e_t, e_m, points[-1])
        n, t, m = points[-1]
        print(f"| {label} | {', '.join(str(p[0]) for p in points)} | {e_t:.2f} | {e_m:.2f} | "
              f"{t:.1f} s, {m / 1024:.2f} GB |")
    serial = {n: (t, m) for n, t, m in paths["lobpcg"]}
    for n, t2, m2 in paths["lobpcg2"]:
        if n in serial:
            print(f"\nAt {n} DoFs, 2 ranks against 1: speedup {serial[n][0] / t2:.2f}x (efficiency "
                  f"{serial[n][0] / t2 / 2:.2f}), memory per rank {100 * m2 / serial[n][1]:.0f} % of one rank's.")
    # The anchor: the largest size measured, on the path measured at the most sizes; its work in
    # process-seconds and its memory over all processes.
    key = max(("lobpcg2", "lobpcg"), key=lambda k: (len(paths[k]), k == "lobpcg2"))
    ranks = 2 if key == "lobpcg2" else 1
    e_t, e_m, (n0, t0, m0) = fits[key]
    # Below 1 only because of a fixed part (libraries, the global space): the vectors and matrices
    # themselves grow at least like n.
    e_m = max(e_m, 1.0)
    print(f"\nExtrapolated from {n0} DoFs on {ranks} rank(s) with that path's exponents (time n^{e_t:.2f}), the "
          f"work ({ranks} x {t0:.0f} s) shared out over the processes with an assumed efficiency {efficiency:g} "
          "(measured at 2 ranks on 2 cores above; at hundreds of processes unmeasured), memory as "
          f"n^{e_m:.2f} (the measured exponent, at least 1) divided evenly:\n")
    t0, m0 = ranks * t0, ranks * m0
    print("| 50 modes | " + " | ".join(f"{n / 1e6:.0f} M DoFs, {p} processes" for n, p in TARGETS) + " |")
    print("|---|" + "---|" * len(TARGETS))
    print("| eigensolve, LOBPCG + AMG | " + " | ".join(human(t0 * (n / n0) ** e_t / (p * efficiency))
                                                      for n, p in TARGETS) + " |")
    print("| memory per process | " + " | ".join(f"{m0 * (n / n0) ** e_m / p / 1024:.1f} GB" for n, p in TARGETS) + " |")
    print("| memory, all processes | " + " | ".join(f"{m0 * (n / n0) ** e_m / 1024 ** 2:.2f} TB" for n, p in TARGETS)
          + " |")


def human(seconds):
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--results", default=os.path.join(HERE, "..", "results", "debian12-2core"))
    parser.add_argument("--efficiency", type=float, default=0.25,
                        help="assumed parallel efficiency of the sparse direct factorization and solves")
    parser.add_argument("--iterative-efficiency", type=float, default=0.5,
                        help="assumed parallel efficiency of LOBPCG + AMG (sparse products, V-cycles, small reductions)")
    args = parser.parse_args()
    rows = read_scaling(os.path.join(args.results, "scaling_block_krylov.csv"))
    sizes = {p: sorted(n for q, n in rows if q == p) for p in (1, 2)}
    n0 = sizes[1][-1]  # the largest measured size: the anchor
    base = rows[(1, n0)]

    print("### Measured growth exponents (t ~ n^e)\n")
    print(f"| phase | e, np = 1 | e, np = 2 | at {n0 // 1000}k, np = 1 | theory used |")
    print("|---|---|---|---|---|")
    theory = {"assembly": (1.0, "n (local cell integrals)"),
              "interpolation": (1.0, "n (point location in the mesh, modes at vertices)"),
              "static_correction": (4 / 3, "n^(4/3) per load: a solve reads the factor"),
              "validation": (4 / 3, "n^(4/3) per load")}
    for phase in PHASES:
        e = {p: exponent([(n, rows[(p, n)][f"{phase}_s"]) for n in sizes[p]]) for p in (1, 2)}
        note = theory.get(phase, (None, "factorization n^2 + iteration n^(4/3), below"))[1]
        if phase == "validation":
            note = "not exercised: the benchmark has 0 validation samples (times are bookkeeping, < 1 ms)"
        print(f"| {phase} | {e[1]:.2f} | {e[2]:.2f} | {base[f'{phase}_s']:.2f} s | {note} |")

    # The eigensolve's two parts, measured apart: MUMPS's analysis and factorization, and the block
    # Krylov iteration (its solves, M products and orthogonalization).
    def factorization(row):
        return row["eigensolve_analyze_s"] + row["eigensolve_factorize_s"]
    e_factor = exponent([(n, factorization(rows[(1, n)])) for n in sizes[1]])
    e_iteration = exponent([(n, rows[(1, n)]["eigensolve_s"] - factorization(rows[(1, n)])) for n in sizes[1]])
    print(f"\nInside the distributed eigensolve at np = 1: factorization (MUMPS's analysis + factorization) "
          f"e = {e_factor:.2f} (theory 2), iteration (block Krylov, its solves reading the factor) e = {e_iteration:.2f} "
          "(theory 4/3).")

    # Memory per process = D / np + R: D is what the processes share out (matrices, the factor, the
    # Lanczos vectors), R what each holds in full (the whole mesh, the gathered modes, the libraries).
    split = {}
    for n1, n2 in zip(sizes[1], sizes[2]):
        m1, m2 = rows[(1, n1)]["max_peak_memory_mb"], rows[(2, n2)]["max_peak_memory_mb"]
        split[n1] = (2 * (m1 - m2), 2 * m2 - m1)
    e_d = exponent([(n, d) for n, (d, _) in split.items()])
    e_r = exponent([(n, r) for n, (_, r) in split.items()])
    d0, r0 = split[n0]
    print(f"\nMemory per process = D/np + R from np = 1 and 2: at {sizes[1][0]}: D = {split[sizes[1][0]][0]:.0f} MB, "
          f"R = {split[sizes[1][0]][1]:.0f} MB; at {n0}: D = {d0:.0f} MB, R = {r0:.0f} MB; "
          f"e(D) = {e_d:.2f} (theory: factor fill n^(4/3)), e(R) = {e_r:.2f} (theory: n, the replicated mesh and modes).")

    eig = base["eigensolve_s"]
    factor0 = factorization(base)
    solves0 = eig - factor0
    solves = int(base["eigensolve_solves"])
    print(f"\nThe distributed eigensolve at {n0} ({eig:.1f} s, np = 1): factorization {100 * factor0 / eig:.0f} %, "
          f"iteration ({solves} solved vectors) {100 * solves0 / eig:.0f} %.")

    E = args.efficiency
    print(f"\n### Predicted wall time and memory (parallel efficiency {E:g} assumed for the direct solver, 1 for "
          "assembly and interpolation)\n")
    print("| phase | " + " | ".join(f"{n / 1e6:.0f} M DoFs, {p} processes" for n, p in TARGETS) + " |")
    print("|---|" + "---|" * len(TARGETS))
    predictions = {}
    for label, work, e, eff in [("assembly", base["assembly_s"], 1.0, 1.0),
                                ("eigensolve: factorization (n^2)", factor0, 2.0, E),
                                (f"eigensolve: iteration, {solves} solves (n^(4/3) each)", solves0, 4 / 3, E),
                                ("static correction (n^(4/3) per load)", base["static_correction_s"], 4 / 3, E),
                                ("interpolation", base["interpolation_s"], 1.0, 1.0)]:
        values = [work * (n / n0) ** e / (p * eff) for n, p in TARGETS]
        predictions[label] = values
        print(f"| {label} | " + " | ".join(human(v) for v in values) + " |")
    totals = [sum(v[k] for v in predictions.values()) for k in range(len(TARGETS))]
    print("| **total** | " + " | ".join(f"**{human(t)}**" for t in totals) + " |")
    # The same with each phase's measured np = 1 exponent instead of theory's (the eigensolve as one).
    measured = [sum(base[f"{phase}_s"] * (n / n0) ** exponent([(m, rows[(1, m)][f"{phase}_s"]) for m in sizes[1]]) /
                    (p * (1.0 if phase in ("assembly", "interpolation") else E)) for phase in PHASES[:4])
                for n, p in TARGETS]
    print("| total with the measured np = 1 exponents | " + " | ".join(human(t) for t in measured) + " |")
    for what, e_used in [("per process now (D/np + R)", None), ("per process without the replicated R", 0)]:
        cells = []
        for n, p in TARGETS:
            d = d0 * (n / n0) ** (4 / 3) / p
            r = r0 * (n / n0) if e_used is None else 0.
            cells.append(f"{(d + r) / 1024:.0f} GB")
        print(f"| memory {what} | " + " | ".join(cells) + " |")
    for n, p in TARGETS:
        total_factor_tb = d0 * (n / n0) ** (4 / 3) / 1024 ** 2
        print(f"\nAt {n / 1e6:.0f} M DoFs the shared part D (mostly MUMPS's factor) totals {total_factor_tb:.1f} TB; "
              f"the factorization is {100 * predictions['eigensolve: factorization (n^2)'][TARGETS.index((n, p))] / totals[TARGETS.index((n, p))]:.0f} % "
              "of the predicted time.")
    print_iterative_path(args.results, args.iterative_efficiency)


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""The eigensolver benchmark: 50 lowest modes of the FACTS plate (facts_plate.geo, linear tets,
graded around one rib) at several sizes; our default path (block Krylov + CHOLMOD) against ARPACK
over the same CHOLMOD factorization, deal.II's UMFPACK under ARPACK, our distributed path (the same
block Krylov method over MUMPS's Cholesky, mpirun on 1 and 2 ranks), SLEPc Krylov-Schur + MUMPS
Cholesky on 1 and 2 ranks, and scipy's eigsh (ARPACK + SuperLU), all on the same K and M, in one
run: the solvers are interleaved, every repetition runs each of them once, the CSV quotes the
median with min and max, the peak resident memory (GNU time) and the machine's limits measured in
the same run (bench-machine-limits: OpenBLAS DGEMM rate, memory read bandwidth).

  run_benchmark.py --build build --out benchmarks/results/<host>/eigensolver.csv \
      [--sizes 0.72,0.345,0.213] [--repetitions 3] [--slow-peer-limit 300000] [--slow-peer-repetitions 1]
      [--large-from 500000]

Slow peers: ARPACK + UMFPACK and scipy (single-threaded LU, time growing about as n^1.6-2 with the
DoFs, and peak memory too; their figures in README.md here) run only up to --slow-peer-limit DoFs and
--slow-peer-repetitions times; above that the CSV has a 'skipped' row saying why.
Large sizes (above --large-from, default 500k DoFs: the ~1M one): only ours (serial, and over MUMPS
on 2 ranks) and the goal's peer, SLEPc on 2 ranks, run, once (their time: docs/performance.md).
ARPACK + CHOLMOD shares our factorization (its ratio is known from the smaller sizes), SLEPc on 1 rank
would hold the whole MUMPS factor (~19 GB beside 24 GiB), and repetitions of the pair would triple
the longest part of the benchmark.
"""
import argparse
import csv
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
NEV = 50
TIME = ["/usr/bin/time", "-f", "maxrss_kb=%M"]  # GNU time: peak resident set of the process


def scene(fine_size, operator, eigensolver):
    return f"""
subsection Scene
  set Name = facts_plate
end
subsection Geometry
  set Source = {os.path.join(HERE, 'facts_plate.geo')}
end
subsection Meshing
  set Coarse size = 10
  set Element degree = 1
end
subsection Scenario 1
  set Name = rib
  set Box lower corner = 80, 25, -1
  set Box upper corner = 120, 35, 26
  set Fine size = {fine_size}
  set Transition = 10
end
subsection Modes
  set Maximum number of modes = {NEV}
  set Minimum number of modes = {NEV}
  set Cut-off rule = none
  set Operator = {operator}
  set Eigensolver = {eigensolver}
end
subsection Contact
  set Maximum candidates = 1
  set Validation samples = 0
  set Cross compliance = false
end
subsection Output
  set VTU modes = 0
  set Export matrices = true
end
"""


def peak_rss_mb(stderr):
    """Every 'maxrss_kb=' line GNU time wrote (one per process): (largest, sum) in MB."""
    kb = [int(v) for v in re.findall(r"maxrss_kb=(\d+)", stderr)]
    return (max(kb) / 1024., sum(kb) / 1024.) if kb else (float("nan"), float("nan"))


MEMORY_RESERVE_MB = 0  # --memory-reserve-mb: keep at least this much of the machine's memory available


def available_mb():
    return int(re.search(r"MemAvailable:\s+(\d+)", open("/proc/meminfo").read()).group(1)) / 1024.


def run(command, env_extra=None):
    """Runs one solver; with --memory-reserve-mb a watchdog kills it (its whole process group) when the
    machine's available memory falls below the reserve: a clean failure recorded in the CSV instead
    of the kernel's OOM killer picking a process on a shared machine."""
    env = dict(os.environ, **(env_extra or {}))
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        process = subprocess.Popen(command, stdout=out, stderr=err, text=True, env=env, start_new_session=True)
        killed = None
        while process.poll() is None:
            if MEMORY_RESERVE_MB > 0 and available_mb() < MEMORY_RESERVE_MB:
                killed = f"killed: the machine's available memory fell below {MEMORY_RESERVE_MB} MB"
                os.killpg(process.pid, 9)
                process.wait()
                break
            time.sleep(0.25)
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read(), err.read()
    if killed or process.returncode != 0:
        raise RuntimeError(killed or f"{' '.join(command)} failed ({process.returncode}):\n{stdout[-3000:]}\n{stderr[-3000:]}")
    return subprocess.CompletedProcess(command, 0, stdout, stderr)


def run_ours(build, folder, fine_size, operator, eigensolver, launcher=(), env_extra=None, options=()):
    """modal-precompute on the plate; launcher: mpirun and its arguments, when under MPI; options:
    more command-line options (--distributed: the MPI path on one rank)."""
    os.makedirs(folder, exist_ok=True)
    prm = os.path.join(folder, f"facts_plate_{operator}_{eigensolver}.prm")
    open(prm, "w").write(scene(fine_size, operator, eigensolver))
    out = run(list(launcher) + TIME + [os.path.join(build, "bin", "modal-precompute"), prm, "--output-dir", folder,
                                       "--quiet"] + list(options), env_extra)
    report = json.load(open(os.path.join(folder, "report.json")))
    rib = [s for s in report["spaces"] if s["name"] == "rib"][0]
    e = rib["eigensolver"]
    lam = [(2 * 3.141592653589793 * f) ** 2 for f in rib["computed_frequencies_hz"]]
    largest, total = peak_rss_mb(out.stderr)
    phases = dict(analyze=e["analyze_s"], factorize=e["factorize_s"], solves=e["solve_s"],
                  mass_products=e.get("mass_products_s", 0.), orthogonalization=e.get("orthogonalization_s", 0.),
                  krylov_total=e["arpack_s"])
    phases["rest"] = phases["krylov_total"] - phases["solves"] - phases["mass_products"] - phases["orthogonalization"]
    return dict(n=rib["n_dofs"], seconds=e["analyze_s"] + e["factorize_s"] + e["arpack_s"], phases=phases,
                solved=e["solved_vectors"], lambda_first=lam[0], lambda_last=lam[-1], factor_flops=e["factor_flops"],
                factor_nonzeros=e["factor_nonzeros"], peak_mb=largest, peak_total_mb=total)


def csr_size(path):
    """n of a binary CSR matrix file (README.md: int64 n first)."""
    with open(path, "rb") as f:
        return int.from_bytes(f.read(8), "little", signed=True)


def run_peer(command, env_extra):
    out = run(command, env_extra)
    line = [l for l in out.stdout.splitlines() if "seconds=" in l][-1]
    peer = {k: float(v) for k, v in re.findall(r"(\w+)=([-+0-9.e]+)", line)}
    peer["peak_mb"], peer["peak_total_mb"] = peak_rss_mb(out.stderr)
    return peer


def machine_limits(build):
    """OpenBLAS DGEMM rate on 1 and 2 threads and the memory read bandwidth, now."""
    result = {}
    for threads in (1, 2):
        out = run([os.path.join(build, "bin", "bench-machine-limits")], {"OPENBLAS_NUM_THREADS": str(threads)})
        values = {k: float(v) for k, v in re.findall(r"(\w+)=([-+0-9.e]+)", out.stdout)}
        result[f"dgemm_gflops_{threads}"] = values["dgemm_gflops"]
        result["read_gbs_1"], result["read_gbs_2"] = values["read_gbs_1"], values["read_gbs_2"]
    return result


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", default="build")
    parser.add_argument("--out", required=True)
    parser.add_argument("--work", default="/tmp/modal-haptics-bench-eigensolver")
    parser.add_argument("--sizes", default="0.72,0.345,0.213",
                        help="VOI fine sizes in mm (1.0 ~ 18k DoFs, 0.72 ~ 40k, 0.5 ~ 93k, 0.36 ~ 222k, 0.345 ~ 250k, "
                             "0.213 ~ 1M)")
    parser.add_argument("--repetitions", type=int, default=3, help="interleaved repetitions of the fast solvers")
    parser.add_argument("--slow-peer-limit", type=int, default=300000,
                        help="ARPACK + UMFPACK, scipy and LOBPCG + AMG run only up to this many DoFs (see the module doc)")
    parser.add_argument("--slow-peer-repetitions", type=int, default=1)
    parser.add_argument("--large-from", type=int, default=500000,
                        help="above this many DoFs only ours and SLEPc on 2 ranks run, once (see the module doc)")
    parser.add_argument("--skip-arpack-above", type=int, default=2000000,
                        help="ARPACK + CHOLMOD runs only up to this many DoFs")
    parser.add_argument("--solvers", default="ours,arpack,lobpcg,lobpcg2,mumps1,mumps2,slepc1,slepc2,umfpack,scipy",
                        help="which solvers run (ours is always first: it exports K and M); the others get a "
                             "'skipped: not in --solvers' row")
    parser.add_argument("--memory-reserve-mb", type=float, default=0.,
                        help="kill a solver when the machine's available memory falls below this (0: never); see run")
    args = parser.parse_args()
    global MEMORY_RESERVE_MB
    MEMORY_RESERVE_MB = args.memory_reserve_mb
    mpirun = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-np"]
    one_thread = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    rows = []
    limits = machine_limits(args.build)
    print(f"machine: DGEMM {limits['dgemm_gflops_1']:.1f} GFLOP/s on 1 thread, {limits['dgemm_gflops_2']:.1f} on 2; "
          f"read {limits['read_gbs_1']:.1f} GB/s on 1 thread, {limits['read_gbs_2']:.1f} on 2", flush=True)
    for fine in (float(s) for s in args.sizes.split(",")):
        folder = os.path.join(args.work, f"fine_{fine}")
        K, M = os.path.join(folder, "rib_K.csr"), os.path.join(folder, "rib_M.csr")
        names = {"ours": "ours: block Krylov + CHOLMOD supernodal (METIS, OpenBLAS 2 threads)",
                 "arpack": "ARPACK + CHOLMOD supernodal (METIS, OpenBLAS 2 threads)",
                 "lobpcg": "ours: LOBPCG (Anasazi) + AMG (ML), no factorization",
                 "lobpcg2": "ours: LOBPCG (Anasazi) + AMG (ML), no factorization, distributed",
                 "mumps1": "ours, distributed: block Krylov over MUMPS Cholesky (METIS order; OpenBLAS 1 thread/rank)",
                 "mumps2": "ours, distributed: block Krylov over MUMPS Cholesky (METIS order; OpenBLAS 1 thread/rank)",
                 "slepc1": "SLEPc Krylov-Schur + MUMPS Cholesky (OpenBLAS 1 thread/rank)",
                 "slepc2": "SLEPc Krylov-Schur + MUMPS Cholesky (OpenBLAS 1 thread/rank)",
                 "umfpack": "ARPACK + deal.II SparseDirectUMFPACK (OpenBLAS)",
                 "scipy": "scipy eigsh sigma=0 (ARPACK + SuperLU)"}
        ranks = dict(ours=1, arpack=1, lobpcg=1, lobpcg2=2, mumps1=1, mumps2=2, slepc1=1, slepc2=2, umfpack=1, scipy=1)
        runners = {
            "ours": lambda: run_ours(args.build, folder, fine, "cholmod", "block-krylov"),
            "arpack": lambda: run_ours(args.build, folder, fine, "cholmod", "arpack"),
            "lobpcg": lambda: run_ours(args.build, folder, fine, "cholmod", "lobpcg-amg"),
            "lobpcg2": lambda: run_ours(args.build, folder, fine, "cholmod", "lobpcg-amg", mpirun + ["2"]),
            # The same MUMPS as the SLEPc peers below, on as many ranks and BLAS threads.
            "mumps1": lambda: run_ours(args.build, folder, fine, "cholmod", "block-krylov", mpirun + ["1"], one_thread,
                                       ["--distributed"]),
            "mumps2": lambda: run_ours(args.build, folder, fine, "cholmod", "block-krylov", mpirun + ["2"], one_thread),
            "slepc1": lambda: run_peer(mpirun + ["1"] + TIME + [os.path.join(args.build, "bin", "bench-slepc-peer"), K, M,
                                                                str(NEV)], one_thread),
            "slepc2": lambda: run_peer(mpirun + ["2"] + TIME + [os.path.join(args.build, "bin", "bench-slepc-peer"), K, M,
                                                                str(NEV)], one_thread),
            "umfpack": lambda: run_ours(args.build, folder, fine, "umfpack", "arpack"),
            "scipy": lambda: run_peer(TIME + ["/usr/bin/python3", os.path.join(HERE, "scipy_peer.py"), K, M, str(NEV)], {}),
        }
        results = {key: [] for key in runners}
        n = None
        skipped = {}
        for repetition in range(args.repetitions):
            for key, runner in runners.items():
                if key in skipped:
                    continue
                if key != "ours" and key not in args.solvers.split(","):
                    skipped[key] = "skipped: not in --solvers for this run"
                    continue
                if n is not None and key in ("umfpack", "scipy", "lobpcg", "lobpcg2"):
                    if n > args.slow_peer_limit:
                        skipped[key] = (f"skipped above --slow-peer-limit {args.slow_peer_limit} DoFs: "
                                        + ("LOBPCG + AMG took 10x the direct path at 250k DoFs and grows as n^1.2"
                                           if key.startswith("lobpcg") else
                                           "single-threaded LU whose time grows about as n^1.6-2")
                                        + " (see the smaller sizes' rows)")
                        continue
                    if repetition >= args.slow_peer_repetitions:
                        continue
                if n is not None and n > args.large_from:
                    if key not in ("ours", "slepc2", "mumps2"):
                        skipped[key] = (f"skipped above --large-from {args.large_from} DoFs: only ours (serial, and "
                                        "over MUMPS on 2 ranks) and the goal's peer (SLEPc on 2 ranks) run there, once")
                        continue
                    if repetition >= 1:
                        continue
                if n is not None and key == "arpack" and n > args.skip_arpack_above:
                    skipped[key] = f"skipped above --skip-arpack-above {args.skip_arpack_above} DoFs"
                    continue
                try:
                    r = runner()
                except RuntimeError as error:
                    print(f"  {names[key]}, {ranks[key]} rank(s): FAILED\n{error}", flush=True)
                    r = dict(failed=str(error).splitlines()[0][:200])
                results[key].append(r)
                if key == "ours" and n is None:
                    # The size from our run, or (it failed) from the K it exported in an earlier run.
                    n = r["n"] if "n" in r else (csr_size(K) if os.path.exists(K) else None)
                if "failed" not in r:
                    print(f"[{fine} mm, {n} DoFs, repetition {repetition + 1}] {names[key]}, {ranks[key]} rank(s): "
                          f"{r['seconds']:.1f} s, peak {r['peak_mb']:.0f} MB"
                          + (f" ({', '.join(f'{k} {v:.2f} s' for k, v in r['phases'].items())}, {r['solved']} solved)"
                             if "phases" in r else ""), flush=True)
        reference = None
        for key in runners:
            good = [r for r in results[key] if "failed" not in r]
            failures = [r["failed"] for r in results[key] if "failed" in r]
            if not good:
                if key in skipped or failures:
                    rows.append(dict(fine_size_mm=fine, n_dofs=n, solver=names[key], ranks=ranks[key], repetitions=0,
                                     note=skipped.get(key, "failed: " + "; ".join(failures))))
                continue
            seconds = [r["seconds"] for r in good]
            row = dict(fine_size_mm=fine, n_dofs=n, solver=names[key], ranks=ranks[key], repetitions=len(good),
                       seconds=statistics.median(seconds), seconds_min=min(seconds), seconds_max=max(seconds),
                       peak_rss_mb_per_process=max(r["peak_mb"] for r in good),
                       peak_rss_mb_all_ranks=max(r["peak_total_mb"] for r in good),
                       lambda_first=good[0]["lambda_first"], lambda_last=good[0]["lambda_last"],
                       note=("failed in %d of %d repetitions: %s" % (len(failures), len(results[key]), failures[0])
                             if failures else ""))
            if "phases" in good[0]:
                row["phases_median_s"] = "; ".join(f"{p} {statistics.median(r['phases'][p] for r in good):.2f}"
                                                   for p in good[0]["phases"])
                row["solved_vectors"] = good[0]["solved"]
                row["factor_nonzeros"] = good[0]["factor_nonzeros"]
                if good[0]["factor_flops"] > 0:  # CHOLMOD and MUMPS count them, UMFPACK through deal.II does not
                    row["factor_gflops"] = good[0]["factor_flops"] / 1e9 / statistics.median(r["phases"]["factorize"]
                                                                                             for r in good)
            if key == "ours":
                reference = row
            rows.append(row)
        for row in rows:
            if row["n_dofs"] == n and "seconds" in row and reference is not None:
                row["ratio_to_ours"] = row["seconds"] / reference["seconds"]
                row["lambda_last_rel_diff"] = abs(row["lambda_last"] - reference["lambda_last"]) / reference["lambda_last"]
    after = machine_limits(args.build)
    for key, value in limits.items():
        unit = "GFLOP/s" if key.startswith("dgemm") else "GB/s"
        what = (f"machine: OpenBLAS DGEMM n=4000, {key[-1]} thread(s)" if key.startswith("dgemm")
                else f"machine: memory read bandwidth, {key[-1]} thread(s)")
        rows.append(dict(solver=what, rate=value, rate_after=after[key], rate_unit=unit,
                         note="measured before (rate) and after (rate_after) the solvers"))
    fields = ["fine_size_mm", "n_dofs", "solver", "ranks", "repetitions", "seconds", "seconds_min", "seconds_max",
              "ratio_to_ours", "peak_rss_mb_per_process", "peak_rss_mb_all_ranks", "lambda_first", "lambda_last",
              "lambda_last_rel_diff", "phases_median_s", "solved_vectors", "factor_nonzeros", "factor_gflops", "rate",
              "rate_after", "rate_unit", "note"]
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    # Written beside the target, then renamed (a kill leaves the previous CSV whole); open() gives the
    # file the umask's mode, where a NamedTemporaryFile would stay 0600.
    with open(args.out + ".tmp", "w", newline="") as f:
        f.write(f"# load average at the end: {' '.join(open('/proc/loadavg').read().split()[:3])}\n")
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
    os.replace(args.out + ".tmp", args.out)
    print(f"\n{'DoFs':>8} {'ranks':>5} {'median s':>9} {'x ours':>7} {'peak MB':>8}  solver")
    for r in rows:
        if "seconds" in r:
            print(f"{r['n_dofs']:8d} {r['ranks']:5d} {r['seconds']:9.2f} {r.get('ratio_to_ours', float('nan')):7.2f} "
                  f"{r['peak_rss_mb_per_process']:8.0f}  {r['solver']}")
        elif "n_dofs" in r:
            print(f"{str(r['n_dofs']):>8} {r['ranks']:5d} {'-':>9} {'-':>7} {'-':>8}  {r['solver']}: {r['note']}")
        else:
            print(f"{r['rate']:.1f} / {r['rate_after']:.1f} {r['rate_unit']}  {r['solver']}")
    print(f"written {args.out}")


if __name__ == "__main__":
    sys.exit(main())

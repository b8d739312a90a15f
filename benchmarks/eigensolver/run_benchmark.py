#!/usr/bin/python3
"""The eigensolver benchmark: 50 lowest modes of the FACTS plate (facts_plate.geo, linear tets,
graded around one rib) at several sizes; our default path (ARPACK + CHOLMOD) against deal.II's
UMFPACK under the same ARPACK driver, SLEPc Krylov-Schur + MUMPS Cholesky on 1 and 2 ranks, and
scipy's eigsh (ARPACK + SuperLU), all on the same K and M, in one run. Writes a CSV with the ratios.

  run_benchmark.py --build build --out benchmarks/results/<host>/eigensolver.csv [--sizes 1.0,0.5] [--skip-slow]
"""
import argparse
import csv
import json
import os
import re
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
NEV = 50


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


def run_ours(build, folder, fine_size, operator, eigensolver):
    os.makedirs(folder, exist_ok=True)
    prm = os.path.join(folder, f"facts_plate_{operator}_{eigensolver}.prm")
    open(prm, "w").write(scene(fine_size, operator, eigensolver))
    subprocess.run([os.path.join(build, "bin", "modal-precompute"), prm, "--output-dir", folder, "--quiet"], check=True)
    report = json.load(open(os.path.join(folder, "report.json")))
    rib = [s for s in report["spaces"] if s["name"] == "rib"][0]
    e = rib["eigensolver"]
    lam = [(2 * 3.141592653589793 * f) ** 2 for f in rib["computed_frequencies_hz"]]
    return dict(n=rib["n_dofs"], seconds=e["analyze_s"] + e["factorize_s"] + e["arpack_s"],
                phases=f"analyze {e['analyze_s']:.2f} s, factorize {e['factorize_s']:.2f} s, "
                       f"{e['operator_applications']} solves {e['solve_s']:.2f} s, lanczos total {e['arpack_s']:.2f} s",
                lambda_first=lam[0], lambda_last=lam[-1], factor_flops=e["factor_flops"], factorize_s=e["factorize_s"])


def parse_peer(output):
    line = [l for l in output.splitlines() if "seconds=" in l][-1]
    return {k: float(v) for k, v in re.findall(r"(\w+)=([-+0-9.e]+)", line)}


def run_peer(command, env_extra):
    env = dict(os.environ, **env_extra)
    start = time.perf_counter()
    out = subprocess.run(command, check=True, capture_output=True, text=True, env=env)
    peer = parse_peer(out.stdout)
    peer["wall"] = time.perf_counter() - start
    return peer


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", default="build")
    parser.add_argument("--out", required=True)
    parser.add_argument("--work", default="/tmp/modal-haptics-bench-eigensolver")
    parser.add_argument("--sizes", default="1.0,0.5", help="VOI fine sizes in mm (1.0 ~ 18k DoFs, 0.5 ~ 93k, 0.36 ~ 222k)")
    parser.add_argument("--skip-slow", action="store_true", help="run UMFPACK and scipy only on the smallest size")
    args = parser.parse_args()
    rows = []
    mpirun = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-np"]
    one_thread = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    sizes = [float(s) for s in args.sizes.split(",")]
    for size_index, fine in enumerate(sizes):
        folder = os.path.join(args.work, f"fine_{fine}")
        ours = run_ours(args.build, folder, fine, "cholmod", "block-krylov")
        n = ours["n"]
        print(f"[{fine} mm, {n} DoFs] ours: {ours['seconds']:.1f} s ({ours['phases']})", flush=True)
        rows.append(dict(fine_size_mm=fine, n_dofs=n, solver="ours: block Krylov + CHOLMOD supernodal (METIS, OpenBLAS 2 threads)",
                         ranks=1, seconds=ours["seconds"], lambda_first=ours["lambda_first"],
                         lambda_last=ours["lambda_last"], phases=ours["phases"]))
        arpack = run_ours(args.build, folder, fine, "cholmod", "arpack")
        print(f"  ARPACK + CHOLMOD: {arpack['seconds']:.1f} s ({arpack['phases']})", flush=True)
        rows.append(dict(fine_size_mm=fine, n_dofs=n, solver="ARPACK + CHOLMOD supernodal (METIS, OpenBLAS 2 threads)",
                         ranks=1, seconds=arpack["seconds"], lambda_first=arpack["lambda_first"],
                         lambda_last=arpack["lambda_last"], phases=arpack["phases"]))
        K, M = os.path.join(folder, "rib_K.csr"), os.path.join(folder, "rib_M.csr")
        slow_ok = not args.skip_slow or size_index == 0
        for ranks in [1, 2]:
            p = run_peer(mpirun + [str(ranks), os.path.join(args.build, "bin", "bench-slepc-peer"), K, M, str(NEV)], one_thread)
            print(f"  SLEPc + MUMPS, {ranks} rank(s): {p['seconds']:.1f} s", flush=True)
            rows.append(dict(fine_size_mm=fine, n_dofs=n, solver="SLEPc Krylov-Schur + MUMPS Cholesky (OpenBLAS 1 thread/rank)",
                             ranks=ranks, seconds=p["seconds"], lambda_first=p["lambda_first"], lambda_last=p["lambda_last"], phases=""))
        if slow_ok:
            umf = run_ours(args.build, folder, fine, "umfpack", "arpack")
            print(f"  ARPACK + UMFPACK: {umf['seconds']:.1f} s", flush=True)
            rows.append(dict(fine_size_mm=fine, n_dofs=n, solver="ARPACK + deal.II SparseDirectUMFPACK (OpenBLAS)", ranks=1,
                             seconds=umf["seconds"], lambda_first=umf["lambda_first"], lambda_last=umf["lambda_last"],
                             phases=umf["phases"]))
            p = run_peer(["/usr/bin/python3", os.path.join(HERE, "scipy_peer.py"), K, M, str(NEV)], {})
            print(f"  scipy eigsh: {p['seconds']:.1f} s", flush=True)
            rows.append(dict(fine_size_mm=fine, n_dofs=n, solver="scipy eigsh sigma=0 (ARPACK + SuperLU)", ranks=1,
                             seconds=p["seconds"], lambda_first=p["lambda_first"], lambda_last=p["lambda_last"], phases=""))
    for row in rows:
        reference = [r for r in rows if r["n_dofs"] == row["n_dofs"] and r["solver"].startswith("ours")][0]
        row["ratio_to_ours"] = row["seconds"] / reference["seconds"]
        row["lambda_last_rel_diff"] = abs(row["lambda_last"] - reference["lambda_last"]) / reference["lambda_last"]
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        writer.writerows(rows)
    print(f"\n{'DoFs':>8} {'ranks':>5} {'seconds':>9} {'x ours':>7}  solver")
    for r in rows:
        print(f"{r['n_dofs']:8d} {r['ranks']:5d} {r['seconds']:9.2f} {r['ratio_to_ours']:7.2f}  {r['solver']}")
    print(f"written {args.out}")


if __name__ == "__main__":
    sys.exit(main())

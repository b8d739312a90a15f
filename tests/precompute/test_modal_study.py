#!/usr/bin/python3
"""The quick speed/accuracy study (parameters/study_quick.prm) runs and its numbers behave as the
physics and the method say they must:
- on each point, adding modes never increases the modal-only error against the point's own full FE
  solution (felt compliance and display field): B_r Lambda_r^-1 B_r^T grows monotonically towards
  W^T K^-1 W;
- the static correction makes every contact exact for its mesh (B Lambda^-1 B^T + C_v = W^T K^-1 W),
  whatever r;
- P2 is closer to the reference than P1 on the same mesh (felt compliance and first frequency);
- a larger r gives a larger .mrt; the kernel ticks were timed; study.md and the four plots exist;
- the force axis: the reference's nonlinear curve starts at its linear compliance (the nonlinear
  module's d^T W^T K^-1 W d against the precompute's full compliance), stays near it at the first load
  level, and every row's error at each force level is |c / c_nl(F) - 1| recomputed from
  force_curves.csv and the row's felt compliances; the stiffness-vs-force plot exists (where the
  study file sets Force levels: the quick study does, the full one of docs/accuracy.md does not).
Bad study files are refused with a message that names the file and the entry."""
import argparse
import csv
import os
import re
import shutil
import subprocess
import sys


def fail(message):
    print("FAIL:", message)
    sys.exit(1)


def rows_by_point(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    points = {}
    for row in rows:
        points.setdefault(row["point"], []).append(row)
    return rows, points


def check_monotone(points):
    for name, rows in points.items():
        counted = sorted((r for r in rows if r["r_rule"] == "count"), key=lambda r: int(r["modes"]))
        for key in ("truncation_error", "display_error_modal"):
            values = [float(r[key]) for r in counted]
            if any(b > a * (1 + 1e-9) + 1e-14 for a, b in zip(values, values[1:])):
                fail(f"{name}: {key} grows with r: {values}")
        print(f"{name}: truncation error {float(counted[0]['truncation_error']):.4f} -> "
              f"{float(counted[-1]['truncation_error']):.4f} for r = {counted[0]['modes']} -> {counted[-1]['modes']}")


def check_correction(rows):
    worst = max(float(r["correction_residual"]) for r in rows)
    if worst > 1e-8:
        fail(f"corrected contact compliance differs from the full FE one by {worst:.2e} (> 1e-8)")
    print(f"corrected compliance = full FE compliance to {worst:.1e}")


def check_degrees(points):
    firsts = [rows[0] for rows in points.values()]
    compared = 0
    for p1 in (r for r in firsts if r["degree"] == "1"):
        for p2 in firsts:
            same_mesh = all(p2[k] == p1[k] for k in ("mesh", "coarse_size", "fine_size"))
            if p2["degree"] != "2" or not same_mesh:
                continue
            compared += 1
            for key in ("felt_error_corrected", "frequency_error_first"):
                if not float(p2[key]) < float(p1[key]):
                    fail(f"{key}: P2 ({p2[key]}) is not closer to the reference than P1 ({p1[key]}) on {p1['point']}")
            print(f"{p1['mesh']} {p1['coarse_size']}/{p1['fine_size']}: felt error P1 {float(p1['felt_error_corrected']):.3f}"
                  f" > P2 {float(p2['felt_error_corrected']):.3f}; f1 error P1 {float(p1['frequency_error_first']):.4f} > "
                  f"P2 {float(p2['frequency_error_first']):.4f}")
    if compared == 0:
        fail("no P1/P2 pair on the same mesh")


def check_costs(points):
    for name, rows in points.items():
        counted = sorted((r for r in rows if r["r_rule"] == "count"), key=lambda r: int(r["modes"]))
        sizes = [int(r["mrt_bytes"]) for r in counted]
        if sizes != sorted(sizes) or len(set(sizes)) != len(sizes):
            fail(f"{name}: .mrt size does not grow with r: {sizes}")
        for r in rows:
            if not (float(r["tick_p50_ns"]) > 0 and float(r["corrected_tick_p50_ns"]) > 0 and float(r["display_ms"]) > 0):
                fail(f"{name}, r = {r['modes']}: kernel cost not measured")


def secant_compliance(linear, curve, force):
    """delta(F)/F interpolated linearly in F between the levels, linear at F = 0 (as modal-study does)."""
    previous_force, previous_secant = 0.0, linear
    for level, displacement in curve:
        secant = displacement / level
        if force <= level:
            return previous_secant + (secant - previous_secant) * (force - previous_force) / (level - previous_force)
        previous_force, previous_secant = level, secant
    return float("nan")


def check_force_axis(output, rows):
    with open(os.path.join(output, "reference.csv")) as f:
        references = {int(r["contact"]): r for r in csv.DictReader(f)}
    curves = {}
    with open(os.path.join(output, "force_curves.csv")) as f:
        for r in csv.DictReader(f):
            linear, curve = curves.setdefault(int(r["contact"]), (float(r["linear_compliance_m_per_n"]), []))
            curve.append((float(r["force_n"]), float(r["felt_displacement_m"])))
    if not curves:
        fail("force_curves.csv has no curve")
    for contact, (linear, curve) in curves.items():
        full = float(references[contact]["felt_compliance_m_per_n"])
        if abs(linear / full - 1) > 1e-8:
            fail(f"contact {contact}: the nonlinear solve's linear compliance {linear:.10e} != full FE {full:.10e}")
        first = abs(linear * curve[0][0] / curve[0][1] - 1)
        if first > 0.02:
            fail(f"contact {contact}: at the first load level {curve[0][0]} N the nonlinear compliance departs "
                 f"{100 * first:.2f} % from the linear one (> 2 %)")
        print(f"contact {contact}: linear compliance = full FE to {abs(linear / full - 1):.1e}; "
              f"{len(curve)} levels up to {curve[-1][0]:g} N, departure {100 * abs(linear * curve[-1][0] / curve[-1][1] - 1):.3f} %")
    prefix = "felt_error_corrected_at_"
    levels = [key[len(prefix):-2] for key in rows[0] if key.startswith(prefix)]
    if not levels:
        fail("study.csv has no felt_error_corrected_at_<F>_n column")
    worst = 0.0
    for row in rows:
        felt = [float(x) for x in row["corrected_felt_compliance_m_per_n"].split(";")]
        for level in levels:
            expected = max(abs(c / secant_compliance(curves[k + 1][0], curves[k + 1][1], float(level)) - 1)
                           for k, c in enumerate(felt))
            reported = float(row[prefix + level + "_n"])
            worst = max(worst, abs(reported - expected))
            if abs(reported - expected) > 1e-9 + 1e-6 * expected:
                fail(f"{row['point']} r = {row['modes']}: error at {level} N is {reported}, recomputed {expected}")
    print(f"force axis at {', '.join(levels)} N: every row's corrected error recomputed to {worst:.1e}")


def sets_force_levels(study):
    """Whether the study file asks for the force axis (the full study of docs/accuracy.md does not)."""
    with open(study) as f:
        return re.search(r"^\s*set\s+Force levels\s*=\s*\S", f.read(), re.M) is not None


def check_bad_study(binary, workdir, scene):
    cases = {
        "unknown_scenario": (f"subsection Study\n  set Scene file = {scene}\n  set Scenario = nowhere\n"
                             "  set Contact points = -10, 0, 10\nend\n", "nowhere"),
        "bad_pattern": (f"subsection Study\n  set Scene file = {scene}\n  set Mode counts = 5, many\nend\n", "Mode counts"),
        "negative_force": (f"subsection Study\n  set Scene file = {scene}\n  set Scenario = left\n"
                           "  set Contact points = -10, 0, 10\n  set Force levels = 5, -1\nend\n", "Force levels"),
        "missing_scene": ("subsection Study\n  set Scene file = no_such_scene.prm\n  set Scenario = left\n"
                          "  set Contact points = 0, 0, 0\nend\n", "no_such_scene.prm"),
    }
    for name, (text, expected) in cases.items():
        path = os.path.join(workdir, name + ".prm")
        with open(path, "w") as f:
            f.write(text)
        done = subprocess.run([binary, path, "--output-dir", os.path.join(workdir, name)], capture_output=True, text=True)
        if done.returncode == 0 or expected not in done.stderr:
            fail(f"{name}: exit {done.returncode}, stderr does not name '{expected}':\n{done.stderr}")
        print(f"bad study '{name}': exit {done.returncode}, names '{expected}'")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--binary", required=True)
    parser.add_argument("--study", required=True)
    parser.add_argument("--workdir", required=True)
    args = parser.parse_args()
    shutil.rmtree(args.workdir, ignore_errors=True)
    os.makedirs(args.workdir)
    output = os.path.join(args.workdir, "study")
    subprocess.run([args.binary, args.study, "--output-dir", output], check=True)

    rows, points = rows_by_point(os.path.join(output, "study.csv"))
    if len(points) < 4:
        fail(f"expected at least 4 study points, found {len(points)}")
    check_monotone(points)
    check_correction(rows)
    check_degrees(points)
    check_costs(points)
    plots = ["error_vs_modes.png", "error_vs_dofs.png", "error_vs_offline_time.png", "pareto.png"]
    if sets_force_levels(args.study):
        check_force_axis(output, rows)
        plots.append("stiffness_vs_force.png")
    for name in ["study.md", "reference.csv", *plots]:
        if not os.path.getsize(os.path.join(output, name)) > 0:
            fail(f"{name} is empty")
    scene = os.path.relpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "small_scene.prm"), args.workdir)
    check_bad_study(args.binary, args.workdir, scene)
    print("PASS")


if __name__ == "__main__":
    main()

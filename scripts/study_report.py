#!/usr/bin/python3
"""study.md and the plots of a modal-study run (called by modal-study; rerun it by hand on a folder):

    scripts/study_report.py DIR        reads DIR/study.csv and DIR/reference.csv

Writes DIR/study.md (the table and the answers the study is for) and DIR/error_vs_modes.png,
error_vs_dofs.png, error_vs_offline_time.png, pareto.png; with a force axis ('Force levels': the
reference's nonlinear curves in DIR/force_curves.csv) also a section on force and
DIR/stiffness_vs_force.png. Every number comes from the CSVs."""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

THRESHOLDS = (0.01, 0.05, 0.10)


def read_rows(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    for row in rows:
        for key, value in row.items():
            try:
                row[key] = float(value)
            except ValueError:
                pass
        row["compliances"] = [float(x) for x in str(row["corrected_felt_compliance_m_per_n"]).split(";")]
    return rows


def points_of(rows):
    """The study points in order, each with its rows sorted by r (mode counts first, then the rules)."""
    points = {}
    for row in rows:
        points.setdefault(row["point"], []).append(row)
    return points


def short_name(row):
    if row["mesh"] == "graded":
        return f"P{int(row['degree'])} graded {row['coarse_size']:g}/{row['fine_size']:g}"
    return f"P{int(row['degree'])} uniform {row['fine_size']:g}"


def percent(x):
    return f"{100 * x:.3g} %"


def counted(rows):
    return sorted((r for r in rows if r["r_rule"] == "count"), key=lambda r: r["modes"])


def modes_needed(rows, key, threshold):
    for row in counted(rows):
        if row[key] <= threshold:
            return f"{int(row['modes'])}"
    return f"> {int(counted(rows)[-1]['modes'])}"


def table(points):
    lines = ["| point | DoFs | r | felt error modal-only | corrected | display error modal-only | f1 error | "
             "offline [s] | correction [ms/candidate] | .mrt [MB] | tick p50 modal / corrected [ns] | display [ms] |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for rows in points.values():
        for row in rows:
            rule = "" if row["r_rule"] == "count" else f" ({row['r_rule']})"
            lines.append(
                f"| {short_name(row)} | {int(row['n_dofs']):,} | {int(row['modes'])}{rule} | "
                f"{percent(row['felt_error_modal'])} | {percent(row['felt_error_corrected'])} | "
                f"{percent(row['display_error_modal'])} | {percent(row['frequency_error_first'])} | "
                f"{row['offline_total_s']:.1f} | {row['correction_ms_per_candidate']:.1f} | "
                f"{row['mrt_bytes'] / 1e6:.2f} | {row['tick_p50_ns']:.0f} / {row['corrected_tick_p50_ns']:.0f} | "
                f"{row['display_ms']:.3f} |")
    return lines


def modes_answer(points):
    lines = ["Smallest r of the study's counts whose modal-only felt-stiffness error is at or below 1 %, 5 %, "
             "10 %: against the reference, and (in brackets) against the point's own full FE solution "
             "(truncation alone).", "",
             "| point | 1 % | 5 % | 10 % |", "|---|---|---|---|"]
    for rows in points.values():
        cells = [f"{modes_needed(rows, 'felt_error_modal', t)} ({modes_needed(rows, 'truncation_error', t)})"
                 for t in THRESHOLDS]
        lines.append(f"| {short_name(rows[0])} | " + " | ".join(cells) + " |")
    return lines


def correction_answer(points):
    lines = ["What the static correction costs and buys, at the largest r:", "",
             "| point | candidates | correction [s] | per candidate [ms] | tick p50 modal → corrected [ns] | "
             "felt error modal-only → corrected |", "|---|---|---|---|---|---|"]
    for rows in points.values():
        top = counted(rows)[-1]
        lines.append(f"| {short_name(top)} | {int(top['candidates'])} | {top['static_correction_s']:.2f} | "
                     f"{top['correction_ms_per_candidate']:.1f} | {top['tick_p50_ns']:.0f} → "
                     f"{top['corrected_tick_p50_ns']:.0f} | {percent(top['felt_error_modal'])} → "
                     f"{percent(top['felt_error_corrected'])} |")
    return lines


def graded_answer(points):
    """Graded VOI meshes against the uniform mesh of their fine size: the felt compliance (corrected,
    so exact for each mesh) at every contact, and the DoFs."""
    firsts = [rows[0] for rows in points.values()]
    lines = ["Graded VOI mesh against the uniform mesh of the VOI's fine size (corrected felt compliance, "
             "largest difference over the contacts; goal: within 1 % with at most 25 % of the DoFs):", "",
             "| graded | uniform | DoFs graded / uniform | felt compliance difference | goal |",
             "|---|---|---|---|---|"]
    found = False
    for graded in (r for r in firsts if r["mesh"] == "graded"):
        for uniform in (r for r in firsts if r["mesh"] == "uniform"):
            if uniform["degree"] != graded["degree"] or uniform["fine_size"] != graded["fine_size"]:
                continue
            found = True
            ratio = graded["n_dofs"] / uniform["n_dofs"]
            difference = max(abs(g - u) / u for g, u in zip(graded["compliances"], uniform["compliances"]))
            met = "met" if ratio <= 0.25 and difference <= 0.01 else "not met"
            lines.append(f"| {short_name(graded)} | {short_name(uniform)} | {ratio:.3f} | {percent(difference)} | {met} |")
    if not found:
        lines.append("| (no graded point has a uniform point of its fine size and degree) | | | | |")
    return lines


def degree_answer(points):
    firsts = [rows[0] for rows in points.values()]
    p1 = [r for r in firsts if r["degree"] == 1]
    lines = ["P1 against P2 at (nearly) equal DoFs: each P2 point with the P1 point closest in DoFs:", "",
             "| P2 point | DoFs | felt error corrected | f1 error | P1 point | DoFs | felt error corrected | f1 error |",
             "|---|---|---|---|---|---|---|---|"]
    for p2 in (r for r in firsts if r["degree"] == 2):
        if not p1:
            break
        closest = min(p1, key=lambda r: abs(r["n_dofs"] / p2["n_dofs"] - 1))
        lines.append(f"| {short_name(p2)} | {int(p2['n_dofs']):,} | {percent(p2['felt_error_corrected'])} | "
                     f"{percent(p2['frequency_error_first'])} | {short_name(closest)} | {int(closest['n_dofs']):,} | "
                     f"{percent(closest['felt_error_corrected'])} | {percent(closest['frequency_error_first'])} |")
    return lines


def plot_error_vs_modes(points, path):
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for rows in points.values():
        rows = counted(rows)
        r = [row["modes"] for row in rows]
        line, = ax.plot(r, [row["felt_error_modal"] for row in rows], "o-", label=short_name(rows[0]))
        ax.plot(r, [row["felt_error_corrected"] for row in rows], "--", color=line.get_color())
    ax.set(xscale="log", yscale="log", xlabel="modes r", ylabel="felt-compliance error vs reference",
           title="solid: modal only, dashed: with static correction")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_error_vs(points, key, xlabel, path, title):
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for mesh, marker in (("graded", "o"), ("uniform", "s")):
        for degree, color in ((1, "tab:red"), (2, "tab:blue")):
            rows = [rows[0] for rows in points.values() if rows[0]["mesh"] == mesh and rows[0]["degree"] == degree]
            if rows:
                ax.plot([r[key] for r in rows], [r["felt_error_corrected"] for r in rows], marker, color=color,
                        label=f"P{degree} {mesh}")
    ax.set(xscale="log", yscale="log", xlabel=xlabel, ylabel="felt-compliance error vs reference (corrected)",
           title=title)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_pareto(rows, path):
    """Every (point, r) twice: modal only at the plain tick's cost, corrected at the corrected tick's."""
    candidates = [(r["tick_p50_ns"], r["felt_error_modal"]) for r in rows] + \
                 [(r["corrected_tick_p50_ns"], r["felt_error_corrected"]) for r in rows]
    front, best = [], float("inf")
    for cost, error in sorted(candidates):
        if error < best:
            front.append((cost, error))
            best = error
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot([r["tick_p50_ns"] for r in rows], [r["felt_error_modal"] for r in rows], "o", alpha=0.5, label="modal only")
    ax.plot([r["corrected_tick_p50_ns"] for r in rows], [r["felt_error_corrected"] for r in rows], "s", alpha=0.5,
            label="corrected")
    ax.step([c for c, _ in front], [e for _, e in front], "k-", where="post", label="Pareto front")
    ax.set(yscale="log", xlabel="kernel tick p50 [ns] (1 HIP)", ylabel="felt-compliance error vs reference",
           title="accuracy against per-tick cost")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def force_levels(rows):
    """The study's force levels [N], from study.csv's felt_error_corrected_at_<F>_n columns."""
    prefix, suffix = "felt_error_corrected_at_", "_n"
    return sorted(float(key[len(prefix):-len(suffix)]) for key in rows[0] if key.startswith(prefix))


def read_force_curves(folder):
    """{(patch radius, contact): (vertex, linear compliance, [(force, displacement)], stop reason)}."""
    path = os.path.join(folder, "force_curves.csv")
    curves = {}
    if not os.path.exists(path):
        return curves
    with open(path) as f:
        for row in csv.DictReader(f):
            key = (float(row["patch_radius"]), int(row["contact"]))
            vertex, linear, points, _ = curves.get(key, (int(row["vertex"]), float(row["linear_compliance_m_per_n"]), [], ""))
            points.append((float(row["force_n"]), float(row["felt_displacement_m"])))
            curves[key] = (vertex, linear, points, row["stop_reason"])
    return curves


def force_answer(folder, points, levels, curves):
    lines = ["The linear basis against the geometrically nonlinear part: at each force level F, |c / c_nl(F) − 1| "
             "of the felt compliance c (corrected, and modal-only at the largest r) against the reference's "
             "nonlinear secant compliance c_nl(F) = δ(F)/F (a dead patch load pushing along the study's "
             "direction), the largest over the contacts; blank where the reference did not carry F.", ""]
    header = " | ".join(f"{level:g} N" for level in levels)
    lines += [f"| point | r | {header} |", "|---|---|" + "---|" * len(levels)]
    for rows in points.values():
        top = counted(rows)[-1]
        for label, key in (("corrected", "felt_error_corrected_at_"), ("modal-only", "felt_error_modal_at_")):
            cells = []
            for level in levels:
                value = top[f"{key}{level:g}_n"]
                cells.append("" if value != value else percent(value))
            lines.append(f"| {short_name(top)} {label} | {int(top['modes'])} | " + " | ".join(cells) + " |")
    lines += ["", "Where the reference's own linear compliance departs from its nonlinear one by 1, 5, 10 % "
              "(the validity forces: above them even an exact linear model is off by that much):", "",
              "| ρ | contact (vertex) | linear stiffness [N/mm] | 1 % | 5 % | 10 % | solved up to |", "|---|---|---|---|---|---|---|"]
    with open(os.path.join(folder, "reference.csv")) as f:
        validity = {(float(r["patch_radius"]), int(r["contact"])): r for r in csv.DictReader(f)}
    for (rho, contact), (vertex, linear, curve, stop) in sorted(curves.items()):
        forces = [float(validity[(rho, contact)][f"validity_force_{p}_percent_n"]) for p in (1, 5, 10)]
        cells = " | ".join("not reached" if f == float("inf") else f"{f:.3g} N" for f in forces)
        reached = f"{curve[-1][0]:g} N" + (f" ({stop})" if stop else "")
        lines.append(f"| {rho:g} | {contact} ({vertex}) | {1e-3 / linear:.4g} | {cells} | {reached} |")
    return lines


def plot_stiffness_vs_force(curves, path):
    """Per contact: the reference's nonlinear secant stiffness F/δ(F) against F, its linear stiffness and
    the 1, 5, 10 % lines around it."""
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for (rho, contact), (vertex, linear, curve, _) in sorted(curves.items()):
        forces = [0.0] + [f for f, _ in curve]
        stiffness = [1e-3 / linear] + [1e-3 * f / d for f, d in curve]
        line, = ax.plot(forces, stiffness, "o-", ms=3, label=f"contact {contact} (vertex {vertex}), ρ = {rho:g}")
        for threshold, style in zip(THRESHOLDS, (":", "--", "-.")):
            for sign in (-1, 1):
                ax.axhline(1e-3 / linear * (1 + sign * threshold), color=line.get_color(), ls=style, lw=0.8,
                           label=f"linear ± {100 * threshold:g} %" if sign > 0 and contact == 1 else None)
        ax.axhline(1e-3 / linear, color=line.get_color(), lw=0.8)
    ax.set(xlabel="contact force F [N]", ylabel="felt stiffness F / δ(F) [N/mm]",
           title="reference: geometrically nonlinear against linear (horizontal)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def reference_lines(folder):
    with open(os.path.join(folder, "reference.csv")) as f:
        references = list(csv.DictReader(f))
    lines = ["Reference (uniform P2 mesh of the study's 'Reference size', full static FE):", ""]
    for ref in references:
        frequencies = ", ".join(f"{float(x):.1f}" for x in ref["frequencies_hz"].split(";"))
        lines.append(f"- rho = {ref['patch_radius']}, contact {ref['contact']} (display vertex {ref['vertex']}): "
                     f"{int(ref['n_dofs']):,} DoFs, {float(ref['seconds']):.0f} s, felt compliance "
                     f"{float(ref['felt_compliance_m_per_n']):.4e} m/N; lowest frequencies [Hz]: {frequencies}")
    return lines


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    folder = sys.argv[1]
    rows = read_rows(os.path.join(folder, "study.csv"))
    if not rows:
        print(f"{folder}/study.csv has no rows", file=sys.stderr)
        return 1
    points = points_of(rows)
    plot_error_vs_modes(points, os.path.join(folder, "error_vs_modes.png"))
    plot_error_vs(points, "n_dofs", "DoFs of the studied space", os.path.join(folder, "error_vs_dofs.png"),
                  "graded VOI meshes against uniform meshes")
    plot_error_vs(points, "offline_total_s", "offline time of the studied space [s]",
                  os.path.join(folder, "error_vs_offline_time.png"), "accuracy against offline time")
    plot_pareto(rows, os.path.join(folder, "pareto.png"))
    levels, curves = force_levels(rows), read_force_curves(folder)
    force_section = []
    if levels and curves:
        plot_stiffness_vs_force(curves, os.path.join(folder, "stiffness_vs_force.png"))
        force_section = ["", "## Force: where linear stops being true", ""] + force_answer(folder, points, levels, curves) + \
                        ["", "![stiffness vs force](stiffness_vs_force.png)"]

    sections = [["# Speed/accuracy study", "",
                 "Felt-compliance error: the compliance d^T G d along the study's push direction d at each "
                 "contact, relative to the reference's, the largest over the contacts. Display error: the "
                 "area-weighted l2 error of the modal display field under the contact's unit loads against the "
                 "point's own full FE field. f1 error: the lowest frequency against the reference's. Ticks: "
                 "one HIP pressing on the first contact, admittance, measured by bench-basis-cost (the kernel "
                 "library, run by modal-study on each basis).", ""],
                reference_lines(folder), ["", "## Every point", ""], table(points), ["", "## Modes needed", ""],
                modes_answer(points), ["", "## The static correction", ""], correction_answer(points),
                ["", "## Graded VOI mesh against uniform mesh", ""], graded_answer(points),
                ["", "## P1 against P2", ""], degree_answer(points),
                ["", "## Plots", "", "![error vs modes](error_vs_modes.png)", "![error vs DoFs](error_vs_dofs.png)",
                 "![error vs offline time](error_vs_offline_time.png)", "![Pareto front](pareto.png)"],
                force_section]
    temporary = os.path.join(folder, "study.md.tmp")
    with open(temporary, "w") as f:
        f.write("\n".join(line for section in sections for line in section) + "\n")
    os.replace(temporary, os.path.join(folder, "study.md"))
    print(f"{folder}/study.md and {5 if force_section else 4} plots written")
    return 0


if __name__ == "__main__":
    sys.exit(main())

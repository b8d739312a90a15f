#!/usr/bin/python3
"""Felt force-displacement curves of a `modal-rt run` against the static stiffness of each contact.

    /usr/bin/python3 scripts/plot_force_displacement.py OUTPUT_DIR

Reads OUTPUT_DIR/trace.csv and OUTPUT_DIR/presses.csv (and stats.json for the title, if present) and
writes OUTPUT_DIR/force_displacement.png: one panel per press (the first six), the force pushing into
the part along the contact normal [N] against the displacement of the active vertex (patch average)
into the part along the same normal [mm], and the static stiffness of that contact as a straight
line: full FE at a candidate vertex, else the modal part only (no full-FE reference exists there).
`modal-rt run` calls it at the end. Exit status: 0 written, 1 bad input, 3 matplotlib is missing
(Debian: apt-get install python3-matplotlib).
"""
import csv
import json
import math
import os
import sys

MAX_PANELS = 6


def begin(argv, script, tables):
    """What a plot script of a modal-rt run starts with: from its command line (OUTPUT_DIR), matplotlib's
    pyplot on the Agg backend, the directory and the CSV `tables` read from it; or the exit status after
    a message naming `script` (1: bad usage or input, 3: matplotlib is missing)."""
    if len(argv) != 2:
        print("usage: /usr/bin/python3 scripts/%s OUTPUT_DIR" % script, file=sys.stderr)
        return 1
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("%s: matplotlib is missing (apt-get install python3-matplotlib)" % script, file=sys.stderr)
        return 3
    directory = argv[1]
    try:
        return plt, directory, [read_csv(os.path.join(directory, name)) for name in tables]
    except OSError as e:
        print("%s: %s" % (script, e), file=sys.stderr)
        return 1


def save_figure(fig, directory, name):
    """Written then renamed, as every output of modal-rt run: a reader never sees half a file."""
    path = os.path.join(directory, name)
    fig.savefig(path + ".tmp", format="png", dpi=110)
    os.replace(path + ".tmp", path)


def read_csv(path):
    """Rows of a CSV file with '#' comment lines, as dicts keyed by the header."""
    with open(path, newline="") as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def press_curve(trace, press):
    """Displacement into the part [mm] and force pushing into it [N], per trace row of the press."""
    hip = "hip%s_" % press["hip"]
    n = [float(press[k]) for k in ("nx", "ny", "nz")]
    rest = [float(press[k]) for k in ("rest_x", "rest_y", "rest_z")]
    sign = float(press["force_sign"])
    start, end = float(press["start_s"]), float(press["end_s"])
    displacement, force = [], []
    for row in trace:
        t = float(row["time"])
        if t < start or t > end or row[hip + "contact"] != "1" or row[hip + "vertex"] != press["vertex"]:
            continue
        # Contact point minus the frame's origin and the rest position: the vertex's displacement
        # (the contact's anchor offset is tangential and drops out along n).
        moved = [float(row[hip + c]) - float(row.get("frame_" + a, 0.0)) - r
                 for c, a, r in zip(("cx", "cy", "cz"), ("x", "y", "z"), rest)]
        displacement.append(-1e3 * sum(m * k for m, k in zip(moved, n)))
        force.append(sign * sum(float(row[hip + f]) * k for f, k in zip(("fx", "fy", "fz"), n)))
    return displacement, force


def finite(text):
    value = float(text)
    return value if math.isfinite(value) else None


def draw_press(ax, trace, press):
    displacement, force = press_curve(trace, press)
    ax.plot(displacement, force, "-", color="C0", lw=1.5, marker=".", ms=3, label="felt (this run)")
    if displacement:
        ax.plot(displacement[0], force[0], "o", color="C2", ms=6, label="contact start")
        ax.plot(displacement[-1], force[-1], "x", color="0.3", ms=7, mew=2, label="last sample in contact")

    compliance = finite(press["compliance_m_per_n"])
    felt_displacement = finite(press["felt_displacement_m"])
    reach = max([d for d in displacement if d > 0] + [1e3 * felt_displacement if felt_displacement else 0.0, 1e-6])
    if compliance and compliance > 0:
        k = 1.0 / compliance  # [N/m]
        if press["full_fe"] == "1":
            label = "full-FE static stiffness %.4g N/mm" % (k * 1e-3)
        else:
            label = "modal static stiffness %.4g N/mm\n(modal only, no full-FE reference)" % (k * 1e-3)
        x = [0.0, 1.15 * reach]
        ax.plot(x, [k * 1e-3 * d for d in x], "--", color="C3", lw=1.5, label=label)

    # Several HIPs in contact: the static answer to all their loads together (full FE through the
    # stored cross compliance when every contact is a candidate; within the far field's measured
    # error where it couples a pair), the reference that applies.
    multi = finite(press.get("multi_static_stiffness_n_per_m", "nan") or "nan")
    if multi and multi > 0 and int(press.get("felt_contacts", "1") or 1) > 1:
        note = press.get("multi_note", "")
        if press.get("multi_full_fe") == "1":
            label = "full-FE static, %s contacts' loads together %.4g N/mm" % (press["felt_contacts"], multi * 1e-3)
        elif note.startswith("far-field coupling"):  # a pair coupled by the precompute's far field
            label = "static with the far field, %s contacts' loads together %.4g N/mm\n(%s)" % (
                press["felt_contacts"], multi * 1e-3, note.split(":")[0])
        else:
            label = "static, %s contacts' loads together %.4g N/mm\n(no full-FE reference: %s)" % (
                press["felt_contacts"], multi * 1e-3, press.get("multi_note", ""))
        x = [0.0, 1.15 * reach]
        ax.plot(x, [multi * 1e-3 * d for d in x], ":", color="C4", lw=1.8, label=label)

    felt = finite(press["felt_stiffness_n_per_m"])
    ratio = finite(press["ratio"])
    if felt:
        ax.plot(felt_displacement * 1e3, float(press["felt_force_n"]), "s", color="C1", ms=7,
                label="end of push (%.2f s): felt %.4g N/mm%s" % (
                    float(press["felt_time_s"]), felt * 1e-3, ", ratio %.3f" % ratio if ratio else ""))

    title = "HIP %s \u00b7 space %s \u00b7 vertex %s\nt = %.2f\u2013%.2f s" % (
        press["hip"], press["space_name"], press["vertex"], float(press["start_s"]), float(press["end_s"]))
    if int(press["max_contacts"]) > 1:
        # The dashed reference is the contact alone; the dotted one adds the other HIPs' loads.
        title += " \u00b7 %s HIPs in contact (loads add)" % press["max_contacts"]
    ax.set_title(title, fontsize=10)
    ax.set_xlabel("displacement into the part along the normal [mm]")
    ax.set_ylabel("force along the normal [N]")
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.axvline(0.0, color="0.6", lw=0.6)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=7.5, framealpha=0.85)


def run_title(directory, presses):
    title = "modal-rt run: felt force vs displacement per press"
    try:
        with open(os.path.join(directory, "stats.json")) as f:
            stats = json.load(f)
        title += " (%s, %s, %g Hz)" % (stats["mode"], stats["device"], stats["rate_hz"])
    except (OSError, ValueError, KeyError):
        pass
    if len(presses) > MAX_PANELS:
        title += "\nfirst %d of %d presses (all in presses.csv)" % (MAX_PANELS, len(presses))
    return title


def main(argv):
    started = begin(argv, "plot_force_displacement.py", ["presses.csv", "trace.csv"])
    if isinstance(started, int):
        return started
    plt, directory, (presses, trace) = started
    shown = presses[:MAX_PANELS]
    columns = {0: 1, 1: 1, 2: 2, 4: 2}.get(len(shown), 3)
    rows = max(1, math.ceil(len(shown) / columns))
    fig, axes = plt.subplots(rows, columns, figsize=(5.2 * columns, 4.4 * rows + 0.6), squeeze=False)
    for ax in axes.flat[len(shown):]:
        ax.axis("off")
    for ax, press in zip(axes.flat, shown):
        draw_press(ax, trace, press)
    if not shown:
        axes[0][0].text(0.5, 0.5, "no contact during this run", ha="center", va="center")
    fig.suptitle(run_title(directory, presses), fontsize=11)
    fig.tight_layout()

    save_figure(fig, directory, "force_displacement.png")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

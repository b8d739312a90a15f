#!/usr/bin/python3
"""Stiffness along the path of each slide of a `modal-rt run` (a proxy contact moving over the part).

    /usr/bin/python3 scripts/plot_slide_stiffness.py OUTPUT_DIR

Reads OUTPUT_DIR/slides.csv and OUTPUT_DIR/trace.csv and writes OUTPUT_DIR/slide_stiffness.png: one
panel per slide (the first four), against the distance the proxy has slid [mm]: the static stiffness
of the basis where the proxy is (1 / n^T G n of its blended load, the exact value at a corrected
contact) and the stiffness felt there (normal force over the load point's normal displacement), in
N/mm; below, the normal and the friction (tangential) force [N]. The active space is marked where it
changes. `modal-rt run` calls it at the end of a run that slid. Exit status: 0 written, 1 bad input,
3 matplotlib is missing (Debian: apt-get install python3-matplotlib).
"""
import math
import sys

from plot_force_displacement import begin, save_figure

MAX_PANELS = 4


def slide_path(trace, slide):
    """Per trace row of the slide: distance slid [mm], static and felt stiffness [N/mm], F_n, F_t [N], space."""
    hip = "hip%s_" % slide["hip"]
    start, end = float(slide["start_s"]), float(slide["end_s"])
    rows = {"distance": [], "static": [], "felt": [], "fn": [], "ft": [], "space": []}
    previous, distance = None, 0.0
    for row in trace:
        t = float(row["time"])
        if t < start or t > end or row[hip + "contact"] != "1":
            continue
        point = [float(row[hip + c]) - float(row["frame_" + a]) for c, a in (("cx", "x"), ("cy", "y"), ("cz", "z"))]
        if previous is not None:
            distance += math.dist(point, previous)
        previous = point
        rows["distance"].append(1e3 * distance)
        rows["static"].append(1e-3 * float(row[hip + "static_stiffness"]))
        rows["felt"].append(1e-3 * float(row[hip + "felt_stiffness"]))
        rows["fn"].append(float(row[hip + "fn"]))
        rows["ft"].append(float(row[hip + "ft"]))
        rows["space"].append(row[hip + "space"])
    return rows


def draw_slide(ax, ax_force, trace, slide):
    path = slide_path(trace, slide)
    d = path["distance"]
    ax.plot(d, path["static"], "-", color="C3", lw=1.6, label="static stiffness of the basis at the proxy")
    ax.plot(d, path["felt"], ".", color="C0", ms=2.5, label="felt: normal force / normal displacement")
    finite = [s for s in path["static"] if math.isfinite(s)]
    if finite:
        ax.set_ylim(0.0, 1.3 * max(finite))
    for k in range(1, len(d)):
        if path["space"][k] != path["space"][k - 1]:
            ax.axvline(d[k], color="0.4", ls="--", lw=1)
            ax.text(d[k], 0.97 * ax.get_ylim()[1], " space %s \u2192 %s" % (path["space"][k - 1], path["space"][k]),
                    va="top", fontsize=8)
    ax.set_title("slide %s \u00b7 HIP %s \u00b7 %s \u2192 %s \u00b7 %.2f\u2013%.2f s\n%.1f mm slid, largest force change "
                 "%.3g N per tick, passivity %+.3g J" % (
                     slide["slide"], slide["hip"], slide["space_start_name"], slide["space_end_name"],
                     float(slide["start_s"]), float(slide["end_s"]), 1e3 * float(slide["length_m"]),
                     float(slide["max_force_step_n"]), float(slide["passivity_energy_j"])), fontsize=10)
    ax.set_ylabel("stiffness along the normal [N/mm]")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="lower left", fontsize=7.5, framealpha=0.85)
    ax_force.plot(d, path["fn"], "-", color="C2", lw=1.2, label="normal force F_n")
    ax_force.plot(d, path["ft"], "-", color="C1", lw=1.2, label="friction force |F_t|")
    ax_force.set_xlabel("distance slid by the proxy [mm]")
    ax_force.set_ylabel("force [N]")
    ax_force.grid(True, alpha=0.3)
    ax_force.legend(loc="best", fontsize=7.5, framealpha=0.85)


def main(argv):
    started = begin(argv, "plot_slide_stiffness.py", ["slides.csv", "trace.csv"])
    if isinstance(started, int):
        return started
    plt, directory, (slides, trace) = started
    shown = slides[:MAX_PANELS]
    columns = max(1, len(shown))
    fig, axes = plt.subplots(2, columns, figsize=(6.4 * columns, 7.0), squeeze=False,
                             gridspec_kw={"height_ratios": [2, 1]}, sharex="col")
    for k, slide in enumerate(shown):
        draw_slide(axes[0][k], axes[1][k], trace, slide)
    if not shown:
        axes[0][0].text(0.5, 0.5, "no slide during this run", ha="center", va="center")
    title = "modal-rt run: stiffness along each slide"
    if len(slides) > MAX_PANELS:
        title += " (first %d of %d, all in slides.csv)" % (MAX_PANELS, len(slides))
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    save_figure(fig, directory, "slide_stiffness.png")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

#!/usr/bin/python3
"""Prints the summary of a precompute's report.json (scripts/demo calls it)."""
import json
import sys


# The face a spot lies on, by the axis its outward normal is nearest to (the part modelled z up).
FACES = {"+z": "the top", "-z": "the underside"}


def facing(spot):
    """', on a side (facing +x, normal 0.99, 0.00, 0.10: pressed along -n)'; empty without a normal."""
    if "normal" not in spot:
        return ""
    n = ", ".join(f"{c:.2f}" for c in spot["normal"])
    face = FACES.get(spot["facing"], "a side")
    return f", on {face} (facing {spot['facing']}, normal {n}: pressed along -n)"


def main(path):
    with open(path) as f:
        report = json.load(f)
    print(f"\nscene '{report['scene']}'  (P{report['element_degree']}, display surface "
          f"{report['display_surface']['n_vertices']} vertices)")
    print(f"{'space':10} {'DoFs':>9} {'modes':>5} {'f1 [Hz]':>9} {'f_r [Hz]':>9} {'orth err':>9} "
          f"{'residual':>9} {'cand':>5} {'modal err':>10} {'corr err':>9}")
    for s in report["spaces"]:
        v = s["validation"]
        modal = max((c["contact_rel_error_modal"] for c in v), default=float("nan"))
        corrected = max((c["contact_rel_error_corrected"] for c in v), default=float("nan"))
        print(f"{s['name']:10} {s['n_dofs']:9d} {s['n_modes']:5d} {s['frequencies_hz'][0]:9.2f} "
              f"{s['frequencies_hz'][-1]:9.1f} {s['orthonormality_error']:9.1e} {s['max_relative_residual']:9.1e} "
              f"{s['static_correction']['n_candidates']:5d} {modal:10.2e} {corrected:9.1e}")
    for s in report["spaces"]:
        m = s.get("felt_stiffness")
        if not m:
            continue
        soft = m["softest"][0]
        x = ", ".join(f"{1e3 * c:.1f}" for c in soft["position_m"])
        print(f"felt stiffness, {s['name']} ({m['n_vertices']} vertices): {m['min_n_per_mm']:.1f} / "
              f"{m['median_n_per_mm']:.1f} / {m['max_n_per_mm']:.3g} N/mm (min / median / max); softest at vertex "
              f"{soft['vertex']} ({x}) mm{facing(soft)}; the modes alone: median "
              f"{m['modal_only_ratio_median']:.3f} x as stiff, "
              f"off by > 8 % at {100 * m['modal_only_off_by_more_than_8_percent']:.0f} % of the vertices")
    for s in report["spaces"]:
        far = s.get("far_field")
        if not far:
            continue
        if far["rank"] == 0:
            print(f"far field, {s['name']}: not kept ({far.get('left_out', '')})")
            continue
        def band(b):
            upper = "" if b["to_m"] is None else f"{1e3 * b['to_m']:.0f}"
            return (f"{1e3 * b['from_m']:.0f}-{upper} mm {100 * b['median_error']:.2g} % "
                    f"({100 * b['median_modes_alone']:.2g} %)")
        bands = "; ".join(band(b) for b in far["error_by_distance"])
        pairs = [p for p in s["two_contact_checks"] if p["far"]]
        pressed = (f"; {len(pairs)} far pairs pressed together: worst {100 * max(p['rel_error_corrected'] for p in pairs):.2g} % "
                   f"off the full solve ({100 * max(p['rel_error_without_cross'] for p in pairs):.2g} % with the modes alone)"
                   if pairs else "")
        print(f"far field, {s['name']} (rank {far['rank']}): coupling error median by distance (modes alone): {bands}{pressed}")
    for s in report["spaces"]:
        for p in s["two_contact_checks"]:
            if p.get("named"):
                print(f"exact pair points, {s['name']}: vertices {p['vertices'][0]} and {p['vertices'][1]} "
                      f"({1e3 * p['distance_m']:.1f} mm apart) pressed together: {p['rel_error_corrected']:.2g} off "
                      f"the full solve ({100 * p['rel_error_without_cross']:.2g} % with the modes alone)")
    for s in report["spaces"]:
        for c in s.get("validity", []):
            def forces(node, missing="never"):  # the full solve's missing ones lie above its force limit
                return " / ".join(missing if node[k] is None else f"{node[k]:.3g}"
                                  for k in ("1_percent", "5_percent", "10_percent"))
            stopped = f", stopped at {c['force_reached_n']:.3g} N: {c['stop_reason']}" if c["stop_reason"] else ""
            print(f"validity, {s['name']} vertex {c['vertex']} (up to {c['force_limit_n']:.3g} N{stopped}): "
                  f"1 / 5 / 10 % at {forces(c['validity_force_n'], 'above')} N (full solve); estimates "
                  f"{forces(c['third_order_exact']['validity_force_n'])} N (exact third order), "
                  f"{forces(c['second_order_exact']['validity_force_n'])} N (exact second order)")
    for c in report.get("cross_space", []):
        if c["region"] != c["space"]:
            continue  # the VOI that holds the vertex is the comparison that matters
        print(f"felt compliance at vertex {c['vertex']} ({c['region']}): global space differs from "
              f"'{c['space']}' by {100 * c['global_rel_difference']:.2f} %")
    t = report["timings_s"]
    print("timings [s]: " + ", ".join(f"{k} {v:.1f}" for k, v in t.items()))
    print(f"files: {report['files']['mrt_bytes'] / 1e6:.1f} MB .mrt, {report['files']['h5_bytes'] / 1e6:.1f} MB .h5")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "results/ribbed_panel/report.json")

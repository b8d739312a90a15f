#!/usr/bin/python3
"""Design variants (docs/precompute.md, "Design variants") on a coarse ribbed panel
(ribbed_panel_variants.prm): a thicker rib A (1.8 -> 2.4 mm) and a stiffer material (+30 % Young's
modulus), with the noise floor measured.

- The material variant reuses the base's meshes: the same display surface, the identity rule, and
  its felt-stiffness map is 1.300 x the base's at every vertex (to 1e-9).
- The thick-rib variant is meshed anew (closest-point rule): rib A is stiffer, and the comparison's
  largest differences lie on rib A.
- Each variant's folder holds its own .mrt, .h5, report.json and used_parameters.prm.
- An override of an unknown entry, a value its entry refuses, an entry outside Geometry and
  Material, or one that fails the scene's checks (two rib thicknesses for three ribs), is refused
  before meshing, its message naming the variant, the entry and the value.
- The scene without its 'Variants' subsection, on the same meshes, writes the base's files as the
  scene with variants wrote them: the .mrt byte for byte, report.json but for the timings and the
  comparison, used_parameters.prm but for the 'Variants' subsection, which it does not list."""
import json
import os
import re
import subprocess
import sys

from precompute_run import Checks, binary_and_fresh_workdir, copy_meshes

HERE = os.path.dirname(os.path.abspath(__file__))
SCENE = "ribbed_panel_variants.prm"
RIB_A_Y_MM, RIB_A_THICKNESS_MM, RIB_A_TOP_MM = 50.0, 2.4, 3.0 + 20.0


def scene_text(without_variants=False):
    text = open(os.path.join(HERE, SCENE)).read()
    if without_variants:
        text = re.sub(r"\nsubsection Variants\n.*?\nend\n", "\n", text, flags=re.S)
    return text


def run(binary, folder, text, check=True):
    """modal-precompute on `text` written into `folder`; returns the finished process."""
    os.makedirs(folder, exist_ok=True)
    prm = os.path.join(folder, "scene.prm")
    with open(prm, "w") as f:
        f.write(text)
    done = subprocess.run([binary, prm, "--output-dir", folder, "--quiet"], capture_output=True, text=True)
    if check and done.returncode != 0:
        print(done.stdout[-3000:], done.stderr[-3000:])
        raise SystemExit("modal-precompute failed")
    return done


# What differs between two runs of one scene on the same meshes: times, memory, whether a mesh was made.
RUN_DEPENDENT = re.compile(r"(_s|seconds\w*|max_peak_memory_mb|reused|made_in_child_process)$")


def without_timings(value):
    """report.json without what RUN_DEPENDENT names, at every depth."""
    if isinstance(value, dict):
        return {k: without_timings(v) for k, v in value.items() if not RUN_DEPENDENT.search(k)}
    if isinstance(value, list):
        return [without_timings(v) for v in value]
    return value


def on_rib_a(position_mm):
    """On rib A's walls or top (above the plate, within its thickness of the centre line and a little)."""
    x, y, z = position_mm
    return abs(y - RIB_A_Y_MM) <= RIB_A_THICKNESS_MM / 2 + 0.5 and z >= 3.0 - 1e-6


def check_variant_outputs(expect, folder, name):
    for file in ["coarse_panel.mrt", "coarse_panel.h5", "report.json", "used_parameters.prm"]:
        path = os.path.join(folder, "variants", name, file)
        expect(os.path.isfile(path) and os.path.getsize(path) > 0, f"{name}: variants/{name}/{file} written")
    own = json.load(open(os.path.join(folder, "variants", name, "report.json")))
    expect(own.get("design_variant", {}).get("name") == name, f"{name}: its own report.json names it")
    used = open(os.path.join(folder, "variants", name, "used_parameters.prm")).read()
    expect("subsection Variants" not in used, f"{name}: its used_parameters.prm holds one design (no 'Variants')")


def check_material_variant(expect, variant):
    comparison = variant["comparison"]
    ratio = comparison["ratio"]
    expect(variant["meshes_reused"], "stiffer_abs: the base's meshes reused (the mesh cache)")
    expect(comparison["rule"] == "identity", f"stiffer_abs: identity rule ({comparison['rule']})")
    compared = comparison["all"]["compared_vertices"]
    expect(compared == comparison["base_vertices"],
           f"stiffer_abs: every vertex compared ({compared} of {comparison['base_vertices']})")
    expect(comparison["match_distance_mm"]["max"] == 0.0, "stiffer_abs: match distance 0")
    worst = max(abs(ratio["min"] - 1.3), abs(ratio["max"] - 1.3))
    expect(worst <= 1e-9, f"stiffer_abs: map 1.300 x the base's at every vertex "
                          f"(ratio {ratio['min']:.12f} .. {ratio['max']:.12f})")
    expect(comparison["all"]["difference"] == "stiffer", f"stiffer_abs: 'stiffer' ({comparison['all']['difference']})")


def check_thick_rib_variant(expect, variant):
    comparison = variant["comparison"]
    largest = comparison["largest_differences"]
    expect(not variant["meshes_reused"], "thick_rib_a: meshed anew (its geometry differs)")
    expect(comparison["rule"] == "closest point", f"thick_rib_a: closest-point rule ({comparison['rule']})")
    expect(len(largest) == 10, f"thick_rib_a: the 10 largest differences listed ({len(largest)})")
    on_rib = [d for d in largest if on_rib_a(d["position_mm"])]
    expect(len(on_rib) == len(largest),
           f"thick_rib_a: the largest differences lie on rib A ({len(on_rib)} of {len(largest)}: "
           + ", ".join(f"({d['position_mm'][0]:.1f}, {d['position_mm'][1]:.1f}, {d['position_mm'][2]:.1f})"
                       for d in largest) + " mm)")
    expect(all(d["percent"] > 0 and d["variant_n_per_mm"] > d["base_n_per_mm"] for d in largest),
           "thick_rib_a: rib A stiffer where it differs most "
           f"({min(d['percent'] for d in largest):.1f} .. {max(d['percent'] for d in largest):.1f} %)")
    rib_a = next(r for r in comparison["regions"] if r["name"] == "rib_a")
    expect(largest[0]["beyond_noise"] and rib_a["difference"] == "stiffer",
           f"thick_rib_a: rib A's region 'stiffer' ({rib_a['difference']}: {rib_a['beyond_noise_vertices']} vertices "
           f"beyond its noise floor {rib_a['noise_floor_percent']:.2f} %, the largest {largest[0]['percent']:.1f} %)")


def check_refusals(expect, binary, workdir):
    cases = [("unknown entry", "Geometry/Ribbed panel/Rib thickness = 1.5, 2, 2.4",
              ["variant 'bad'", "'Rib thickness'", "Did you mean 'Rib thicknesses'"]),
             ("refused value", "Material/Young's modulus = -5",
              ["variant 'bad'", "'Material/Young's modulus' = -5", "must be a number > 0", "Pa"]),
             ("not a design entry", "Meshing/Coarse size = 6",
              ["variant 'bad'", "'Meshing/Coarse size = 6'", "'Geometry' or 'Material'"]),
             ("scene check", "Geometry/Ribbed panel/Rib thicknesses = 1.5, 2",
              ["variant 'bad'", "'Geometry/Ribbed panel/Rib thicknesses = 1.5, 2'", "same number of entries"])]
    for what, override, words in cases:
        folder = os.path.join(workdir, "refused_" + what.replace(" ", "_"))
        text = scene_text().replace("set Name       = stiffer_abs", "set Name       = bad").replace(
            "set Override 1 = Material/Young's modulus = 2.99e9", "set Override 1 = " + override)
        done = run(binary, folder, text, check=False)
        message = done.stderr
        expect(done.returncode != 0 and all(w in message for w in words),
               f"refused, {what}: the message names the variant, the entry and the value", message[-800:])
        expect(not any(name.endswith(".msh") for name in os.listdir(folder)), f"refused, {what}: before any meshing")


def check_without_variants(expect, binary, workdir, with_variants):
    """The scene without 'Variants' on the base's meshes: the base's files as the run with variants wrote them."""
    folder = os.path.join(workdir, "without_variants")
    copy_meshes(with_variants, folder)
    run(binary, folder, scene_text(without_variants=True))
    same_mrt = open(os.path.join(folder, "coarse_panel.mrt"), "rb").read() == \
        open(os.path.join(with_variants, "coarse_panel.mrt"), "rb").read()
    expect(same_mrt, "without variants: the same .mrt, byte for byte")
    plain = json.load(open(os.path.join(folder, "report.json")))
    base = json.load(open(os.path.join(with_variants, "report.json")))
    expect("design_variants" not in plain, "without variants: report.json has no 'design_variants'")
    for report in (plain, base):
        report.pop("design_variants", None), report.pop("parameter_file")
    expect(json.dumps(without_timings(plain), sort_keys=True) == json.dumps(without_timings(base), sort_keys=True),
           "without variants: report.json the same but for timings and the comparison")
    used_plain = open(os.path.join(folder, "used_parameters.prm")).read()
    used_base = open(os.path.join(with_variants, "used_parameters.prm")).read()
    expect("subsection Variants" not in used_plain, "without variants: used_parameters.prm lists no 'Variants'")
    stripped = re.sub(r"subsection Variants\n.*?\nend\n\n*", "", used_base, flags=re.S)
    expect(stripped == used_plain, "without variants: used_parameters.prm the same but for 'Variants'")


def main():
    args = binary_and_fresh_workdir()
    expect = Checks()
    check_refusals(expect, args.binary, args.workdir)

    folder = os.path.join(args.workdir, "with_variants")
    run(args.binary, folder, scene_text())
    report = json.load(open(os.path.join(folder, "report.json")))
    design = report.get("design_variants", {})
    variants = {v["name"]: v for v in design.get("variants", [])}
    expect(sorted(variants) == ["stiffer_abs", "thick_rib_a"], f"two variants compared ({sorted(variants)})")
    noise = design.get("noise_floor", {})
    floors = {r["name"]: r["percent"]["p95_abs"] for r in noise.get("comparison", {}).get("regions", [])}
    expect(noise.get("measured") and noise["comparison"]["rule"] == "closest point" and len(floors) == 2,
           "noise floor measured by the closest-point rule, per region (95th pct of |%|): "
           + ", ".join(f"{name} {floor:.2f} %" for name, floor in floors.items()) + f", {noise.get('seconds', 0):.0f} s")
    for name in variants:
        check_variant_outputs(expect, folder, name)
    if "stiffer_abs" in variants:
        check_material_variant(expect, variants["stiffer_abs"])
    if "thick_rib_a" in variants:
        check_thick_rib_variant(expect, variants["thick_rib_a"])
    check_without_variants(expect, args.binary, args.workdir, folder)
    return expect.exit_code()


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/python3
"""The felt compliance under a contact patch converges as the VOI mesh is refined; under a single
vertex (rho = 0) it does not (the displacement under a point load in 3D grows without bound).

A 40 x 40 x 10 mm block clamped at its bottom is pressed in z at the centre of its top face; the VOI
is a ball of radius 6 mm around that point, meshed with 2, 1 and 0.5 mm. For each patch radius the
full static FE compliance u_c,z / F_z is read from report.json (validation at that point), and every
run's corrected contact error must be <= 1e-8 (rho = 0 and rho > 0)."""
import os
import sys

from precompute_run import binary_and_fresh_workdir, run_precompute, test_prm

FINE_SIZES = [2.0, 1.0, 0.5]


def scene(fine_size, patch_radius):
    return test_prm("patch_convergence_block.prm", "block.geo",
                    {"Scenario 1/Fine size": fine_size, "Contact/Patch radius": patch_radius})


def felt_compliance(binary, workdir, fine_size, patch_radius):
    report, _ = run_precompute(binary, os.path.join(workdir, f"h{fine_size}_rho{patch_radius}"),
                               scene(fine_size, patch_radius))
    press = [s for s in report["spaces"] if s["name"] == "press"][0]
    # The static correction is exact for a single-vertex load and for a patch alike.
    corrected = max(c["contact_rel_error_corrected"] for s in report["spaces"] for c in s["validation"])
    assert corrected <= 1e-8, f"h = {fine_size}, rho = {patch_radius}: corrected contact error {corrected}"
    case = [c for c in press["validation"] if c["direction"] == "z"][0]
    return case["full_contact_response_m_per_n"][2]


def main():
    args = binary_and_fresh_workdir()
    ok = True
    last_change = {}
    for rho in [1.5, 0.0]:
        c = [felt_compliance(args.binary, args.workdir, h, rho) for h in FINE_SIZES]
        d1, d2 = abs(c[1] - c[0]), abs(c[2] - c[1])
        print(f"rho = {rho} mm: compliance at h = {FINE_SIZES}: " + ", ".join(f"{x:.6e}" for x in c) +
              f" m/N; differences {d1:.3e}, {d2:.3e} (ratio {d2 / d1:.2f}; change {100 * d2 / c[2]:.2f} %)")
        last_change[rho] = d2 / c[2]
        if rho > 0:
            converges = d2 < 0.5 * d1
            print("  patch load: differences shrink:", converges)
            ok &= converges
        else:
            keeps_growing = c[2] > c[1] > c[0] and d2 > 0.5 * d1
            print("  single-vertex load keeps growing:", keeps_growing)
            ok &= keeps_growing
    settles = last_change[1.5] < 0.25 * last_change[0.0]
    print(f"  last refinement changes the patch compliance by {100 * last_change[1.5]:.2f} %, "
          f"the single-vertex one by {100 * last_change[0.0]:.2f} %: patch settles {settles}")
    ok &= settles
    print("1 passed, 0 failed" if ok else "0 passed, 1 failed")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

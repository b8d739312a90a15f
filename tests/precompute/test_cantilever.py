#!/usr/bin/python3
"""A solid steel cantilever (P2 tets) against Timoshenko beam theory.

Beam: L = 200 mm, square section a = 10 mm, E = 200 GPa, nu = 0.3, rho = 7850 kg/m^3, clamped at
x = 0. Reference values:

* Bending frequencies from Timoshenko's equations
      kappa G A (w'' - theta') + ... :  rho A w_tt = kappa G A (w' - theta)',
                                        rho I theta_tt = E I theta'' + kappa G A (w' - theta),
  with Cowper's shear coefficient for a rectangle kappa = 10 (1 + nu) / (12 + 11 nu), solved here by a
  1D finite-element discretization fine enough (2000 elements, error ~1e-6) to be exact for the test.
  For reference, Euler-Bernoulli gives f_n = (beta_n L)^2 / (2 pi L^2) sqrt(E I / (rho A)) with
  beta_1 L = 1.8751, beta_2 L = 4.6941: 203.9 Hz and 1277.7 Hz.
* Static tip deflection under an end load P: delta = P L^3 / (3 E I) + P L / (kappa G A).

The square section has two equal bending planes, so the modes come in pairs: modes 1-2 are the first
bending frequency, modes 3-4 the second. Both must be within 1 %, and so must the compliance felt at
the centre of the end face (patch radius 4 mm) in y and z.
"""
import json
import math
import os
import subprocess
import sys

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from precompute_run import binary_and_fresh_workdir

E, NU, RHO = 2e11, 0.3, 7850.0
L, A_SIDE = 0.2, 0.01
AREA = A_SIDE**2
I = A_SIDE**4 / 12


def shear_modulus(nu):
    return E / (2 * (1 + nu))


def shear_coefficient(nu):
    """Cowper's kappa for a rectangular section."""
    return 10 * (1 + nu) / (12 + 11 * nu)


def timoshenko_frequencies(nu=NU, n_elements=2000, n_modes=2, clamped=True):
    """Timoshenko beam, clamped at x = 0 or free-free (its two rigid-body modes skipped), linear
    elements with one-point (reduced) shear integration. K and M are banded (4002 DoFs): they are
    assembled sparse and the lowest eigenvalues found by shift-invert Lanczos (ARPACK) about a shift
    below them all, instead of the dense generalized eigh of the same matrices, which was most of
    the test's time (docs/testing.md); the two agree within 8e-7 relative (the dense solve's
    rounding, about eps lambda_max / lambda_1 on this stiff 1D problem; other shifts move the sparse
    one by 2e-8), far inside the 1-3 % the tests ask of the 3D models against it."""
    G, KAPPA = shear_modulus(nu), shear_coefficient(nu)
    h = L / n_elements
    n = 2 * (n_elements + 1)
    bending = E * I / h * np.array([[0, 0, 0, 0], [0, 1, 0, -1], [0, 0, 0, 0], [0, -1, 0, 1]])
    shear_strain = np.array([-1 / h, -0.5, 1 / h, -0.5])  # w' - theta at the element centre
    shear = KAPPA * G * AREA * h * np.outer(shear_strain, shear_strain)
    lumped = np.array([[2, 1], [1, 2]]) * h / 6
    element_mass = np.zeros((4, 4))  # element DoFs w0, theta0, w1, theta1
    element_mass[0::2, 0::2] = RHO * AREA * lumped
    element_mass[1::2, 1::2] = RHO * I * lumped
    dofs = 2 * np.arange(n_elements)[:, None] + np.arange(4)[None, :]
    rows = np.repeat(dofs, 4, axis=1).ravel()
    cols = np.tile(dofs, (1, 4)).ravel()
    K = scipy.sparse.coo_matrix((np.tile((bending + shear).ravel(), n_elements), (rows, cols)), shape=(n, n)).tocsc()
    M = scipy.sparse.coo_matrix((np.tile(element_mass.ravel(), n_elements), (rows, cols)), shape=(n, n)).tocsc()
    free = slice(2, n) if clamped else slice(0, n)  # clamped: w and theta fixed at x = 0
    first = 0 if clamped else 2
    shift = -(2 * math.pi * 10.0) ** 2  # below every eigenvalue (the rigid ones: 0)
    lam = np.sort(scipy.sparse.linalg.eigsh(K[free, free], k=first + n_modes, M=M[free, free], sigma=shift,
                                            which="LM", return_eigenvectors=False))[first:]
    return np.sqrt(lam) / (2 * math.pi)


def tip_compliance(nu=NU):
    return L**3 / (3 * E * I) + L / (shear_coefficient(nu) * shear_modulus(nu) * AREA)


def check(name, value, reference, tolerance):
    error = abs(value - reference) / abs(reference)
    print(f"{name:34s} {value:14.6g}  reference {reference:14.6g}  error {100 * error:6.3f} %")
    return error <= tolerance


def solves_use_the_cores(eigensolver):
    """The triangular solves run on deal.II's thread count: the machine's cores (or
    DEAL_II_NUM_THREADS), at most 8. One process must not be limited to one thread (as it was when
    main() passed 1 to MPI_InitFinalize)."""
    expected = min(os.cpu_count(), 8)  # deal.II counts std::thread::hardware_concurrency()
    if os.environ.get("DEAL_II_NUM_THREADS"):
        expected = min(expected, max(1, int(os.environ["DEAL_II_NUM_THREADS"])))
    threads = eigensolver["solve_threads"]
    print(f"triangular solves on {threads} threads, expected {expected}")
    return threads == expected


def main():
    args = binary_and_fresh_workdir()
    here = os.path.dirname(os.path.abspath(__file__))
    subprocess.run([args.binary, os.path.join(here, "cantilever.prm"), "--output-dir", args.workdir], check=True)
    with open(os.path.join(args.workdir, "report.json")) as f:
        report = json.load(f)
    space = report["spaces"][0]
    f = space["frequencies_hz"]
    f_ref = timoshenko_frequencies()
    ok = True
    ok &= check("first bending (mode 1)", f[0], f_ref[0], 0.01)
    ok &= check("first bending (mode 2)", f[1], f_ref[0], 0.01)
    ok &= check("second bending (mode 3)", f[2], f_ref[1], 0.01)
    ok &= check("second bending (mode 4)", f[3], f_ref[1], 0.01)
    cases = [c for c in space["validation"]]
    assert cases, "no validation case at the end face"
    for c in cases:
        if c["direction"] in ("y", "z"):
            component = "xyz".index(c["direction"])
            ok &= check(f"tip compliance {c['direction']} [m/N]", c["full_contact_response_m_per_n"][component],
                        tip_compliance(), 0.01)
    ok &= solves_use_the_cores(space["eigensolver"])
    print("cantilever:", "PASSED" if ok else "FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

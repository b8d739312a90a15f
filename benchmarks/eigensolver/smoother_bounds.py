#!/usr/bin/python3
"""How well the P2 smoother's upper eigenvalue of D^-1 K is estimated: reads K exported by
modal-precompute (`Output/Export matrices`, binary CSR) and prints the true maximum (ARPACK) beside
the Gershgorin bound, power steps and Lanczos steps (largest Ritz value theta, and theta + the last
off-diagonal beta, what amg_eigensolver.cc's VertexTwoLevel takes). Usage: smoother_bounds.py K.csr"""
import sys

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from scipy_peer import read_csr


def power_estimate(B, steps, rng):
    x = rng.uniform(-1, 1, B.shape[0])
    for _ in range(steps):
        y = B @ x
        estimate = x @ y / (x @ x)
        x = y / np.linalg.norm(y)
    return estimate


def lanczos_estimates(B, steps, rng):
    """theta_max and beta_k of 'steps' plain Lanczos steps (no reorthogonalization, as in the code)."""
    q = rng.uniform(-1, 1, B.shape[0])
    q /= np.linalg.norm(q)
    previous, alpha, beta = np.zeros_like(q), [], []
    for _ in range(steps):
        w = B @ q
        alpha.append(q @ w)
        w -= alpha[-1] * q + (beta[-1] if beta else 0.) * previous
        beta.append(np.linalg.norm(w))
        previous, q = q, w / beta[-1]
    T = np.diag(alpha) + np.diag(beta[:-1], 1) + np.diag(beta[:-1], -1)
    return np.linalg.eigvalsh(T)[-1], beta[-1]


def main():
    K = read_csr(sys.argv[1])
    scale = scipy.sparse.diags(1. / np.sqrt(K.diagonal()))
    B = (scale @ K @ scale).tocsr()  # D^-1/2 K D^-1/2: the spectrum of D^-1 K, symmetric
    true = scipy.sparse.linalg.eigsh(B, k=1, which="LA", tol=1e-8)[0][0]
    gershgorin = (abs(K) @ np.ones(K.shape[0]) / K.diagonal()).max()
    rng = np.random.default_rng(1)
    print(f"{K.shape[0]} rows; lambda_max(D^-1 K) = {true:.4f}")
    print(f"Gershgorin bound      {gershgorin:.4f}  ({gershgorin / true:.3f}x)")
    for steps in (10, 20, 40):
        p = power_estimate(B, steps, rng)
        print(f"{steps:2d} power steps        {p:.4f}  ({p / true:.3f}x; x 1.1: {1.1 * p / true:.3f}x)")
    for steps in (10, 20):
        theta, beta = lanczos_estimates(B, steps, rng)
        print(f"{steps:2d} Lanczos steps      theta {theta / true:.4f}x, theta + beta {(theta + beta) / true:.4f}x")


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""The scipy peer of the eigensolver benchmark: eigsh(K, k, M, sigma=0) (ARPACK + SuperLU) on K and M
exported by modal-precompute (binary CSR, README.md). Prints one line like the SLEPc peer."""
import sys
import time

import numpy as np
import scipy.sparse
import scipy.sparse.linalg


def read_csr(name):
    with open(name, "rb") as f:
        n, nnz = np.fromfile(f, "<i8", 2)
        indptr = np.fromfile(f, "<i8", n + 1)
        indices = np.fromfile(f, "<i4", nnz)
        data = np.fromfile(f, "<f8", nnz)
    return scipy.sparse.csr_matrix((data, indices, indptr), shape=(n, n))


def main():
    K, M = read_csr(sys.argv[1]), read_csr(sys.argv[2])
    nev = int(sys.argv[3])
    tol = float(sys.argv[4]) if len(sys.argv) > 4 else 1e-10
    start = time.perf_counter()
    lam = scipy.sparse.linalg.eigsh(K.tocsc(), k=nev, M=M.tocsc(), sigma=0.0, which="LM", tol=tol,
                                    return_eigenvectors=True)[0]
    seconds = time.perf_counter() - start
    lam = np.sort(lam)
    print(f"scipy n={K.shape[0]} nev={nev} converged={len(lam)} seconds={seconds:.3f} "
          f"lambda_first={lam[0]:.12e} lambda_last={lam[-1]:.12e}")


if __name__ == "__main__":
    main()

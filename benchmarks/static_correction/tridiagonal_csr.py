#!/usr/bin/python3
"""Writes a small SPD matrix (tridiagonal 2, -1) in the exported CSR format, for the smoke test of
bench-static-correction and bench-factorization:  tridiagonal_csr.py OUT.csr [N]"""
import struct
import sys

out, n = sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 300
row_start, columns, values = [0], [], []
for i in range(n):
    for j in (i - 1, i, i + 1):
        if 0 <= j < n:
            columns.append(j)
            values.append(2.0 if i == j else -1.0)
    row_start.append(len(columns))
with open(out, "wb") as f:
    f.write(struct.pack(f"<2q{n + 1}q", n, len(columns), *row_start))
    f.write(struct.pack(f"<{len(columns)}i", *columns))
    f.write(struct.pack(f"<{len(values)}d", *values))

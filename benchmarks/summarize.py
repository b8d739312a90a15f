#!/usr/bin/python3
"""Prints the ratios of one benchmark run (scripts/bench): eigensolver peers against ours per size,
the kernel tick at the goal's case and the display reconstruction against a plain copy."""
import csv
import glob
import os
import sys


def rows(path):
    with open(path) as f:
        return list(csv.reader(line for line in f if not line.startswith("#")))


def eigensolver(path):
    table = rows(path)
    header, data = table[0], [dict(zip(table[0], r)) for r in table[1:]]
    for size in sorted({r["n_dofs"] for r in data}, key=int):
        print(f"eigensolve, {int(size):,} DoFs, 50 modes:")
        for r in (r for r in data if r["n_dofs"] == size):
            print(f"  {float(r['seconds']):8.1f} s  {float(r['ratio_to_ours']):6.2f}x ours  "
                  f"{r['solver']} ({r['ranks']} rank{'s' if r['ranks'] != '1' else ''})")


def kernel(path):
    table = rows(path)
    tick_header = next(r for r in table if r[:2] == ["kind", "scenario"])
    display_header = next(r for r in table if r[:2] == ["kind", "r"])
    ticks = [dict(zip(tick_header, r)) for r in table if r[0] == "tick"]
    print("kernel tick, r = 200, 2 HIPs, corrected (goal: p99.9 <= 5 us):")
    for t in ticks:
        if t["r"] == "200" and t["hips"] == "2" and t["corrected"] == "1":
            print(f"  {t['scenario']:11s} p50 {float(t['p50_ns']) / 1e3:6.2f} us  p99 {float(t['p99_ns']) / 1e3:6.2f} us  "
                  f"p99.9 {float(t['p99.9_ns']) / 1e3:6.2f} us  max {float(t['max_ns']) / 1e3:8.1f} us")
    print("display reconstruction against a memcpy of the same mode bytes (goal: >= 0.8):")
    for d in (dict(zip(display_header, r)) for r in table if r[0] == "display"):
        print(f"  r = {d['r']:>4}, {d['vertices']} vertices: {float(d['reconstruct_GBps']):6.2f} GB/s, "
              f"{float(d['memcpy_time_over_reconstruct_time']):.2f}x the copy's speed")


def main():
    folder = sys.argv[1]
    for pattern, report in (("eigensolver*.csv", eigensolver), ("kernel_tick*.csv", kernel)):
        paths = sorted(glob.glob(os.path.join(folder, pattern)))
        for path in paths:
            report(path)
        if not paths:
            print(f"{os.path.join(folder, pattern)}: not found")
    return 0


if __name__ == "__main__":
    sys.exit(main())

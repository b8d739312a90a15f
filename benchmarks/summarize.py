#!/usr/bin/python3
"""Prints the ratios of one benchmark run (scripts/bench): eigensolver peers against ours per size,
the kernel tick at the goal's case, the display reconstruction against a plain copy and OpenBLAS,
the static correction's cost per candidate by block size, and the haptic loop's jitter."""
import csv
import glob
import os
import sys


def rows(path):
    with open(path) as f:
        return list(csv.reader(line for line in f if not line.startswith("#")))


def eigensolver(path):
    data = records(path)
    for size in sorted({r["n_dofs"] for r in data if r["n_dofs"]}, key=int):
        print(f"eigensolve, {int(size):,} DoFs, 50 modes:")
        for r in (r for r in data if r["n_dofs"] == size):
            ranks = f"{r['ranks']} rank{'s' if r['ranks'] != '1' else ''}"
            if not r.get("seconds"):
                print(f"  {'-':>8}    {'-':>6}       {r['solver']} ({ranks}): {r.get('note', '')}")
                continue
            spread = f" [{float(r['seconds_min']):.1f}-{float(r['seconds_max']):.1f}]" if r.get("seconds_min") else ""
            memory = f", peak {float(r['peak_rss_mb_per_process']) / 1024:.1f} GB" if r.get("peak_rss_mb_per_process") else ""
            print(f"  {float(r['seconds']):8.1f} s  {float(r['ratio_to_ours']):6.2f}x ours  "
                  f"{r['solver']} ({ranks}){spread}{memory}")
    for r in data:
        if r["solver"].startswith("machine:"):
            print(f"  {r['solver']}: {float(r['rate']):.1f} {r['rate_unit']}")


def records(path):
    """The rows of a CSV with one header, as dicts (comment lines skipped)."""
    table = rows(path)
    return [dict(zip(table[0], r)) for r in table[1:]]


def kernel(path):
    table = rows(path)
    tick_header = next(r for r in table if r[:2] == ["kind", "scenario"])
    ticks = [dict(zip(tick_header, r)) for r in table if r[0] == "tick"]
    print("kernel tick, r = 200, 2 HIPs, corrected (goal: p99.9 <= 5 us):")
    for t in ticks:
        if t["r"] == "200" and t["hips"] == "2" and t["corrected"] == "1":
            print(f"  {t['scenario']:12s} p50 {float(t['p50_ns']) / 1e3:6.2f} us  p99 {float(t['p99_ns']) / 1e3:6.2f} us  "
                  f"p99.9 {float(t['p99.9_ns']) / 1e3:6.2f} us  max {float(t['max_ns']) / 1e3:8.1f} us")
    sliding = {t["scenario"]: t for t in ticks if t["r"] == "200" and t["hips"] == "1"
               and t["scenario"].startswith(("fixed", "slide", "machine"))}
    if sliding:
        print("sliding contact, r = 200, 1 HIP (targets: slide p50 <= 2x fixed, p99.9 <= 5 us; 'machine' is constant "
              "work as long as the fixed tick, timed in the same loop: the tail the machine alone adds):")
        for name, t in sliding.items():
            print(f"  {name:20s} p50 {float(t['p50_ns']) / 1e3:6.2f} us  p99 {float(t['p99_ns']) / 1e3:6.2f} us  "
                  f"p99.9 {float(t['p99.9_ns']) / 1e3:6.2f} us  over 5 us {t.get('over_5us_per_mille', '?')} per mille")


def display(path):
    print("display reconstruction: kernel GB/s, and each method's time over the kernel's (memcpy: goal >= 0.8, "
          "OpenBLAS gemv: goal >= 1.0; int16: the 16-bit storage study), median [min, max] of interleaved repetitions:")
    data = records(path)
    for k in (d for d in data if d["method"] == "kernel"):
        case = [d for d in data if (d["precision"], d["r"], d["vertices"]) == (k["precision"], k["r"], k["vertices"])]
        ratios = "  ".join(f"{d['method']} {float(d['method_time_over_kernel_time_median']):.2f}x "
                           f"[{float(d['method_time_over_kernel_time_min']):.2f}, {float(d['method_time_over_kernel_time_max']):.2f}]"
                           + (f" (error {float(d['max_diff_to_kernel_rel']):.0e} of |u|max)" if d["method"].startswith("int16") else "")
                           for d in case if d["method"] != "kernel")
        print(f"  {k['precision']} r = {k['r']:>3}, {int(k['vertices']):>7,} vertices: {float(k['GBps_at_median']):6.2f} GB/s  {ratios}")


def static_correction(path):
    print("static correction solves, ms per candidate (3 loads), median [min, max]:")
    for d in records(path):
        print(f"  {int(d['n_dofs']):>8,} DoFs, {d['rhs_per_solve']:>2} right-hand sides per solve: "
              f"{float(d['ms_per_candidate_median']):8.2f} ms [{float(d['ms_per_candidate_min']):.2f}, "
              f"{float(d['ms_per_candidate_max']):.2f}], {float(d['one_by_one_over_blocked_median']):.2f}x faster than one by one")


def haptic_jitter(path):
    print("haptic loop (modal-rt run, display thread at 60 Hz): period jitter and overruns:")
    for d in records(path):
        print(f"  {float(d['rate_hz']):5.0f} Hz, {float(d['duration_s']):.0f} s: jitter p50 {float(d['jitter_p50_us']):.1f} "
              f"p99 {float(d['jitter_p99_us']):.1f} p99.9 {float(d['jitter_p99_9_us']):.1f} max {float(d['jitter_max_us']):.1f} us, "
              f"{d['overruns']} overruns of {d['ticks']} ticks")


def main():
    folder = sys.argv[1]
    for pattern, report in (("eigensolver*.csv", eigensolver), ("kernel_tick*.csv", kernel), ("display*.csv", display),
                            ("static_correction*.csv", static_correction), ("haptic_jitter*.csv", haptic_jitter)):
        paths = sorted(glob.glob(os.path.join(folder, pattern)))
        for path in paths:
            report(path)
        if not paths:
            print(f"{os.path.join(folder, pattern)}: not found")
    return 0


if __name__ == "__main__":
    sys.exit(main())

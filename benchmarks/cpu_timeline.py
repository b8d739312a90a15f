#!/usr/bin/env python3
"""Where a run leaves a core idle: runs a command (e.g. modal-precompute on the default scene),
samples its CPU time (user + system, all threads) every 0.1 s from /proc, and prints per window
the cores it used with the log lines it wrote in that window; then the idle core-seconds over
the run (cores x wall - CPU time). Usage:

  benchmarks/cpu_timeline.py [--window 0.5] [--cores 2] -- COMMAND [ARGS ...]
  e.g. benchmarks/cpu_timeline.py -- build/bin/modal-precompute parameters/ribbed_panel.prm --output-dir /tmp/t

OpenBLAS's workers spin for a while after their last call, so CPU time is an upper bound of the
work done; an idle window is idle for certain.
"""
import argparse
import os
import subprocess
import sys
import threading
import time


def sample(command, period):
    """Runs command; returns (samples [(t, cpu_s)], log lines [(t, text)], exit code)."""
    start = time.time()
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1)
    lines = []

    def read_log():
        for line in process.stdout:
            lines.append((time.time() - start, line.rstrip()))

    reader = threading.Thread(target=read_log)
    reader.start()
    ticks_per_second = os.sysconf("SC_CLK_TCK")
    samples = []
    while process.poll() is None:
        try:
            fields = open(f"/proc/{process.pid}/stat").read().rsplit(")", 1)[1].split()
            # utime and stime are fields 14 and 15 of stat, 12 and 13 after the command's name.
            samples.append((time.time() - start, (int(fields[11]) + int(fields[12])) / ticks_per_second))
        except (FileNotFoundError, ProcessLookupError, IndexError):
            pass
        time.sleep(period)
    reader.join()
    return samples, lines, process.returncode


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--window", type=float, default=0.5, help="seconds per printed line")
    parser.add_argument("--cores", type=int, default=os.cpu_count(), help="cores the run may use")
    parser.add_argument("command", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not command:
        parser.error("no command given (put it after --)")
    samples, lines, code = sample(command, 0.1)
    if len(samples) < 2:
        sys.exit(f"cpu_timeline: the command ended before two samples (exit code {code})")
    next_line, first = 0, 0
    while first + 1 < len(samples):
        last = first
        while last + 1 < len(samples) and samples[last][0] - samples[first][0] < args.window:
            last += 1
        wall, cpu = samples[last][0] - samples[first][0], samples[last][1] - samples[first][1]
        texts = []
        while next_line < len(lines) and lines[next_line][0] <= samples[last][0]:
            texts.append(lines[next_line][1][:100])
            next_line += 1
        print(f"{samples[first][0]:6.1f} s  {cpu / wall if wall > 0 else 0:4.2f} cores  {' | '.join(texts)}")
        first = last
    wall, cpu = samples[-1][0], samples[-1][1]
    print(f"wall {wall:.1f} s, CPU {cpu:.1f} s, idle {max(0.0, args.cores * wall - cpu):.1f} core-seconds "
          f"of {args.cores * wall:.1f}; exit code {code}")
    sys.exit(code)


if __name__ == "__main__":
    main()

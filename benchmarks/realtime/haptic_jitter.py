#!/usr/bin/python3
"""Haptic loop jitter of `modal-rt run` while its display thread reconstructs the surface at 60 Hz:
the default scene's session (presses, switches of modal space, two hands, the part carried)
repeated back to back for the whole duration, at each rate, the rates interleaved over the
repetitions. One CSV row per run, from its stats.json: period jitter (|start-to-start period -
nominal period|) p50/p99/p99.9/max, tick latency, overruns, missed periods, display reconstructions.

  haptic_jitter.py --build build --basis results/ribbed_panel/ribbed_panel.mrt \
      --out benchmarks/results/<label>/haptic_jitter.csv [--duration 60] [--rates 1000,4000] [--repetitions 1]
"""
import argparse
import csv
import json
import os
import subprocess
import sys

TOP = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def looped_session(source, duration, path):
    """Writes `source` repeated back to back until `duration` s (its `end` rows dropped, a final `end`)."""
    rows, length = [], 0.0
    for line in open(source):
        line = line.split("#", 1)[0].strip()
        if not line or line.startswith("time,"):
            continue
        fields = line.split(",")
        length = max(length, float(fields[0]))
        if fields[2] != "end":
            rows.append(fields)
    with open(path, "w") as out:
        out.write(f"# {source} repeated back to back for {duration} s (benchmarks/realtime/haptic_jitter.py)\n")
        out.write("time,hip,event,x,y,z\n")
        start = 0.0
        while start < duration:
            for fields in rows:
                if start + float(fields[0]) < duration:
                    out.write(",".join([f"{start + float(fields[0]):.3f}"] + fields[1:]) + "\n")
            start += length
        out.write(f"{duration:.3f},-,end\n")


def run(build, basis, session, rate, duration, folder):
    os.makedirs(folder, exist_ok=True)
    subprocess.run([os.path.join(build, "bin", "modal-rt"), "run", "--basis", basis, "--session", session,
                    "--output-dir", folder, "--rate", str(rate), "--duration", str(duration),
                    "--frame-rate", "0", "--no-plot", "--quiet"], check=True)
    return json.load(open(os.path.join(folder, "stats.json")))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", default=os.path.join(TOP, "build"))
    parser.add_argument("--basis", default=os.path.join(TOP, "results", "ribbed_panel", "ribbed_panel.mrt"))
    parser.add_argument("--session", default=os.path.join(TOP, "parameters", "ribbed_panel_session.csv"))
    parser.add_argument("--out", required=True)
    parser.add_argument("--duration", type=float, default=60.0, help="seconds per run")
    parser.add_argument("--rates", default="1000,4000", help="haptic rates [Hz]")
    parser.add_argument("--repetitions", type=int, default=1)
    parser.add_argument("--work", default="/tmp/modal-haptics-bench-jitter")
    args = parser.parse_args()
    if not os.path.exists(args.basis):
        sys.exit(f"haptic_jitter.py: {args.basis} not found: precompute the default scene first "
                 f"(build/bin/modal-precompute parameters/ribbed_panel.prm, or scripts/demo)")
    os.makedirs(args.work, exist_ok=True)
    session = os.path.join(args.work, "session.csv")
    looped_session(args.session, args.duration, session)
    rates = [float(r) for r in args.rates.split(",")]
    rows = []
    for k in range(args.repetitions):
        for j in range(len(rates)):
            rate = rates[(j + k) % len(rates)]  # rotating order: the machine's load hits every rate alike
            s = run(args.build, args.basis, session, rate, args.duration, os.path.join(args.work, f"{rate:g}_{k}"))
            jitter = {k: round(v, 2) for k, v in s["period_jitter_us"].items()}
            latency = {k: round(v, 2) for k, v in s["tick_latency_us"].items()}
            rows.append(dict(rate_hz=rate, repetition=k, duration_s=args.duration, ticks=s["ticks"],
                             realtime_priority=int(s["realtime_priority"]),
                             jitter_p50_us=jitter["p50"], jitter_p99_us=jitter["p99"], jitter_p99_9_us=jitter["p99_9"],
                             jitter_max_us=jitter["max"], latency_p50_us=latency["p50"], latency_p99_us=latency["p99"],
                             latency_p99_9_us=latency["p99_9"], latency_max_us=latency["max"], overruns=s["overruns"],
                             missed_periods=s["missed_periods"], switches=s["switches"],
                             display_reconstructions=s["display"]["reconstructions"],
                             display_max_ms=s["display"]["max_reconstruct_ms"]))
            r = rows[-1]
            print(f"  {rate:g} Hz, {args.duration:g} s: jitter p50 {r['jitter_p50_us']:.1f} p99 {r['jitter_p99_us']:.1f} "
                  f"p99.9 {r['jitter_p99_9_us']:.1f} max {r['jitter_max_us']:.1f} us, {r['overruns']} overruns, "
                  f"{r['display_reconstructions']} display reconstructions", flush=True)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w", newline="") as f:
        f.write(f"# haptic_jitter.py: modal-rt run on {os.path.basename(args.basis)}, {os.path.relpath(args.session, TOP)} looped, "
                f"display thread at 60 Hz\n")
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        writer.writerows(rows)
    print(f"written {args.out}")


if __name__ == "__main__":
    sys.exit(main())

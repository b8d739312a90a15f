#!/usr/bin/env bash
# The default scene end to end (meshing included, fresh output folders) with two modal-precompute
# binaries, alternately in one run on one machine: before/after figures that carry over only as
# ratios (docs/performance.md). Usage:
#   benchmarks/default_scene_before_after.sh BEFORE_BINARY BEFORE_PRM AFTER_BINARY AFTER_PRM [PAIRS]
# e.g. a build of an earlier commit with its own parameters/ribbed_panel.prm (git show REV:parameters/ribbed_panel.prm).
set -euo pipefail
[ $# -ge 4 ] || { sed -n 2,6p "$0"; exit 2; }
work=$(mktemp -d)
for pair in $(seq 1 "${5:-1}"); do
  for side in before after; do
    if [ $side = before ]; then binary=$1 prm=$2; else binary=$3 prm=$4; fi
    start=$(date +%s.%N)
    OMP_NUM_THREADS=2 "$binary" "$prm" --output-dir "$work/$side-$pair" --quiet > "$work/$side-$pair.log" 2>&1
    end=$(date +%s.%N)
    /usr/bin/python3 - "$work/$side-$pair/report.json" "$side" "$pair" "$start" "$end" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
t = r["timings_s"]
print(f"{sys.argv[2]} {sys.argv[3]}: wall {float(sys.argv[5]) - float(sys.argv[4]):.1f} s, total {t['total']:.1f} s, "
      f"static_correction {t.get('static_correction', 0):.1f} s, eigensolve {t['eigensolve']:.1f} s, "
      f".mrt {r['files']['mrt_bytes'] / 1e6:.1f} MB, .h5 {r['files']['h5_bytes'] / 1e6:.1f} MB")
PY
  done
done
rm -rf "$work"

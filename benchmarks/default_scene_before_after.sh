#!/usr/bin/env bash
# The default scene end to end (meshing included, fresh output folders) with two or more
# modal-precompute binaries, alternately in one run on one machine: before/after figures that carry
# over only as ratios (docs/performance.md). Usage:
#   benchmarks/default_scene_before_after.sh BINARY_1 PRM_1 BINARY_2 PRM_2 [BINARY_3 PRM_3 ...] [ROUNDS]
# e.g. a build of an earlier commit with its own parameters/ribbed_panel.prm (git show REV:parameters/ribbed_panel.prm).
# Each line names the binary by its position (1, 2, ...) and the round.
set -euo pipefail
[ $# -ge 4 ] || { sed -n 2,7p "$0"; exit 2; }
rounds=1
if [ $(( $# % 2 )) -eq 1 ]; then rounds=${!#}; set -- "${@:1:$#-1}"; fi
binaries=() prms=()
while [ $# -gt 0 ]; do binaries+=("$1"); prms+=("$2"); shift 2; done
work=$(mktemp -d)
for round in $(seq 1 "$rounds"); do
  for k in "${!binaries[@]}"; do
    label="binary $((k + 1))"
    start=$(date +%s.%N)
    OMP_NUM_THREADS=2 "${binaries[$k]}" "${prms[$k]}" --output-dir "$work/$k-$round" --quiet > "$work/$k-$round.log" 2>&1
    end=$(date +%s.%N)
    /usr/bin/python3 - "$work/$k-$round/report.json" "$label" "$round" "$start" "$end" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
t = r["timings_s"]
print(f"{sys.argv[2]}, round {sys.argv[3]}: wall {float(sys.argv[5]) - float(sys.argv[4]):.1f} s, total {t['total']:.1f} s, "
      f"meshing {t.get('meshing', 0):.1f} s, assembly {t.get('assembly', 0):.1f} s, static_correction {t.get('static_correction', 0):.1f} s, "
      f"eigensolve {t['eigensolve']:.1f} s, validity_estimate {t.get('validity_estimate', 0):.1f} s, validity {t.get('validity', 0):.1f} s, "
      f"far_field {t.get('far_field', 0):.1f} s, vtu_output {t.get('vtu_output', 0):.1f} s, "
      f"BLAS kernels {r['processes'].get('blas_kernels', '?')}, "
      f".mrt {r['files']['mrt_bytes'] / 1e6:.1f} MB, .h5 {r['files']['h5_bytes'] / 1e6:.1f} MB", flush=True)
PY
  done
done
rm -rf "$work"

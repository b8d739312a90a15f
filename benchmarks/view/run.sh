#!/bin/sh
# The view's benchmark (benchmarks/view/README.md): the default scene and a 100k-vertex synthetic
# plate, each with and without a headless chromium attached. Writes results/view.csv and the README's
# screenshot of the default scene.
# Usage: benchmarks/view/run.sh [BUILD_DIR (build)] [DEFAULT_MRT (results/ribbed_panel/ribbed_panel.mrt)]
set -eu
here=$(cd "$(dirname "$0")" && pwd)
build=${1:-build}
panel=${2:-results/ribbed_panel/ribbed_panel.mrt}
out="$here/results"
mkdir -p "$out" "$build/benchmarks/view"
rm -f "$out/view.csv"
# Default scene: press vertex 618, a candidate of the rib_a space.
node "$here/bench_view.mjs" --modal-rt "$build/bin/modal-rt" --basis "$panel" --vertex 618 --seconds 10 \
  --label ribbed_panel --csv "$out/view.csv" --screenshot "$here/../../docs/images/view_ribbed_panel.png"
# 100,489 display vertices (317 x 317), 10 modes per space (the default scene's r), float32 modes.
"$build/bin/make_view_fixture" plate "$build/benchmarks/view/plate_100k.mrt" 317 317 10
node "$here/bench_view.mjs" --modal-rt "$build/bin/modal-rt" --basis "$build/benchmarks/view/plate_100k.mrt" \
  --vertex $((158 * 317 + 158)) --seconds 10 --label plate_100k_r10 --csv "$out/view.csv"
# modal-rt run on the default scene's session, without and with --view and a browser watching.
rm -f "$out/run_view.csv"
node "$here/bench_run_view.mjs" --modal-rt "$build/bin/modal-rt" --basis "$panel" \
  --session "$here/../../parameters/ribbed_panel_session.csv" --work "$build/benchmarks/view" --label ribbed_panel \
  --csv "$out/run_view.csv"

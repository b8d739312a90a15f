#!/bin/sh
# ctest view.browser: runs test_view_browser.mjs in Debian's chromium. Without chromium, node or
# playwright-core (scripts/setup installs them) it skips with a message (exit 77), except in CI
# (CI=true), where it must run and therefore fails.
# Usage: run_browser_test.sh MODAL_RT FIXTURE_MAKER WORK_DIR [SCRIPT (test_view_browser.mjs)]
set -u
modal_rt=$1 maker=$2 work=$3 script=${4:-test_view_browser.mjs}
here=$(cd "$(dirname "$0")" && pwd)
missing=""
command -v node >/dev/null 2>&1 || missing="node"
[ -x "${CHROMIUM:-/usr/bin/chromium}" ] || missing="$missing chromium"
[ -d "$here/../../view/web/node_modules/playwright-core" ] || missing="$missing playwright-core (npm ci in view/web)"
if [ -n "$missing" ]; then
  if [ "${CI:-}" = "true" ]; then
    echo "view.browser: missing $missing, and CI=true: the browser test must run in CI (scripts/setup installs them)" >&2
    exit 1
  fi
  echo "view.browser: SKIPPED: missing $missing (scripts/setup installs them)"
  exit 77
fi
mkdir -p "$work" && "$maker" lattice "$work/view_lattice.mrt" || exit 1
exec node "$here/$script" --modal-rt "$modal_rt" --basis "$work/view_lattice.mrt" \
  --screenshot "$work/view_browser_test.png" --work "$work" --maker "$maker"

#!/usr/bin/env bash
# Rewrites the golden replay's expected output from the committed recording. Run it only when a
# change of the model, the filter or the pipeline is meant to change the estimates, and say so
# in the commit (the diff of hp1.expected.csv is the change's effect on 149 cycles).
# Usage: tests/golden/regenerate.sh [BUILD_DIR]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build=${1:-$here/../../build}
"$build/daemon/replay/hvac-twin-replay" --config "$here/heat-pump.json" \
  --out "$here/hp1.expected.csv" "$here/hp1.00000001.htrec"

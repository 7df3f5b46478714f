#!/usr/bin/env bash
# The live demo, all on this machine: hvac-twin-sim serves a simulated zone over Modbus TCP on
# 127.0.0.1:15020, hvac-twind estimates it (one model minute per wall second) and publishes over
# DDS on the loopback interface, and hvac-twin-echo prints what a dashboard would receive.
# Usage: daemon/run-demo.sh [BUILD_DIR] [SECONDS]   (default: build, until Ctrl-C)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$here/build}" && pwd)
seconds=${2:-0}
config="$here/config/demo.json"
logs="$build/demo"
mkdir -p "$logs"
cd "$logs"  # the demo's state directory is relative: it lands here

pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
}
trap cleanup EXIT
trap 'exit 0' INT TERM

"$build/tests/simulator/hvac-twin-sim" --config "$config" --truth-csv "$logs/truth.csv" \
  >"$logs/sim.log" 2>&1 &
pids+=($!)
sleep 0.5
"$build/daemon/runtime/hvac-twind" --config "$config" 2> >(sed -u 's/^/[hvac-twind] /' >&2) &
pids+=($!)

echo "hvac-twin demo: simulated zone on Modbus 127.0.0.1:15020, DDS domain 0 on lo."
echo "Each line is a DDS sample: virtual sensors (value ± 1 sigma), health. Ctrl-C stops."
echo "Logs and the simulated truth: $logs"
echo
echo_args=(--domain 0 --format text --topics virtual_sensor,estimator_health)
if [ "$seconds" != 0 ]; then echo_args+=(--duration "$seconds"); fi
"$build/io/dds/hvac-twin-echo" "${echo_args[@]}"

#!/usr/bin/env bash
# The live demo, all on this machine: hvac-twin-sim simulates an R32 split heat pump cooling a
# zone through a summer day (its outdoor coil 7 % fouled) and serves its sensor points over
# Modbus TCP on 127.0.0.1:15021; hvac-twind estimates it in real time and publishes over DDS on
# the loopback interface; hvac-twin-web serves the live dashboard on http://127.0.0.1:15080/
# (HVAC_TWIN_WEB_PORT to change it; 127.0.0.1 only); hvac-twin-echo prints the samples.
# Usage: daemon/run-demo.sh [BUILD_DIR] [SECONDS] [CONFIG]
#   default: build, until Ctrl-C, config/demo-heat-pump.json (config/demo.json: the zone model)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$here/build}" && pwd)
seconds=${2:-0}
config=$(cd "$(dirname "${3:-$here/config/demo-heat-pump.json}")" && pwd)/$(basename "${3:-demo-heat-pump.json}")
logs="$build/demo"
mkdir -p "$logs"
cd "$logs"  # the demo's state directory is relative: it lands here

# The simulated plant keeps its place across runs of the demo, as the daemon's checkpoint does
# (demo-state/): a restarted demo is a restarted daemon on a plant that stood still meanwhile,
# not one resumed against a plant that started its day over. Remove $logs to start both over.
sim_args=(--config "$config" --truth-csv "$logs/truth.csv" --state "$logs/plant.state")
shown='.'  # every line
if grep -q '"heat_pump_r32"' "$config"; then
  sim_args+=(--set cond_ua_air=700)  # the truth's outdoor coil is 7 % fouled
  shown=' (condenser_outlet_pressure|valve_inlet_enthalpy|superheat|subcooling|cooling_capacity'
  shown+="|compressor_power|cop|charge|leak_rate|outdoor_coil_fouling) | health | leak "
fi

pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
}
trap cleanup EXIT
trap 'exit 0' INT TERM

"$build/tests/simulator/hvac-twin-sim" "${sim_args[@]}" >"$logs/sim.log" 2>&1 &
pids+=($!)
for _ in $(seq 100); do  # serving, or stopped with the reason in its log
  grep -q "Modbus TCP" "$logs/sim.log" && break
  if ! kill -0 "${pids[0]}" 2>/dev/null; then
    echo "hvac-twin demo: the plant simulator stopped:" >&2
    cat "$logs/sim.log" >&2
    exit 1
  fi
  sleep 0.1
done
# Ctrl-C reaches every process of the demo; the daemon's log filter ignores it and ends when the
# daemon, shutting down cleanly (its last checkpoint saved), closes its stderr.
"$build/daemon/runtime/hvac-twind" --config "$config" \
  2> >(trap '' INT TERM; exec sed -u 's/^/[hvac-twind] /' >&2) &
pids+=($!)

web_port=${HVAC_TWIN_WEB_PORT:-15080}
"$build/io/web/hvac-twin-web" --domain 0 --listen "127.0.0.1:$web_port" 2>"$logs/web.log" &
pids+=($!)
for _ in $(seq 50); do grep -q "serving" "$logs/web.log" && break; sleep 0.1; done

echo "hvac-twin demo: $(basename "$config"), simulated plant on Modbus 127.0.0.1, DDS domain 0 on lo."
if grep -q "serving" "$logs/web.log"; then
  echo "Dashboard: http://127.0.0.1:$web_port/ (open it in a browser on this machine)"
else
  echo "Dashboard: not started: $(tail -n 1 "$logs/web.log") (HVAC_TWIN_WEB_PORT=N picks another port)"
fi
echo "Each line is a DDS sample: virtual sensors (value ± 1 sigma), health, leak diagnosis. Ctrl-C stops."
echo "Logs and the simulated truth: $logs"
echo
echo_args=(--domain 0 --format text --topics virtual_sensor,estimator_health,leak_diagnostic)
if [ "$seconds" != 0 ]; then echo_args+=(--duration "$seconds"); fi
"$build/io/dds/hvac-twin-echo" "${echo_args[@]}" | grep --line-buffered -E "$shown"

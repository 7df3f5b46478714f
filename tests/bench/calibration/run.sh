#!/usr/bin/env bash
# The calibration's evidence (README "Calibration"): a truth whose factors differ from the
# nominal model, with the closures the model does not share (Smith void fraction, other two-phase
# heat transfer and friction), is commissioned (six operating points held 45 min each, the charge
# known), calibrated, and then run on an ordinary day; the daemon's pipeline replays the day with
# the nominal and with the calibrated parameters, and both are compared with the truth.
# Usage: tests/bench/calibration/run.sh [BUILD_DIR] [WORK_DIR]   (about 15 min: two replays)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build=$(cd "${1:-$here/../../../build}" && pwd)
work=${2:-$(mktemp -d)}
mkdir -p "$work" && cd "$work"
config=$here/../../../config/demo-heat-pump.json
truth=(--set fouling=0.85 --set evap_ua_factor=1.12 --set comp_flow_factor=0.95
  --set valve_factor=0.9 --set comp_efficiency_factor=1.06 --step 2)
fit=fouling,evap_ua_factor,comp_flow_factor,void_exponent,cond_htc_factor,evap_htc_factor
fit=$fit,valve_factor,comp_efficiency_factor
"$build/tests/simulator/hvac-twin-sim" --config "$config" --commissioning "${truth[@]}" \
  --write-points commissioning.csv 6
"$build/daemon/calibration/hvac-twin-calibrate" --config "$config" --charge 0.5 --fit "$fit" \
  --out hp1.calibration.json commissioning.csv
"$build/tests/simulator/hvac-twin-sim" --config "$config" --seed 3 "${truth[@]}" \
  --truth-csv day.truth.csv --write-points day.csv 3
python3 - "$config" <<'PY'
import json, sys
c = json.load(open(sys.argv[1]))
json.dump(c, open('nominal.json', 'w'), indent=1)
c['units'][0]['calibration'] = 'hp1.calibration.json'
json.dump(c, open('calibrated.json', 'w'), indent=1)
PY
"$build/daemon/replay/hvac-twin-replay" --config nominal.json --out nominal.csv day.csv &
"$build/daemon/replay/hvac-twin-replay" --config calibrated.json --out calibrated.csv day.csv
wait
echo "after the first 30 min; bias and RMS error against the truth, z = RMS of error / sigma"
python3 "$here/compare_truth.py" day.truth.csv 1800 nominal.csv calibrated.csv
echo "work directory: $work"

#!/usr/bin/env python3
"""The filter's and the smoother's virtual sensors against the simulator's truth, per output:
RMS error, mean sigma and mean |error|/sigma. The figures in the README's "Recording and replay".

  hvac-twin-replay --config tests/golden/heat-pump.json --out filter.csv \\
      --smooth smoothed.csv tests/golden/hp1.00000001.htrec
  tests/golden/compare_smoother.py tests/golden/truth.csv filter.csv smoothed.csv

truth.csv: the simulator's outputs (hvac-twin-sim --truth-csv) during the golden recording, the
truth row at or before each cycle's time."""
import csv, sys, bisect, math
truth = list(csv.DictReader(open(sys.argv[1])))
f = list(csv.DictReader(open(sys.argv[2])))
s = list(csv.DictReader(open(sys.argv[3])))
tt = [int(r['wall_time_ns']) for r in truth]
names = ['charge','condenser_heat_flow','evaporator_heat_flow','cop','condenser_outlet_pressure','valve_inlet_enthalpy','subcooling','superheat']
skip = int(sys.argv[4]) if len(sys.argv) > 4 else 0
for n in names:
    ef=[];es=[];zf=[];zs=[];sf=[];ss=[]
    for i,(a,b) in enumerate(zip(f,s)):
        if i < skip or not a.get(n) or not b.get(n): continue
        j = bisect.bisect_right(tt, int(a['timestamp_ns'])) - 1
        if j < 0: continue
        t = float(truth[j]['output:'+n])
        e1 = float(a[n]) - t; e2 = float(b[n]) - t
        ef.append(e1); es.append(e2); zf.append(abs(e1)/float(a[n+'_sigma'])); zs.append(abs(e2)/float(b[n+'_sigma']))
        sf.append(float(a[n+'_sigma'])); ss.append(float(b[n+'_sigma']))
    rms=lambda v: math.sqrt(sum(x*x for x in v)/len(v)) if v else float('nan')
    mean=lambda v: sum(v)/len(v) if v else float('nan')
    print(f"{n:28s} n={len(ef):3d} RMS filter {rms(ef):10.4g} smoother {rms(es):10.4g} | mean sigma f {mean(sf):9.4g} s {mean(ss):9.4g} | mean |e|/sigma f {mean(zf):5.2f} s {mean(zs):5.2f}")

# The replay estimates against the simulator's truth, per virtual sensor: bias, RMS error and the RMS
# of error / sigma, after a warm-up; truth matched by time. Usage: compare_truth.py TRUTH.csv WARM_UP_S REPLAY.csv...
import csv, sys, math, bisect
truth_file, warm = sys.argv[1], float(sys.argv[2])
outs = sys.argv[3:]
T = list(csv.DictReader(open(truth_file)))
tt = [int(r['wall_time_ns']) for r in T]
names = ['charge', 'condenser_outlet_pressure', 'valve_inlet_enthalpy', 'superheat', 'subcooling',
         'cooling_capacity', 'condenser_heat_flow', 'cop']
print('%-28s' % 'signal' + ''.join('%34s' % o.split('/')[-1] for o in outs))
res = {o: {} for o in outs}
for o in outs:
    R = list(csv.DictReader(open(o)))
    t0 = int(R[0]['timestamp_ns'])
    for n in names:
        e, z = [], []
        for r in R:
            t = int(r['timestamp_ns'])
            if (t - t0) / 1e9 < warm or r[n] == '': continue
            i = bisect.bisect_left(tt, t)
            if i >= len(tt): continue
            i = min(range(max(i - 1, 0), min(i + 1, len(tt))), key=lambda k: abs(tt[k] - t))
            tv = float(T[i]['output:' + n]); v = float(r[n]); s = float(r[n + '_sigma'])
            e.append(v - tv); z.append((v - tv) / s if s > 0 else float('nan'))
        res[o][n] = (sum(e) / len(e), math.sqrt(sum(x * x for x in e) / len(e)),
                     math.sqrt(sum(x * x for x in z) / len(z)), len(e))
for n in names:
    print('%-28s' % n + ''.join('  bias %9.4g rmse %9.4g z %5.2f' % res[o][n][:3] for o in outs))

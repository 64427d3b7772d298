# Cross-IMU pair-axis check (a quick one; the full tool is scripts/cross_imu_report.sh):
# insid's gyro bias differences against the direct raw-sample differences, the mean of the
# 50 Hz rate differences of two IMUs over the flight window 85-215 s boot
# (imported t_s = boot - 74.7).
# Usage: /usr/bin/python3 scripts/cross_imu_quick.py DIR PREFIX   (results/uncertainty/README.md)
#   DIR holds d_IMU, d_IMU2, d_IMU3 (insid import ardupilot ... --imu K --t-start 74.7 --t-end 215)
#   and PREFIX{IMU,IMU2,IMU3}.json (insid identify results); prints z per pair-axis.
import json, sys, math
D = sys.argv[1]          # directory with d_IMU, d_IMU2, d_IMU3
prefix = sys.argv[2]     # result json prefix, e.g. before_ekf_ -> before_ekf_IMU.json
T0, T1 = 85.0 - 74.7, 215.0 - 74.7   # flight window, boot seconds -> imported t_s
def rates(k):
    rows = [l.split(',') for l in open(f'{D}/d_{k}/imu.csv').read().split('\n')[1:] if l]
    out = {}; prev = None
    for r in rows:
        t = float(r[0])
        if prev is not None and T0 <= t <= T1:
            dt = t - prev
            out[round(t, 6)] = [float(r[i]) / dt for i in (1, 2, 3)]
        prev = t
    return out
R = {k: rates(k) for k in ('IMU', 'IMU2', 'IMU3')}
def res(k):
    r = json.load(open(f'{D}/{prefix}{k}.json'))
    return {p['name']: (p['estimate'], p['sd']) for p in r['parameters']}
E = {k: res(k) for k in R}
deg = 180 / math.pi
covered = 0; n = 0
print('pair axis direct(deg/s) insid(deg/s) sd(deg/s) z')
for a, b in (('IMU', 'IMU2'), ('IMU', 'IMU3'), ('IMU2', 'IMU3')):
    ts = sorted(set(R[a]) & set(R[b]))
    for i, ax in enumerate('xyz'):
        direct = sum(R[a][t][i] - R[b][t][i] for t in ts) / len(ts)
        ea, sa = E[a][f'gyro_bias_{ax}']; eb, sb = E[b][f'gyro_bias_{ax}']
        d = ea - eb; sd = math.hypot(sa or float('nan'), sb or float('nan'))
        z = (d - direct) / sd
        n += 1; covered += abs(z) <= 2
        print(f'{a}-{b} {ax} {direct*deg:+.3f} {d*deg:+.3f} {sd*deg:.3f} {z:+.2f}')
print(f'within 2 sd: {covered}/{n}')

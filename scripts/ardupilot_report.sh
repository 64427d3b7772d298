#!/usr/bin/env bash
# A real drone flight end to end: the shared ArduPilot quadcopter log
# (../shared/data/ardupilot-copter/log171.bin), for each of its three IMUs:
#   import ardupilot (boot time T_START-T_END: the ground window before the motors, Loiter; the
#   Acro part and the flip cut off) -> navigate uncompensated -> identify (EKF-RTS and DVPIO on
#   the windowed fitness, MEMS grade, level + GNSS-course heading) -> navigate compensated ->
#   diagnose, then results/real/ardupilot/report.md (scripts/ardupilot_report.py) with insid's
#   biases held against the autopilot EKF's own (EKF1 GX/GY/GZ, EKF2 AZ1bias/AZ2bias).
#   scripts/ardupilot_report.sh     # from the repository root, after a build (build/cli/insid)
# Without the shared log it says so and exits 0 ("skipped"). Intermediate files go to
# build/real-ardupilot/ (not committed); results/real/ardupilot/ is rewritten.
set -euo pipefail
cd "$(dirname "$0")/.."

log=../shared/data/ardupilot-copter/log171.bin
if [[ ! -f $log ]]; then
  echo "ardupilot_report: skipped: $log is absent (the shared real recordings; see" \
    "scripts/get-sample-data.sh)" >&2
  exit 0
fi
insid=${INSID:-build/cli/insid}
if [[ ! -x $insid ]]; then
  echo "ardupilot_report: $insid not found: build first (scripts/build.sh, or set INSID=...)" >&2
  exit 1
fi
py=/usr/bin/python3
[[ -x $py ]] || py=python3
work=build/real-ardupilot
out=results/real/ardupilot
# Boot seconds: from after the 2.0 s logging gap at ~72.6 s (the import refuses a 2 s IMU gap),
# over ~8 s on the ground before the motors start at ~83 s (the static window), through Loiter,
# to 2 s before the pilot switches to Acro at 217.2 s (the flip at ~239 s stays out).
T_START=${T_START:-74.7}
T_END=${T_END:-215}
W=${W:-10}  # the MEMS default window (results/window/)
rm -rf "$work"
mkdir -p "$work" "$out/figures"
{ git rev-parse --short=12 HEAD && git status --porcelain --untracked-files=no | grep -q . && echo " (with uncommitted changes)"; } 2>/dev/null | tr -d '\n' >"$work/git.txt" || true

# The MEMS box (sigma 0.1 deg/s, 10 mg; gyro z [-8, 8] sigma: it trades with the heading) and
# the accelerometer z bias, which the autopilot also estimates.
G=0.0017453292519943296
A=0.0980665
est=(--estimate gyro_bias_x:$G --estimate gyro_bias_y:$G --estimate gyro_bias_z:$G:-8:8
     --estimate accel_bias_x:$A --estimate accel_bias_y:$A --estimate accel_bias_z:$A)
att=(--initial-attitude level+heading)

for imu in IMU IMU2 IMU3; do
  d=$work/$imu
  echo "ardupilot_report: $imu: import" >&2
  "$insid" import ardupilot "$log" --imu "$imu" --t-start "$T_START" --t-end "$T_END" \
    --out "$d" 2>"$work/$imu.import.txt"
  echo "ardupilot_report: $imu: navigate uncompensated" >&2
  for w in 0 "$W"; do
    "$insid" navigate --data "$d" "${att[@]}" --window-s $w --out "$work/$imu.nav_none_w$w.csv" \
      --summary "$work/$imu.nav_none_w$w.json" 2>>"$work/log.txt"
  done
  echo "ardupilot_report: $imu: identify (EKF-RTS, DVPIO; W = $W s)" >&2
  "$insid" identify --data "$d" --algo ekf-rts --grade mems "${est[@]}" "${att[@]}" \
    --window-s "$W" --no-reference-optimum --threads 1 --out "$work/$imu.ekf.json" \
    2>>"$work/log.txt"
  "$insid" identify --data "$d" --algo dvpio --grade mems "${est[@]}" "${att[@]}" \
    --window-s "$W" --iterations 100 --seed 1 --no-reference-optimum --threads 1 \
    --out "$work/$imu.dvpio.json" 2>>"$work/log.txt"
  echo "ardupilot_report: $imu: navigate compensated" >&2
  for m in ekf dvpio; do
    for w in 0 "$W"; do
      "$insid" navigate --data "$d" "${att[@]}" --window-s $w \
        --compensate-from "$work/$imu.$m.json" --out "$work/$imu.nav_${m}_w$w.csv" \
        --summary "$work/$imu.nav_${m}_w$w.json" 2>>"$work/log.txt"
    done
  done
  echo "ardupilot_report: $imu: diagnose" >&2
  base=()
  for e in gyro_bias_x:$G gyro_bias_y:$G gyro_bias_z:$G:-8:8 accel_bias_x:$A accel_bias_y:$A \
    accel_bias_z:$A; do
    base+=(--base "$e")
  done
  "$insid" diagnose --data "$d" --grade mems "${base[@]}" "${att[@]}" --window-s "$W" \
    --algo none --max-effects 2 --threads 1 --quiet --out "$work/$imu.diagnose.json" \
    2>>"$work/log.txt" || echo "diagnose failed: $(tail -n 1 "$work/log.txt")" \
    >"$work/$imu.diagnose.failed"
done

echo "ardupilot_report: cross-IMU check (the airframe's own truth for bias differences)" >&2
for m in ekf dvpio; do
  "$insid" cross-imu --data "$work/IMU" --data "$work/IMU2" --data "$work/IMU3" --clock boot \
    --result "$work/IMU.$m.json" --result "$work/IMU2.$m.json" --result "$work/IMU3.$m.json" \
    --t-start 85 --t-end "$T_END" --out "$work/cross_imu_$m.json" 2>>"$work/log.txt"
done

echo "ardupilot_report: report" >&2
$py scripts/ardupilot_report.py --work "$work" --out "$out" --window-s "$W" \
  --t-start "$T_START" --t-end "$T_END"
echo "ardupilot_report: wrote $out/report.md" >&2

#!/usr/bin/env bash
# The cross-IMU check on the shared ArduPilot quadcopter log: its three IMUs
# sit on one airframe, so the differences of their gyro readings measure the differences of their
# biases without any model of the flight.
#   import ardupilot --imu all (boot 74.7-215 s) -> identify each IMU (EKF-RTS, and DVPIO with
#   100 iterations, seed 1; MEMS grade, the default box, W = 10 s, gyro biases and accel z)
#   -> insid cross-imu in flight (boot 85-215 s, with each algorithm's three results) and on the
#   ground before the motors (75-82.5 s)
#   -> results/real/ardupilot/cross_imu.json (EKF-RTS), cross_imu_dvpio.json,
#      cross_imu_ground.json, cross_imu.md
#   and the motor offsets: import with --align-s 7.9 (the static window ends 0.08 s before the
#   motors start at 82.86 s), identify each IMU by LM with the gyro biases measured at rest
#   (--gyro-bias-at-rest) and gyro_motor_offset_x|y|z and accel z estimated, cross-imu over
#   75-215 s with 1 s blocks (the jump at motor start per pair)
#   -> cross_imu_motor.json
#   scripts/cross_imu_report.sh     # from the repository root, after a build (about 35 s)
# Without the shared log it says so and exits 0 ("skipped"). Intermediate files go to
# build/real-cross-imu/ (not committed).
set -euo pipefail
cd "$(dirname "$0")/.."

log=../shared/data/ardupilot-copter/log171.bin
if [[ ! -f $log ]]; then
  echo "cross_imu_report: skipped: $log is absent (the shared real recordings; see" \
    "scripts/get-sample-data.sh)" >&2
  exit 0
fi
insid=${INSID:-build/cli/insid}
if [[ ! -x $insid ]]; then
  echo "cross_imu_report: $insid not found: build first (scripts/build.sh, or set INSID=...)" >&2
  exit 1
fi
work=build/real-cross-imu
out=results/real/ardupilot
rm -rf "$work"
mkdir -p "$work" "$out"

"$insid" import ardupilot "$log" --imu all --t-start 74.7 --t-end 215 --out "$work/copter" \
  2>"$work/import.txt"
results=()
dvpio=()
for imu in IMU IMU2 IMU3; do
  common=(--data "$work/copter/$imu" --grade mems --initial-attitude level+heading --window-s 10
          --estimate gyro_bias_x --estimate gyro_bias_y --estimate gyro_bias_z
          --estimate accel_bias_z --threads 2)
  "$insid" identify "${common[@]}" --algo ekf-rts --no-reference-optimum \
    --out "$work/$imu.ekf.json" 2>"$work/$imu.identify.txt"
  "$insid" identify "${common[@]}" --algo dvpio --iterations 100 --seed 1 \
    --out "$work/$imu.dvpio.json" 2>"$work/$imu.identify_dvpio.txt"
  results+=(--result "$work/$imu.ekf.json")
  dvpio+=(--result "$work/$imu.dvpio.json")
done
data=(--data "$work/copter/IMU" --data "$work/copter/IMU2" --data "$work/copter/IMU3"
      --clock boot)
"$insid" cross-imu "${data[@]}" "${results[@]}" --t-start 85 --t-end 215 --force \
  --out "$out/cross_imu.json" --markdown "$work/flight.md" 2>&1 | tee "$work/flight.txt" >&2
"$insid" cross-imu "${data[@]}" "${dvpio[@]}" --t-start 85 --t-end 215 --force \
  --out "$out/cross_imu_dvpio.json" --markdown "$work/flight_dvpio.md" 2>&1 |
  tee "$work/flight_dvpio.txt" >&2
"$insid" cross-imu "${data[@]}" --t-start 75 --t-end 82.5 --force \
  --out "$out/cross_imu_ground.json" --markdown "$work/ground.md" 2>&1 | tee "$work/ground.txt" >&2
# The motor offsets against the jump of each pair's difference at motor start.
"$insid" import ardupilot "$log" --imu all --t-start 74.7 --t-end 215 --align-s 7.9 \
  --out "$work/motors" 2>"$work/import_motors.txt"
motor=()
for imu in IMU IMU2 IMU3; do
  "$insid" identify --data "$work/motors/$imu" --grade mems --initial-attitude level+heading \
    --window-s 10 --gyro-bias-at-rest --estimate accel_bias_z \
    gyro_motor_offset_x gyro_motor_offset_y gyro_motor_offset_z --algo lm \
    --no-reference-optimum --uncertainty-replicas 40 --threads 2 \
    --out "$work/$imu.motor.json" 2>"$work/$imu.identify_motor.txt"
  motor+=(--result "$work/$imu.motor.json")
done
"$insid" cross-imu --data "$work/motors/IMU" --data "$work/motors/IMU2" \
  --data "$work/motors/IMU3" --clock boot "${motor[@]}" --t-start 75 --t-end 215 --block-s 1 \
  --force --out "$out/cross_imu_motor.json" --markdown "$work/motor.md" 2>&1 |
  tee "$work/motor.txt" >&2
{
  echo "# Cross-IMU check: the shared ArduPilot quadcopter (log171.bin)"
  echo
  echo "Written by \`scripts/cross_imu_report.sh\`. Gyro bias differences measured directly from"
  echo "the samples of the three IMUs (\`insid cross-imu\`, README \"The cross-IMU check\"), boot"
  echo "seconds. insid's estimates: \`insid identify --grade mems --initial-attitude level+heading"
  echo "--window-s 10\`, gyro biases and accel z, the default box (widened where an estimate presses"
  echo "it), with \`--algo ekf-rts\` and with \`--algo dvpio --iterations 100 --seed 1\`."
  echo
  echo "## In flight, boot 85-215 s; insid = EKF-RTS"
  echo
  sed 1,2d "$work/flight.md"
  echo
  echo "## In flight, boot 85-215 s; insid = DVPIO (the comparison only; the direct differences as above)"
  echo
  sed -n '/estimated differences/,$p' "$work/flight_dvpio.md"
  echo
  echo "## On the ground before the motors start, boot 75-82.5 s"
  echo
  sed 1,2d "$work/ground.md"
  echo
  echo "## The motor offsets: the jump at motor start, boot 75-215 s (1 s blocks)"
  echo
  echo "Imported with \`--align-s 7.9\` (the static window ends 0.08 s before the motors start);"
  echo "insid = \`identify --algo lm --gyro-bias-at-rest\` with \`gyro_motor_offset_x|y|z\` and"
  echo "accel z estimated: each gyro's motors-off bias is the window's mean rate less the Earth"
  echo "rate, so the gyro_bias rows are not compared (insid measures them from the same samples"
  echo "as the direct difference)."
  echo
  sed -n '/jump of the difference/,$p' "$work/motor.md"
} >"$out/cross_imu.md"
echo "cross_imu_report: wrote $out/cross_imu.json, $out/cross_imu_dvpio.json," \
  "$out/cross_imu_ground.json, $out/cross_imu_motor.json, $out/cross_imu.md" >&2

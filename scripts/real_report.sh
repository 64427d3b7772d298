#!/usr/bin/env bash
# The real-data report: the shared MEMS walk (../shared/data/rtklib-walk) through
# import -> navigate -> identify (EKF-RTS, DVPIO on the windowed fitness, LM as the data's own
# least-squares optimum) -> navigate compensated -> diagnose, then results/real/report.md and
# its figures (scripts/real_report.py, Debian's python3 + matplotlib).
#   scripts/real_report.sh            # from the repository root, after a build (build/cli/insid)
# Without ../shared/data/rtklib-walk it says so and exits 0 ("skipped").
# Intermediate files go to build/real-walk/ (not committed); results/real/ is rewritten.
# Choices made by measurement (the report shows the measurements each run):
#   * the static window: the import's default ends at the IMU block before the walker's turn on
#     the spot (9.0 s; the GNSS speed alone would give 10.0 s, into the turn); as a cross-check
#     real_report.py --static-end measures the last quiet 0.5 s block of the gyros (also 9.0 s)
#     and the data are imported again with that --align-s;
#   * the initial attitude: gyrocompass is tried (and refused: MEMS gyros do not sense Earth
#     rate), so level+heading (GNSS course); a --heading-deg scan shows what the heading trades;
#   * the window W: LM on W in {5, 10, 20, 40, 0}; W_CHOSEN below, reasons in the report.
set -euo pipefail
cd "$(dirname "$0")/.."

data=../shared/data/rtklib-walk
if [[ ! -f $data/imu_1730_sf.csv || ! -f $data/gnss_1730_sf.pos ]]; then
  echo "real_report: skipped: $data is absent (the shared real recordings; see its README)" >&2
  exit 0
fi
insid=${INSID:-build/cli/insid}
if [[ ! -x $insid ]]; then
  echo "real_report: $insid not found: build first (scripts/build.sh, or set INSID=...)" >&2
  exit 1
fi
py=/usr/bin/python3
[[ -x $py ]] || py=python3
work=build/real-walk
out=results/real
W_CHOSEN=${W_CHOSEN:-20}
rm -rf "$work"
mkdir -p "$work" "$out/figures"
{ git rev-parse --short=12 HEAD && git status --porcelain --untracked-files=no | grep -q . && echo " (with uncommitted changes)"; } 2>/dev/null | tr -d '\n' >"$work/git.txt" || true

# MEMS search box (the catalogue's sigmas are navigation grade): sigma 0.1 deg/s for the gyros,
# 10 mg for the accelerometers, [-4, 4] sigma (gyro z [-8, 8]: it trades with the heading).
G=0.0017453292519943296  # 0.1 deg/s in rad/s
A=0.0980665              # 10 mg in m/s^2
est=(--estimate gyro_bias_x:$G --estimate gyro_bias_y:$G --estimate gyro_bias_z:$G:-8:8
     --estimate accel_bias_x:$A --estimate accel_bias_y:$A)
att=(--initial-attitude level+heading)
# EKF-RTS: bias priors from the MEMS grade (identification/grade.h). The noise from the walk's README (gyro 0.0038 deg/s/sqrt(Hz) =
# 0.23 deg/sqrt(h), accel 70 ug/sqrt(Hz) = 0.041 m/s/sqrt(h)) and the .pos std (0.05 m/s).
ekf=(--grade mems --param arw_deg_rth=0.23 --param vrw_mps_rth=0.041
     --param gnss_vel_sigma_mps=0.05 --param gnss_pos_sigma_m=0.05)

import_walk() {  # $1 = dataset dir, rest: extra options
  local dir=$1; shift
  "$insid" import csv --imu $data/imu_1730_sf.csv --columns t,ax,ay,az,gx,gy,gz,-,-,-,- \
    --units s,g-local,rad/s --gnss $data/gnss_1730_sf.pos --mounting-rpy-deg 180,0,-90 \
    --out "$dir" "$@" 2>>"$work/log.txt"
}

echo "real_report: import (documented mounting 180,0,-90) and the static window" >&2
import_walk "$work/walk-default"
align_s=$($py scripts/real_report.py --static-end "$work/walk-default")
import_walk "$work/walk" --align-s "$align_s"
echo "$align_s" >"$work/align_s.txt"
cp "$work/walk/provenance.json" "$work/provenance.json"

echo "real_report: initial attitude" >&2
if "$insid" navigate --data "$work/walk" --summary "$work/gyrocompass.json" 2>"$work/gyrocompass.err"; then
  echo "gyrocompass accepted" >"$work/gyrocompass.txt"
else
  cp "$work/gyrocompass.err" "$work/gyrocompass.txt"
fi
for h in 113 123 133 143 153; do
  "$insid" identify --data "$work/walk" --algo lm "${est[@]}" "${att[@]}" --heading-deg $h \
    --window-s "$W_CHOSEN" --no-reference-optimum --uncertainty-replicas 0 --threads 1 \
    --out "$work/heading_$h.json" 2>>"$work/log.txt"
done

echo "real_report: navigate uncompensated" >&2
for w in 0 "$W_CHOSEN"; do
  "$insid" navigate --data "$work/walk" "${att[@]}" --window-s $w --out "$work/nav_none_w$w.csv" \
    --summary "$work/nav_none_w$w.json"
done

echo "real_report: the window W (LM, least squares, on W = 5, 10, 20, 40, 0)" >&2
for w in 5 10 20 40 0; do
  "$insid" identify --data "$work/walk" --algo lm "${est[@]}" "${att[@]}" --window-s $w \
    --no-reference-optimum --threads 1 --out "$work/lm_w$w.json" 2>>"$work/log.txt"
done

echo "real_report: identify (EKF-RTS; DVPIO at W = $W_CHOSEN s)" >&2
"$insid" identify --data "$work/walk" --algo ekf-rts "${est[@]}" "${att[@]}" "${ekf[@]}" \
  --window-s "$W_CHOSEN" --no-reference-optimum --threads 1 --out "$work/ekf.json" 2>>"$work/log.txt"
"$insid" identify --data "$work/walk" --algo dvpio "${est[@]}" "${att[@]}" --window-s "$W_CHOSEN" \
  --iterations 200 --seed 1 --threads 1 --out "$work/dvpio.json" 2>>"$work/log.txt"
cp "$work/lm_w$W_CHOSEN.json" "$work/lm.json"

echo "real_report: navigate compensated" >&2
for m in ekf dvpio lm; do
  comp=$($py scripts/real_report.py --compensate "$work/$m.json")
  for w in 0 "$W_CHOSEN"; do
    # shellcheck disable=SC2086
    "$insid" navigate --data "$work/walk" "${att[@]}" --window-s $w $comp \
      --out "$work/nav_${m}_w$w.csv" --summary "$work/nav_${m}_w$w.json"
  done
done

echo "real_report: diagnose (base: the five biases, W = $W_CHOSEN s)" >&2
base=()
for e in gyro_bias_x:$G gyro_bias_y:$G gyro_bias_z:$G:-8:8 accel_bias_x:$A accel_bias_y:$A; do
  base+=(--base "$e")
done
"$insid" diagnose --data "$work/walk" "${base[@]}" "${att[@]}" --window-s "$W_CHOSEN" \
  --candidates gyro_scale_z accel_bias_drift_x accel_bias_drift_y gyro_bias_drift_z gnss_latency \
  --algo none --max-effects 2 --threads 1 --quiet --out "$work/diagnose.json" 2>>"$work/log.txt" \
  || echo "diagnose failed: $(tail -n 1 "$work/log.txt")" >"$work/diagnose.failed"

echo "real_report: report" >&2
$py scripts/real_report.py --report "$work" --out "$out" --window-s "$W_CHOSEN"
echo "real_report: wrote $out/report.md" >&2

#!/usr/bin/env bash
# Fuzz insid's readers (dataset; JSON configs; the JSON reader's limits; an external optimizer's
# reply line) with libFuzzer (clang, AddressSanitizer + UBSan): builds fuzz/ into
# ./build-fuzz, seeds each target's corpus, runs each for SECONDS (default 60), and prints the
# executions and findings per target. Findings (crash-*, leak-*, timeout-*) stay in
# build-fuzz/findings/<target>/. Usage: scripts/fuzz.sh [SECONDS [TARGET ...]] (default: all
# targets, 60 s each). INSID_FUZZ_READER=N pins insid_import_fuzzer to one reader (0 .pos,
# 1 KF-GINS GNSS, 2 KF-GINS IMU, 3 mapped CSV, 4 assembly, 5 ULog with --heading gps and mag,
# 6 CSV with a dual-antenna heading, 7 CSV with a magnetometer, both assembled, 8 ArduPilot
# DataFlash), e.g.
# INSID_FUZZ_READER=5 scripts/fuzz.sh 600 insid_import_fuzzer.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
command -v clang++ >/dev/null || { echo "insid fuzz: needs clang++ (apt-get install clang libclang-rt-dev)" >&2; exit 1; }
CC=clang CXX=clang++ cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DINSID_FUZZ=ON \
  -DINSID_BUILD_TESTS=OFF -DINSID_BUILD_BENCHMARKS=OFF -DINSID_WITH_MPI=OFF >&2
targets=(insid_dataset_fuzzer insid_config_fuzzer insid_import_fuzzer insid_json_fuzzer
         insid_external_reply_fuzzer)
if [ $# -gt 1 ]; then targets=("${@:2}"); fi
cmake --build build-fuzz -j"$(nproc)" --target "${targets[@]}" >&2

# Seed corpus: a valid dataset's files, each behind the byte that selects it.
seed_dir=build-fuzz/seed-dataset
rm -rf "$seed_dir" build-fuzz/corpus build-fuzz/findings
# (from the main build's insid when there is one; libFuzzer also starts from an empty corpus)
if [ -x build/cli/insid ]; then
  build/cli/insid simulate --preset straight --flight-s 2 --out "$seed_dir" >/dev/null 2>&1 || true
fi
mkdir -p build-fuzz/corpus/insid_dataset_fuzzer
i=0
for f in imu.csv gnss.csv truth.csv meta.json; do
  if [ -f "$seed_dir/$f" ]; then
    { printf "\\x0$i"; head -c 20000 "$seed_dir/$f"; } > "build-fuzz/corpus/insid_dataset_fuzzer/seed-$f"
  fi
  i=$((i + 1))
done

# Config seeds: byte 0 = a campaign config, byte 1 = a scenario file (the presets).
mkdir -p build-fuzz/corpus/insid_config_fuzzer
{ printf "\\x00"; cat <<'JSON'
{"name": "seed", "seeds": [1, 2], "max_iterations": 3,
 "scenarios": [{"name": "s", "preset": "rich", "flight_s": 120, "grade": "nav", "data_seed": 3,
                "set": {"gyro_bias_x": 1e-7}}],
 "algorithms": [{"label": "PSO", "name": "pso", "parameters": {"population": 20}},
                {"label": "DVPIO", "name": "dvpio"}],
 "estimate": ["accel_bias_x", "gyro_bias_y:1e-7:-3:3"]}
JSON
} > build-fuzz/corpus/insid_config_fuzzer/seed-campaign.json
for f in scenarios/presets/*.json; do
  { printf "\\x01"; cat "$f"; } > "build-fuzz/corpus/insid_config_fuzzer/seed-$(basename "$f")"
done

# Import seeds: a .pos (byte 0), KF-GINS GNSS (1) and IMU (2), a mapped CSV (3), assembly (4).
mkdir -p build-fuzz/corpus/insid_import_fuzzer
walk=../shared/data/rtklib-walk
if [ -f "$walk/gnss_1730_sf.pos" ]; then
  { printf "\\x00"; head -c 6000 "$walk/gnss_1730_sf.pos"; } > build-fuzz/corpus/insid_import_fuzzer/seed-pos
fi
{ printf "\\x01"; for k in 0 1 2 3 4; do echo "10$k 40.1 -105.1 1600 0.01 0.01 0.02"; done; } \
  > build-fuzz/corpus/insid_import_fuzzer/seed-kf-gnss
{ printf "\\x02"; for k in 0 1 2 3 4 5; do echo "100.0$k 1e-5 -2e-5 3e-6 0.001 -0.002 -0.098"; done; } \
  > build-fuzz/corpus/insid_import_fuzzer/seed-kf-imu
{ printf "\\x03"; echo "t,ax,ay,az,gx,gy,gz,m"; for k in 0 6 12 19; do echo "100$k,0.01,0,1.01,0.1,-0.2,0.3,0"; done; } \
  > build-fuzz/corpus/insid_import_fuzzer/seed-csv
{ printf "\\x04"; for k in $(seq 100 2 160); do echo "$((k / 10)).$((k % 10))00 1e-5 -2e-5 3e-6 0.001 -0.002 -0.098"; done; } \
  > build-fuzz/corpus/insid_import_fuzzer/seed-assemble

# ULog seeds (byte 5): the head of each shared PX4 log (formats, subscriptions, first data).
for f in ../shared/data/px4-ulog/sample_log_small.ulg ../shared/data/px4-ulog/sample_px4_events.ulg; do
  if [ -f "$f" ]; then
    { printf "\\x05"; head -c 60000 "$f"; } > "build-fuzz/corpus/insid_import_fuzzer/seed-$(basename "$f")"
  fi
done

# DataFlash seed (byte 8): the head of the shared ArduPilot log (FMT records, first data).
f=../shared/data/ardupilot-copter/log171.bin
if [ -f "$f" ]; then
  { printf "\\x08"; head -c 60000 "$f"; } > build-fuzz/corpus/insid_import_fuzzer/seed-log171
  # Its FMT block (bytes 0-6407) and 40 kB from the IMU record at byte 1499984 (in flight: 3D fixes).
  { printf "\\x08"; head -c 6408 "$f"
    dd if="$f" iflag=skip_bytes,count_bytes skip=1499984 count=40000 bs=4096 status=none; } \
    > build-fuzz/corpus/insid_import_fuzzer/seed-log171-flight
fi

# JSON seeds (the presets, an escaped quote and backslash before brackets) and protocol replies.
mkdir -p build-fuzz/corpus/insid_json_fuzzer build-fuzz/corpus/insid_external_reply_fuzzer
cp scenarios/presets/*.json build-fuzz/corpus/insid_json_fuzzer/
printf '{"a": "[[{\\"\\\\", "b": [[[1]]]}' > build-fuzz/corpus/insid_json_fuzzer/seed-escapes
printf '{"points": [[0, 0.5, 1.25], [-1, -2, 0.5]]}' > build-fuzz/corpus/insid_external_reply_fuzzer/seed-points
printf '{"error": "no idea"}' > build-fuzz/corpus/insid_external_reply_fuzzer/seed-error

status=0
for t in "${targets[@]}"; do
  mkdir -p "build-fuzz/findings/$t"
  log="build-fuzz/findings/$t.log"
  set +e
  "build-fuzz/fuzz/$t" "build-fuzz/corpus/$t" -max_total_time="$seconds" -timeout=10 \
     -rss_limit_mb=4096 -artifact_prefix="build-fuzz/findings/$t/" > "$log" 2>&1
  rc=$?
  set -e
  runs=$(grep -oE "Done [0-9]+ runs" "$log" | grep -oE "[0-9]+" || echo "?")
  findings=$(find "build-fuzz/findings/$t" -type f | wc -l)
  echo "insid fuzz: $t: $runs executions in ${seconds} s, $findings finding(s) (exit $rc; log $log)"
  [ "$findings" -eq 0 ] && [ "$rc" -eq 0 ] || status=1
done
exit $status

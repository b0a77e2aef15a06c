#!/usr/bin/env bash
# What a flood of session requests from one robot costs another robot, before and after a change,
# in one run: robot A (locsim live corridor, feature_ekf, 20 s) alone, then with robot "flooder"
# writing session requests at RATE a second (default 10000; 0 = as fast as it can) from its own
# participant, against each build's locd. Prints A's poses and latency, and the flood's rate.
# ROBOTS > 1: the flooder names robots flooder_0 .. flooder_(ROBOTS-1) in turn from one writer (an
# operator's identity, or anyone in plain mode); DELAY_S: the flood starts that long after A.
# Each build floods with its own request_flood (its own IDL): `cmake -DLOCD_BUILD_BENCH=ON` and
# `make request_flood` in both. Usage (as root, from the repository root):
#   bench/server/request_flood.sh BEFORE_BUILD_DIR AFTER_BUILD_DIR [ROUNDS] [RATE] [ROBOTS] [DELAY_S]
set -euo pipefail
cd "$(dirname "$0")/../.."
before="$1"
after="$2"
rounds="${3:-2}"
rate="${4:-10000}"
robots="${5:-1}"
delay="${6:-0}"
source bench/lib/loopback_namespace.sh
field() { sed -n "s/.*\"$1\":\([^,}]*\).*/\1/p" "$2"; }

measure() {  # BUILD_DIR LABEL FLOOD(0|1)
  local build="$1" label="$2" flood="$3"
  cat > "$work/locd.yaml" <<CONFIG
domain_id: 93
plugin_directories: [$build/plugins]
map_directories: [$PWD/config/maps]
log_level: warning
CONFIG
  run "$build/bin/locd" --config "$work/locd.yaml" > "$work/locd.log" 2>&1 &
  sleep 2  # loading the plugins on a busy machine
  local flood_json="$work/flood.json"
  echo '{}' > "$flood_json"
  if [ "$flood" = 1 ]; then
    ( sleep "$delay"; run "$build/bin/request_flood" --domain 93 --robot flooder --rate "$rate" --robots "$robots" \
        --seconds 22 > "$flood_json" ) &
  fi
  if ! run "$build/bin/locsim" live config/scenarios/corridor.yaml --domain 93 --duration 20 --json > "$work/a.json" \
      2> "$work/a.err"; then
    echo "{\"updates\":\"none (locsim: $(tail -1 "$work/a.err" | tr -d '"'))\"}" > "$work/a.json"
  fi
  wait %2 2>/dev/null || true
  pkill -TERM -f "$build/bin/locd --config $work/locd.yaml" || true
  wait 2>/dev/null || true
  printf "%-7s %-8s A: poses %s, rmse %s m, latency p50 %s ms p99 %s ms | flood: %s requests at %s/s\n" \
    "$label" "$([ "$flood" = 1 ] && echo flooded || echo alone)" "$(field updates "$work/a.json")" \
    "$(field rmse_m "$work/a.json")" "$(field latency_ms_p50 "$work/a.json")" "$(field latency_ms_p99 "$work/a.json")" \
    "$(field written "$flood_json")" "$(field per_s "$flood_json")"
}

for round in $(seq "$rounds"); do
  for flood in 0 1; do
    measure "$before" before "$flood"
    measure "$after" after "$flood"
  done
done

#!/usr/bin/env bash
# Fault isolation, measured (server/README.md quotes the output). Three parts, each against a
# real locd over loopback DDS, inside a network namespace made here and removed at the end:
#
#  isolation  robot A drives the corridor on feature_ekf (locsim live) while robot B, on the
#             same server, runs the `faulty` test plugin that crashes / exits / hangs / hoards
#             memory / writes garbage after 50 updates (then again after each restart, until it
#             is marked failed). Per fault: A's RMSE and longest wait between two poses.
#  restart    robot A drives the corridor; locd is killed with SIGKILL after 30 s and started
#             again 1 s later. A's error just before the kill and in the first second after.
#  sigterm    SIGTERM to a server whose plugin hangs: seconds until it has exited.
#
# Usage (as root, from the repository root, after a build):
#   bench/server/fault_isolation.sh [isolation|restart|sigterm|all] [DURATION_S]
# LOCD_FAULTS="hang allocate": only those faults in the isolation part.
set -euo pipefail
cd "$(dirname "$0")/../.."
part="${1:-all}"
duration="${2:-40}"
bin="$PWD/build/bin"
source bench/lib/loopback_namespace.sh

mkdir -p "$work/state"
cat > "$work/locd.yaml" <<EOF
domain_id: 90
plugin_directories: [$PWD/build/plugins, $PWD/build/broken_plugins]
map_directories: [$PWD/config/maps]
state_directory: $work/state
log_level: warning
EOF

# Robot B: the corridor under another name, on the faulty plugin.
faulty_scenario() {
  sed -e "s/id: corridor_bot/id: broken_bot/" \
      -e "s|config_file: ../plugins/feature_ekf.yaml|config_file: $work/faulty.yaml|" \
      -e "s|map_directories: \[\"../maps\"\]|map_directories: [\"$PWD/config/maps\"]|" \
      config/scenarios/corridor.yaml > "$work/broken_bot.yaml"
  printf "plugin: faulty\nparams: {fault: %s, after_updates: 50}\n" "$1" > "$work/faulty.yaml"
}

field() { sed -n "s/.*\"$1\":\([^,}]*\).*/\1/p" "$2"; }

if [[ "$part" == isolation || "$part" == all ]]; then
  echo "fault     robot A rmse_m  max_pose_gap_ms  poses   robot B last error"
  for fault in ${LOCD_FAULTS:-none segfault abort exit hang allocate stack_overflow garbage}; do
    faulty_scenario "$fault"
    run "$bin/locd" --config "$work/locd.yaml" > "$work/locd.log" 2>&1 &
    sleep 0.5
    run "$bin/locsim" live "$work/broken_bot.yaml" --domain 90 --duration "$duration" --json \
      > "$work/b.json" 2> "$work/b.err" &
    b=$!
    run "$bin/locsim" live config/scenarios/corridor.yaml --domain 90 --duration "$duration" --json \
      > "$work/a.json" 2> "$work/a.err"
    wait "$b" || true
    last_error=$(run "$bin/locctl" status broken_bot --domain 90 --json 2>/dev/null |
                 sed -n 's/.*"last_error":"\([^"]*\)".*/\1/p' | cut -c1-110)
    printf "%-9s %-14s %-16s %-7s %s\n" "$fault" "$(field rmse_m "$work/a.json")" \
      "$(field max_pose_gap_ms "$work/a.json")" "$(field updates "$work/a.json")" "${last_error:--}"
    pkill -TERM -f "$bin/locd --config $work/locd.yaml" || true
    wait 2>/dev/null || true
    rm -f "$work/state/sessions.json"
  done
fi

if [[ "$part" == restart || "$part" == all ]]; then
  run "$bin/locd" --config "$work/locd.yaml" > "$work/locd.log" 2>&1 &
  sleep 0.5
  run "$bin/locsim" live config/scenarios/corridor.yaml --domain 90 --duration 60 > "$work/a.txt" 2>&1 &
  a=$!
  sleep 30.5
  pkill -KILL -f "$bin/locd --config $work/locd.yaml"
  echo "restart: locd killed (SIGKILL) at t = 30 s; started again 1 s later"
  sleep 1
  run "$bin/locd" --config "$work/locd.yaml" > "$work/locd2.log" 2>&1 &
  wait "$a" || true
  # locsim prints one line a second: the error of the last pose scored by then.
  grep -E "^t=(2[89]|3[0-4])\." "$work/a.txt"
  grep -E "rmse|position error" "$work/a.txt" || true
  grep -E "resumed|restarted|state file" "$work/locd2.log" | head -5 || true
  pkill -TERM -f "$bin/locd --config $work/locd.yaml" || true
  wait 2>/dev/null || true
fi

if [[ "$part" == sigterm || "$part" == all ]]; then
  faulty_scenario hang
  for i in 1 2 3; do
    run "$bin/locd" --config "$work/locd.yaml" > "$work/locd.log" 2>&1 &
    sleep 0.5
    run timeout 5 "$bin/locsim" live "$work/broken_bot.yaml" --domain 90 --duration 3 > /dev/null 2>&1 || true
    pid=$(pgrep -f "$bin/locd --config $work/locd.yaml")
    start=$(date +%s.%N)
    kill -TERM "$pid"
    while kill -0 "$pid" 2>/dev/null; do sleep 0.01; done
    end=$(date +%s.%N)
    echo "sigterm: locd with a hung plugin exited $(echo "$end - $start" | bc) s after SIGTERM"
  done
fi

#!/usr/bin/env bash
# The cost of DDS Security, plain against secure against secure with whole RTPS messages encrypted
# (`locctl security init --rtps-protection encrypt`) in one run, rounds interleaved (plain, secure,
# rtps, plain, ...): ROBOTS robots at once, each a locd_latency_probe publishing MESSAGES
# odometry messages 5 ms apart to one locd serving the fixture_odometry test plugin (about 1 us
# of compute), each robot with its own identity in secure rounds (made here by locctl security).
# Per robot: end-to-end latency p50/p99 (odometry published -> pose received), time to join
# (participant created -> the server matched its writers: discovery, plus the handshake when
# secure) and to start its session (request written -> status running). Per round: locd's CPU
# time (user + system from /proc) over the probes' run, per robot and per message.
#
#   CYCLONEDDS_URI is set here (loopback); run inside a network namespace when others share the
#   machine. usage: bench/security/security_cost.sh [ROBOTS (4)] [MESSAGES (2000)] [ROUNDS (2)]
set -euo pipefail
cd "$(dirname "$0")/../.."
robots=${1:-4}
messages=${2:-2000}
rounds=${3:-2}
domain=${LOCD_BENCH_DOMAIN:-130}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
loopback="file://$PWD/config/dds/loopback.xml"
build/bin/locctl security init "$work/fleet" > /dev/null
build/bin/locctl security init "$work/fleet_rtps" --rtps-protection encrypt > /dev/null
for f in fleet fleet_rtps; do
  build/bin/locctl security server "$work/$f" srv > /dev/null
  for i in $(seq 1 "$robots"); do build/bin/locctl security robot "$work/$f" "robot$i" > /dev/null; done
done
printf "domain_id: %s\nplugin_directories: [%s]\nlog_level: warning\n" "$domain" "$PWD/build/broken_plugins" \
  > "$work/locd.yaml"
ticks_per_second=$(getconf CLK_TCK)
uri() {  # uri MODE IDENTITY
  case "$1" in
    plain) echo "$loopback" ;;
    secure) echo "$loopback,file://$work/fleet/$2/cyclonedds.xml" ;;
    rtps) echo "$loopback,file://$work/fleet_rtps/$2/cyclonedds.xml" ;;
  esac
}
echo "robots $robots, $messages messages each at 200 Hz, load average $(cut -d' ' -f1-3 /proc/loadavg)"
for round in $(seq 1 "$rounds"); do
  for mode in plain secure rtps; do
    CYCLONEDDS_URI=$(uri $mode server/srv) build/bin/locd --config "$work/locd.yaml" > "$work/locd.log" 2>&1 &
    locd=$!
    sleep 1
    read -r utime stime < <(awk '{print $14, $15}' "/proc/$locd/stat")
    start=$(date +%s.%N)
    probes=()
    for i in $(seq 1 "$robots"); do
      CYCLONEDDS_URI=$(uri $mode "robot/robot$i") build/bin/locd_latency_probe "$domain" "$messages" 5 "robot$i" \
        > "$work/probe$i.txt" 2>&1 &
      probes+=($!)
    done
    failed=0
    for p in "${probes[@]}"; do wait "$p" || failed=1; done
    end=$(date +%s.%N)
    read -r utime2 stime2 < <(awk '{print $14, $15}' "/proc/$locd/stat")
    kill "$locd"
    wait "$locd" || true
    awk -v r="$round" -v m="$mode" -v u0="$utime" -v s0="$stime" -v u1="$utime2" -v s1="$stime2" \
        -v hz="$ticks_per_second" -v t0="$start" -v t1="$end" -v n="$robots" -v k="$messages" 'BEGIN {
      cpu = (u1 + s1 - u0 - s0) / hz; wall = t1 - t0
      printf "round %d %-6s locd CPU %.2f s over %.1f s: %.1f %% of a core per robot, %.1f us per message\n",
             r, m, cpu, wall, 100 * cpu / wall / n, 1e6 * cpu / (n * k) }'
    for i in $(seq 1 "$robots"); do echo "  robot$i $(cat "$work/probe$i.txt")"; done
    [ "$failed" = 0 ] || { echo "a probe failed; locd log:"; cat "$work/locd.log"; exit 1; }
  done
done

#!/usr/bin/env bash
# Several hosts on one machine for multi-host tests and benchmarks: network namespaces
# PREFIX0 .. PREFIX<N-1>, each with an interface eth0 (10.99.0.<i+1>/24) on a veth pair whose
# other end is on a bridge in the namespace PREFIXsw. Nothing leaves these namespaces. Each host
# gets a Cyclone DDS config DIR/host<i>.xml: its own interface, no multicast, the other hosts as
# unicast peers. Needs root.
#   tests/common/hosts.sh up PREFIX N DIR
#   tests/common/hosts.sh down PREFIX N
#   tests/common/hosts.sh cut PREFIX I | heal PREFIX I    (unplug / plug host I's cable)
set -euo pipefail
action="$1"; prefix="$2"
case "$action" in
  up)
    n="$3"; dir="$4"
    mkdir -p "$dir"
    ip netns add "${prefix}sw"
    ip -n "${prefix}sw" link add br0 type bridge
    ip -n "${prefix}sw" link set br0 up
    ip -n "${prefix}sw" link set lo up
    peers=""
    for i in $(seq 0 $((n - 1))); do peers+="<Peer address=\"10.99.0.$((i + 1))\"/>"; done
    for i in $(seq 0 $((n - 1))); do
      host="${prefix}${i}"
      ip netns add "$host"
      ip -n "$host" link set lo up
      ip link add "${prefix}v${i}" type veth peer name "${prefix}p${i}"
      ip link set "${prefix}v${i}" netns "$host"
      ip link set "${prefix}p${i}" netns "${prefix}sw"
      ip -n "$host" link set "${prefix}v${i}" name eth0
      ip -n "$host" addr add "10.99.0.$((i + 1))/24" dev eth0
      ip -n "$host" link set eth0 up
      ip -n "${prefix}sw" link set "${prefix}p${i}" master br0
      ip -n "${prefix}sw" link set "${prefix}p${i}" up
      cat > "$dir/host${i}.xml" <<XML
<CycloneDDS xmlns="https://cdds.io/config"><Domain id="any">
  <General><Interfaces><NetworkInterface name="eth0"/></Interfaces><AllowMulticast>false</AllowMulticast></General>
  <Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>32</MaxAutoParticipantIndex>
    <Peers>$peers</Peers></Discovery>
  <Internal><MaxSampleSize>64MB</MaxSampleSize></Internal>
</Domain></CycloneDDS>
XML
    done
    ;;
  down)
    n="$3"
    for i in $(seq 0 $((n - 1))); do
      ip netns pids "${prefix}${i}" 2>/dev/null | xargs -r kill -9 2>/dev/null || true
      ip netns del "${prefix}${i}" 2>/dev/null || true
    done
    ip netns del "${prefix}sw" 2>/dev/null || true
    ;;
  cut)  ip -n "${prefix}sw" link set "${prefix}p$3" down ;;
  heal) ip -n "${prefix}sw" link set "${prefix}p$3" up ;;
  *) echo "usage: hosts.sh up PREFIX N DIR | down PREFIX N | cut PREFIX I | heal PREFIX I" >&2; exit 2 ;;
esac

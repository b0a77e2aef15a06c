# Sourced by the benchmark scripts (as root, from the repository root): a network namespace of
# their own with only loopback, removed with everything in it on exit, a scratch folder $work,
# and run(): a command inside the namespace with the loopback DDS config. Nothing the benchmark
# sends leaves the namespace, and it cannot meet another run's DDS traffic.
ns="locd_bench_$$"
work="$(mktemp -d)"
ip netns add "$ns"
ip netns exec "$ns" ip link set lo up
cleanup() {
  ip netns pids "$ns" 2>/dev/null | xargs -r kill -9 2>/dev/null || true
  ip netns del "$ns" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
run() { ip netns exec "$ns" env CYCLONEDDS_URI="file://$PWD/config/dds/loopback.xml" "$@"; }

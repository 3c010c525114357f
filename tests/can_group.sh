#!/usr/bin/env bash
# tests/can_group.sh: every CAN test of can_bridge that needs a kernel with
# CAN, in ONE boot of the project's QEMU guest (this machine's kernel has no
# CAN; see tests/vm/README.md).
#
#   tests/can_group.sh
#
# 1. builds on the host: the vcan test binaries (can_bridge/tests/vcan_*.rs)
#    and, with them, the binaries can_bridge_cli and virtual_drive, release
#    profile, with the rust group's feature resolution (nothing rebuilt);
# 2. boots one guest running tests/vm/can_guest.sh: the Rust vcan groups
#    (watchdog, e-stop, drive killed/silent/axis error, odometry, error
#    frames / bus-off, ENOBUFS, interface down) and the candump + python
#    cantools decoding checks (tests/can/can_checks.py), PASS/FAIL per check;
#    and the robot's bringup on vcan0 with scans and no upstream command
#    (tests/can/bringup_no_upstream.py: only zero setpoints on the bus);
# 3. prints the timing of each step and the tx jitter measured in the guest.
#
# Needs: Rust ≥ 1.85, and tests/vm/setup-host.sh run once (can-utils, python
# cantools, the guest kernel). Honours CARGO_TARGET_DIR (it must not be under
# /tmp, /run or /dev/shm: the guest has its own). Exits non-zero on any failure.
set -Eeuo pipefail
trap 'echo "can_group: ERROR at line $LINENO: $BASH_COMMAND" >&2' ERR

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd -P)
cd "$ROOT"
export CARGO_TERM_COLOR=${CARGO_TERM_COLOR:-never}
ms() { date +%s%3N; }
die() { echo "can_group: $*" >&2; exit 1; }

command -v cargo >/dev/null || die "cargo not found (install Rust ≥ 1.85 with rustup)"
command -v candump >/dev/null || die "candump not found: run tests/vm/setup-host.sh"
python3 -c 'import cantools' 2>/dev/null || die "python3 cannot import cantools: run tests/vm/setup-host.sh"
python3 -c 'import canopen' 2>/dev/null || die "python3 cannot import canopen (the CiA 402 drive of tests/can/cia402_drive.py): run tests/vm/setup-host.sh"

TARGET=${CARGO_TARGET_DIR:-$ROOT/target}
# The harness shares the repository read-write at the same path (even under
# /tmp); a target dir elsewhere under /tmp, /run or /dev/shm is invisible in
# the guest, which has its own.
case "$TARGET" in
  "$ROOT"/*) ;;
  /tmp/*|/run/*|/dev/shm/*) die "CARGO_TARGET_DIR=$TARGET: outside the repository, the guest cannot see host /tmp, /run, /dev/shm" ;;
esac
OUT="$ROOT/target/can_group"
mkdir -p "$OUT"
TESTS=(vcan_watchdog_estop vcan_drive_faults vcan_odometry vcan_bus_errors)

t_start=$(ms)
# ------------------------------------------------------------------ 1. build
args=()
for t in "${TESTS[@]}"; do args+=(--test "$t"); done
# --workspace, as the rust group's `cargo test --workspace`: the same feature
# resolution, so what that group built is reused and only the vcan test crates
# compile (-p can_bridge alone resolves features differently and rebuilds the
# crates under it). Building can_bridge's integration tests builds its
# binaries too, can_bridge_cli and virtual_drive among them.
cargo test --release --locked --workspace --no-run "${args[@]}" --message-format=json \
  > "$OUT/build.json" 2> "$OUT/build.log" || { tail -30 "$OUT/build.log"; die "building the vcan tests and binaries failed"; }
python3 - "$OUT/build.json" "${TESTS[@]}" > "$OUT/bins.txt" <<'PY'
import json, sys
want = set(sys.argv[2:])
found = {}
bins = set()
for line in open(sys.argv[1]):
    try:
        m = json.loads(line)
    except ValueError:
        continue
    if m.get("reason") == "compiler-artifact" and m.get("executable") and m["target"]["name"] in want \
            and "test" in m["target"]["kind"]:
        found[m["target"]["name"]] = m["executable"]
    if m.get("reason") == "compiler-artifact" and m.get("executable") and "bin" in m["target"]["kind"]:
        bins.add(m["target"]["name"])
missing = want - set(found)
if missing:
    sys.exit(f"no executable for {sorted(missing)} in cargo's output")
# The binaries the guest runs come from this same build.
missing = {"can_bridge_cli", "virtual_drive"} - bins
if missing:
    sys.exit(f"cargo's output built no binary {sorted(missing)}")
for name in sys.argv[2:]:
    print(found[name])
PY
BIN_DIR="$TARGET/release"
for b in can_bridge_cli virtual_drive; do [ -x "$BIN_DIR/$b" ] || die "$BIN_DIR/$b missing"; done
# The robot's bringup on the bus (tests/can/bringup_no_upstream.py) needs ROS
# and the nodes laid out as a ROS package (target/ros).
"$ROOT/tests/ros/install_deps.sh" > "$OUT/ros_deps.log" 2>&1 || { tail -20 "$OUT/ros_deps.log"; die "installing the ROS packages failed"; }
"$ROOT/oldbf_ros/rospkg/install.sh" > "$OUT/rospkg.log" 2>&1 || { tail -20 "$OUT/rospkg.log"; die "building the ROS nodes failed"; }
t_built=$(ms)

# ------------------------------------------------------------------ 2. one guest
rm -f "$OUT/summary.json"
set +e
OLDBF_VM_TIMEOUT=${OLDBF_VM_TIMEOUT:-900} \
  "$ROOT/tests/vm/run-in-vm.sh" "$ROOT/tests/vm/can_guest.sh" "$OUT/bins.txt" "$BIN_DIR" "$OUT/summary.json" \
  | tee "$OUT/guest.log"
rc=${PIPESTATUS[0]}
set -e
t_done=$(ms)

# ------------------------------------------------------------------ 3. timing
echo
echo "can_group timing:"
secs() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%6.1f s", (b - a) / 1000 }'; }
echo "  build (host)           $(secs "$t_start" "$t_built")"
echo "  guest (boot+tests+off) $(secs "$t_built" "$t_done")"
echo "  total                  $(secs "$t_start" "$t_done")"
if [ -s "$OUT/summary.json" ]; then
  python3 - "$OUT/summary.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
j = s.get("generic_jitter")
if j:
    print(f"  tx period jitter (generic, {j['frames']} frames at {j['nominal_ms']:.0f} ms, candump timestamps, TCG guest):")
    print(f"    mean period {j['mean_period_ms']:.3f} ms; |period - T| p50 {j['dev_p50_ms']:.3f}, p99 {j['dev_p99_ms']:.3f}, "
          f"max {j['dev_max_ms']:.3f} ms; grid phase max {j['grid_phase_max_ms']:.3f} ms; {j['missed_periods']} late > 1.5 T")
PY
fi
grep -c '^PASS' "$OUT/guest.log" | sed 's/^/  checks passed: /'
grep -c '^FAIL' "$OUT/guest.log" | sed 's/^/  checks failed: /' || true
[ "$rc" -eq 0 ] || die "guest reported failure (exit $rc); log: $OUT/guest.log"
echo "can_group: all CAN checks passed"

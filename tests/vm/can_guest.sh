#!/bin/bash
# tests/vm/can_guest.sh — guest side of tests/can_group.sh: every CAN test
# of can_bridge in ONE boot of the QEMU guest (vcan0 UP).
#
#   tests/vm/run-in-vm.sh tests/vm/can_guest.sh BINS_FILE BIN_DIR SUMMARY_JSON
#
# BINS_FILE lists the vcan test executables (one path per line), BIN_DIR
# holds can_bridge_cli and virtual_drive (release builds). Runs each test
# binary serially (they share vcan0) and the candump + cantools checks
# (tests/can/can_checks.py). Prints PASS/FAIL per check and a timing line
# per step; exits 1 on any failure.
set -uo pipefail

BINS_FILE=${1:?usage: can_guest.sh BINS_FILE BIN_DIR SUMMARY_JSON}
BIN_DIR=${2:?}
SUMMARY=${3:?}
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd -P)
cd "$ROOT"

fails=0
pass() { echo "PASS: $*"; }
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
ms() { date +%s%3N; }
TIMES=()

# ------------------------------------------------------------------ preconditions
if [ -d /proc/net/can ] && ip -details link show vcan0 2>/dev/null | grep -qw vcan; then
  pass "CAN stack and vcan0 present ($(uname -r))"
else
  fail "no CAN or no vcan0: run this inside tests/vm/run-in-vm.sh"
  exit 1
fi
for t in candump tc ip python3; do
  command -v "$t" >/dev/null || fail "$t not found (tests/vm/setup-host.sh installs can-utils; iproute2 for tc/ip)"
done
[ -s "$BINS_FILE" ] || fail "no vcan test binaries listed in $BINS_FILE"
[ "$fails" -eq 0 ] || exit 1

# ------------------------------------------------------------------ Rust vcan groups
while read -r bin; do
  [ -n "$bin" ] || continue
  name=$(basename "$bin" | sed 's/-[0-9a-f]*$//')
  t0=$(ms)
  # Serially (they share vcan0); each test's output is captured and shown at the end.
  out=$("$bin" --test-threads=1 --show-output 2>&1)
  rc=$?
  dt=$(( $(ms) - t0 ))
  TIMES+=("$name $dt")
  # One line per test case, then the measurements the tests print (not their logs).
  grep -E '^test .* \.\.\. (ok|FAILED)$' <<< "$out" \
    | sed -E 's/^test (.*) \.\.\. ok$/PASS: '"$name"'::\1/; s/^test (.*) \.\.\. FAILED$/FAIL: '"$name"'::\1/'
  grep -E '^(Generic|Odrive|counter|interface)' <<< "$out" | sed 's/^/    /'
  if [ "$rc" -eq 0 ]; then
    pass "$name (${dt} ms)"
  else
    fail "$name exited $rc (${dt} ms); output:"
    sed 's/^/    | /' <<< "$out" | tail -60
  fi
done < "$BINS_FILE"

# ------------------------------------------------------------------ candump + cantools
t0=$(ms)
if python3 tests/can/can_checks.py --bin-dir "$BIN_DIR" --summary "$SUMMARY"; then
  pass "candump + cantools checks"
else
  fail "candump + cantools checks"
fi
TIMES+=("can_checks.py $(( $(ms) - t0 ))")

# ------------------------------------------------------------------ drive variants
# ODrive 0.6, the two-axis CANopen node, SDO at run time (tests/can/drive_variant_checks.py).
t0=$(ms)
if python3 tests/can/drive_variant_checks.py --bin-dir "$BIN_DIR"; then
  pass "drive variant checks"
else
  fail "drive variant checks"
fi
TIMES+=("drive_variant_checks.py $(( $(ms) - t0 ))")

# ------------------------------------------------------------------ the bringup, no upstream command
t0=$(ms)
if ( source "$ROOT/target/ros/setup.bash" && /usr/bin/python3 tests/can/bringup_no_upstream.py ); then
  pass "bringup.launch with scans and no cmd_vel_in: zero setpoints only"
else
  fail "bringup.launch with scans and no cmd_vel_in (logs: target/can_group/bringup/)"
fi
TIMES+=("bringup_no_upstream.py $(( $(ms) - t0 ))")

echo "guest timings (ms):"
for t in "${TIMES[@]}"; do echo "  $t"; done
if [ "$fails" -eq 0 ]; then echo "can_guest: all checks passed"; exit 0; fi
echo "can_guest: $fails failure(s)"
exit 1

#!/bin/bash
# tests/vm/smoke.sh — guest-side smoke test group for the VM harness.
# Run it in the guest:  tests/vm/run-in-vm.sh tests/vm/smoke.sh
# Checks: the CAN stack is loaded, vcan0 exists and is UP, frames sent with
# cansend are captured by candump, and python cantools decodes a captured
# frame against a DBC. Prints PASS/FAIL per check; exits 1 on any failure.
set -euo pipefail

IFACE=${SMOKE_IFACE:-vcan0}
fails=0
pass() { echo "PASS: $*"; }
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
finish() {
  if [ "$fails" -eq 0 ]; then echo "smoke: all checks passed"; exit 0; fi
  echo "smoke: $fails check(s) failed"; exit 1
}

TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT

# ------------------------------------------------------------------ CAN stack
if [ -d /proc/net/can ] && [ -r /proc/net/can/stats ]; then
  pass "CAN stack loaded (/proc/net/can present)"
else
  fail "no /proc/net/can: kernel has no CAN support (running on the host instead of via tests/vm/run-in-vm.sh?)"
  finish
fi

# ------------------------------------------------------------------ vcan0
if link=$(ip -details link show "$IFACE" 2>&1); then
  flags=$(sed -n '1s/.*<\([^>]*\)>.*/\1/p' <<< "$link")
  if grep -qw vcan <<< "$link"; then pass "$IFACE is a vcan device"; else fail "$IFACE is not a vcan device: $link"; fi
  if [[ ",$flags," == *,UP,* ]]; then pass "$IFACE is UP ($flags)"; else fail "$IFACE is not UP: $link"; fi
else
  fail "$IFACE missing: $link"
  finish
fi

# ------------------------------------------------------------------ candump/cansend
for t in candump cansend; do
  command -v "$t" >/dev/null || { fail "$t not found (apt-get install can-utils, or tests/vm/setup-host.sh)"; finish; }
done

DUMP=$TMP/dump.txt
candump -n 3 "$IFACE" > "$DUMP" 2>&1 &
dump_pid=$!
# Wait until candump's receiver is registered (it shows up in the kernel's
# receive lists) rather than sleeping a fixed time; emulation is slow.
for _ in $(seq 100); do
  grep -Eq "^[[:space:]]+${IFACE}[[:space:]]" /proc/net/can/rcvlist_all 2>/dev/null && break
  sleep 0.05
done

FRAMES=("123#DEADBEEF" "123#E8030500" "123#01020304")
for f in "${FRAMES[@]}"; do
  cansend "$IFACE" "$f" || fail "cansend $IFACE $f"
done

for _ in $(seq 100); do kill -0 "$dump_pid" 2>/dev/null || break; sleep 0.05; done
if kill -0 "$dump_pid" 2>/dev/null; then
  kill "$dump_pid" 2>/dev/null || true
  fail "candump did not capture 3 frames within 5 s"
fi
wait "$dump_pid" 2>/dev/null || true

# candump's default format: "  vcan0  123   [4]  DE AD BE EF"
expected=$(printf '%s 123 [4] DE AD BE EF\n%s 123 [4] E8 03 05 00\n%s 123 [4] 01 02 03 04' "$IFACE" "$IFACE" "$IFACE")
got=$(tr -s ' \t' ' ' < "$DUMP" | sed 's/^ //;s/ $//')
if [ "$got" = "$expected" ]; then
  pass "candump captured the 3 frames sent with cansend"
else
  fail "candump output mismatch; expected:"$'\n'"$expected"$'\n'"got:"$'\n'"$got"
fi

# ------------------------------------------------------------------ cantools
PY=$(command -v python3 || true)
if [ -z "$PY" ]; then
  fail "python3 not found"
  finish
fi
cat > "$TMP/smoke.dbc" <<'EOF'
VERSION ""

NS_ :

BS_:

BU_: Bridge

BO_ 291 Smoke: 4 Bridge
 SG_ Speed : 0|16@1+ (0.1,0) [0|6553.5] "rpm" Vector__XXX
 SG_ Mode : 16|8@1+ (1,0) [0|255] "" Vector__XXX
EOF
# Decode the second *captured* frame (E8 03 05 00: Speed 0x03E8*0.1, Mode 5).
payload=$(sed -n '2p' "$DUMP" | sed 's/.*\] *//' | tr -d ' ')
if out=$("$PY" - "$TMP/smoke.dbc" "$payload" <<'EOF' 2>&1
import sys, cantools
db = cantools.database.load_file(sys.argv[1])
sig = db.decode_message(0x123, bytes.fromhex(sys.argv[2]))
assert abs(sig["Speed"] - 100.0) < 1e-9, sig
assert sig["Mode"] == 5, sig
print(f"Speed={sig['Speed']} Mode={sig['Mode']} (cantools {cantools.__version__})")
EOF
); then
  pass "cantools decoded captured frame '$payload': $out"
else
  fail "cantools decode of '$payload' failed: $out"
fi

finish

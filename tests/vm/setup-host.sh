#!/bin/bash
# tests/vm/setup-host.sh — idempotently install what the CAN tests need on the
# host (the guest chroots into the host root, so these are what it runs):
#   * apt: can-utils (candump/cansend/...), xz-utils (kernel extraction)
#   * pip: cantools (DBC decoding) and canopen (the independent CiA 402
#     drive of tests/can/cia402_drive.py), for the python3 found on PATH
#   * the VM assets: tests/vm/run-in-vm.sh --setup
# Run as root (CI does). Safe to re-run: each step is skipped when satisfied.
set -Eeuo pipefail
trap 'echo "setup-host: ERROR: failed (rc=$?) at line $LINENO: $BASH_COMMAND" >&2' ERR

SCRIPT_DIR=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd -P)
APT_PKGS=(can-utils xz-utils)

log() { echo "setup-host: $*"; }
now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$(now)" 'BEGIN{printf "%.1f", b-a}'; }
T_ALL=$(now)

# ------------------------------------------------------------------ apt
t=$(now)
missing=()
for p in "${APT_PKGS[@]}"; do
  [ "$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)" = "install ok installed" ] || missing+=("$p")
done
if [ "${#missing[@]}" -eq 0 ]; then
  log "apt: ${APT_PKGS[*]} already installed"
else
  # Update the lists only if apt cannot see an installable candidate.
  for p in "${missing[@]}"; do
    # (capture first: `apt-cache | grep -q` can fail with SIGPIPE under pipefail)
    policy=$(apt-cache policy "$p" 2>/dev/null || true)
    if ! grep -q 'Candidate: [^(]' <<< "$policy"; then
      log "apt: no candidate for $p in the package lists; running apt-get update"
      apt-get -q -o DPkg::Lock::Timeout=300 update
      break
    fi
  done
  log "apt: installing ${missing[*]}"
  DEBIAN_FRONTEND=noninteractive \
    apt-get -q -o DPkg::Lock::Timeout=300 install -y --no-install-recommends "${missing[@]}"
  log "apt: done in $(elapsed "$t") s"
fi

# ------------------------------------------------------------------ pip
t=$(now)
PY=$(command -v python3) || { echo "setup-host: ERROR: python3 not found on PATH" >&2; exit 1; }
if "$PY" -c 'import cantools' 2>/dev/null; then
  log "pip: cantools already importable by $PY"
else
  log "pip: installing cantools for $PY"
  "$PY" -m pip install --quiet cantools
  "$PY" -c 'import cantools' || { echo "setup-host: ERROR: cantools still not importable by $PY" >&2; exit 1; }
  log "pip: done in $(elapsed "$t") s"
fi
log "pip: cantools $("$PY" -c 'import cantools; print(cantools.__version__)')"
if "$PY" -c 'import canopen' 2>/dev/null; then
  log "pip: canopen already importable by $PY"
else
  log "pip: installing canopen for $PY"
  "$PY" -m pip install --quiet canopen
  "$PY" -c 'import canopen' || { echo "setup-host: ERROR: canopen still not importable by $PY" >&2; exit 1; }
fi
log "pip: canopen $("$PY" -c 'import canopen; print(canopen.__version__)')"

# ------------------------------------------------------------------ VM assets
t=$(now)
"$SCRIPT_DIR/run-in-vm.sh" --setup
log "vm assets: ready in $(elapsed "$t") s"

log "all done in $(elapsed "$T_ALL") s"

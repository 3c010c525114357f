#!/bin/bash
# tests/vm/run-in-vm.sh [--setup | --help | CMD [ARGS...]]
#
# Runs CMD once inside a throw-away QEMU guest booted from Debian's stock kernel
# (which has can, can-raw, can-bcm, can-gw, can-dev and vcan as modules), with
# vcan0 created and UP, and exits with CMD's exit status. The host kernel of
# the dev/CI machines has no CAN support at all, hence the VM.
#
# One boot per invocation: give it a test-group script to run many tests in a
# single boot (e.g. tests/vm/smoke.sh), or use it as a cargo runner (one boot
# per test binary):
#   CARGO_TARGET_X86_64_UNKNOWN_LINUX_GNU_RUNNER=$PWD/tests/vm/run-in-vm.sh cargo test
#
#  * host / is shared READ-ONLY over virtio-9p and the guest chroots into it,
#    so host binaries (cargo-built tests, candump/cansend, python3 + its
#    packages) run unchanged; /tmp, /run and /dev/shm are fresh guest tmpfs;
#  * the repo root (or OLDBF_VM_RW_DIRS) is shared READ-WRITE at the same path,
#    so target/ and test output written in the guest land on the host; the cwd
#    and CMD's directory are added automatically if they lie under /tmp, /run or
#    /dev/shm (which the guest would otherwise hide);
#  * the caller's exported environment and cwd are reproduced in the guest;
#    stdin is /dev/null; CMD's stdout+stderr come back merged on stdout (a
#    terminal in the guest only if the host's stdout is one).
#
# --setup only fetches/prepares the cached assets (kernel, busybox, and qemu
# if the host has none: ~90 MB of .debs via `apt-get download`, extracted with
# dpkg -x, nothing installed) and exits 0. Runs do this implicitly when needed.
#
# Knobs (environment):
#   OLDBF_VM_CACHE=$HOME/.cache/oldbf-vm  asset cache (flock-protected)
#   OLDBF_VM_TIMEOUT=300     seconds for the whole boot+CMD+poweroff
#   OLDBF_VM_RW_DIRS=<repo>  colon-separated dirs shared read-write
#   OLDBF_VM_VCAN=vcan0      space-separated vcan interfaces to create (UP)
#   OLDBF_VM_SMP=2  OLDBF_VM_MEM=512 (MiB)
#   OLDBF_VM_ACCEL=auto|kvm|tcg  (auto: KVM only with real kvm_intel/kvm_amd)
#   OLDBF_VM_CPU             default host (kvm) / max (tcg)
#   OLDBF_VM_MACHINE=pc|microvm  (microvm boots faster but may hang under load)
#   OLDBF_VM_VERBOSE=1       kernel messages + harness timings
#   OLDBF_VM_APPEND, OLDBF_VM_QEMU_EXTRA  extra kernel cmdline / qemu args
#   OLDBF_VM_PY_SHIMS=resolve|keep  if python3 is a pyenv shim, put the real
#                            interpreter's dir first on the guest PATH (saves
#                            ~6 s per python3 start under emulation)
#
# Exit status: CMD's status, or (with a "run-in-vm: ERROR" line on stderr)
#   2 usage, 100 guest setup failed (module, 9p mount, vcan), 101 asset fetch
#   failed, 102 guest died without reporting a status, 103 timeout.
# Needs: Debian/Ubuntu host with apt, xz, GNU grep, flock; run as root (as CI
# does) so the 9p view of / is complete.
set -Eeuo pipefail
# Never die silently: name the command that tripped `set -e`.
trap 'echo "run-in-vm: ERROR: unexpected failure (rc=$?) at line $LINENO: $BASH_COMMAND" >&2' ERR

SCRIPT_DIR=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd -P)
REPO_ROOT=$(git -C "$SCRIPT_DIR" rev-parse --show-toplevel 2>/dev/null ||
            (cd "$SCRIPT_DIR/../.." && pwd -P))

CACHE=${OLDBF_VM_CACHE:-$HOME/.cache/oldbf-vm}
TIMEOUT=${OLDBF_VM_TIMEOUT:-300}
RW_DIRS=${OLDBF_VM_RW_DIRS:-$REPO_ROOT}
VCAN=${OLDBF_VM_VCAN:-vcan0}
SMP=${OLDBF_VM_SMP:-2}
MEM=${OLDBF_VM_MEM:-512}
MACHINE=${OLDBF_VM_MACHINE:-pc}
ROOT=$CACHE/root
# Load order matters: virtio transport before 9p; 9p needs netfs+fscache;
# vcan needs can-dev. The kernel .deb ships no usable modules.dep for insmod.
MODS=(virtio_ring virtio virtio_mmio virtio_pci_modern_dev virtio_pci_legacy_dev virtio_pci
      9pnet 9pnet_virtio netfs fscache 9p
      can can-raw can-bcm can-gw can-dev vcan)
# Bump to force every cache to be rebuilt when the asset recipe changes.
ASSET_KEY="oldbf-vm-assets-v1 ${MODS[*]}"

log() { echo "run-in-vm: $*" >&2; }
die() { local rc=$1; shift; echo "run-in-vm: ERROR: $*" >&2; exit "$rc"; }
now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$(now)" 'BEGIN{printf "%.1f", b-a}'; }

usage() { sed -n '2,/^set -/{/^set -/d;s/^# \{0,1\}//;p}' "${BASH_SOURCE[0]}"; }

# ------------------------------------------------------------------ 1. assets
apt_kernel_pkg() {
  apt-cache depends linux-image-amd64 2>/dev/null |
    awk '/Depends: linux-image-[0-9]/ && !n++ {print $2}' || true  # no early awk exit: SIGPIPE
}

apt_update() {
  log "$1: running 'apt-get update'"
  apt-get -q -o DPkg::Lock::Timeout=300 update >&2 ||
    die 101 "'apt-get update' failed (not root? no network to the Debian mirror?). Run 'apt-get update' as root, then retry."
}

fetch_assets() {
  local t0 tmp kpkg pkgs=() extra d vmlinuz off
  t0=$(now)
  command -v apt-get >/dev/null || die 101 "apt-get not found: the harness needs a Debian/Ubuntu host"
  command -v xz >/dev/null || die 101 "xz not found: apt-get install xz-utils (or run tests/vm/setup-host.sh)"
  log "fetching guest kernel/busybox/qemu into $CACHE (one-time, ~90 MB)"
  tmp=$CACHE/.build
  rm -rf "$tmp" "$ROOT" "$CACHE/.ready"
  mkdir -p "$tmp/debs" "$tmp/root"

  kpkg=$(apt_kernel_pkg)
  if [ -z "$kpkg" ]; then
    apt_update "apt package lists are missing (cannot resolve linux-image-amd64)"
    kpkg=$(apt_kernel_pkg)
    [ -n "$kpkg" ] || die 101 "apt cannot resolve linux-image-amd64 even after 'apt-get update'; is this a Debian amd64 host?"
  fi
  pkgs=("$kpkg" busybox-static)
  if ! command -v qemu-system-x86_64 >/dev/null; then
    # qemu-system-x86 + those of its deps not installed yet. Extracted, never
    # installed: installing bookworm's qemu 7.2 would REMOVE a newer qemu-utils
    # (bookworm-backports) present on the CI image.
    mapfile -t extra < <(apt-get install -s --no-install-recommends qemu-system-x86 2>/dev/null |
                         awk '/^Inst /{print $2}' | grep -vx busybox-static || true)
    [ "${#extra[@]}" -gt 0 ] || die 101 "apt cannot resolve qemu-system-x86 (apt-get install -s qemu-system-x86 lists nothing to fetch)"
    pkgs+=("${extra[@]}")
  fi
  # Stale lists point at superseded versions (404): update once and retry.
  if ! (cd "$tmp/debs" && apt-get -q -o APT::Sandbox::User=root download "${pkgs[@]}" >&2); then
    apt_update "'apt-get download' failed (stale or missing package lists?)"
    kpkg=$(apt_kernel_pkg); pkgs[0]=$kpkg
    (cd "$tmp/debs" && apt-get -q -o APT::Sandbox::User=root download "${pkgs[@]}" >&2) ||
      die 101 "'apt-get download ${pkgs[*]}' failed even after 'apt-get update' (network to the Debian mirror?)"
  fi
  for d in "$tmp"/debs/*.deb; do dpkg -x "$d" "$tmp/root" || die 101 "dpkg -x $d failed"; done
  rm -rf "$tmp/debs"

  # Debian's bzImage is XZ-compressed; decompressing it under TCG costs
  # seconds. Extract the ELF vmlinux once: QEMU boots it via PVH (CONFIG_PVH=y).
  vmlinuz=$(echo "$tmp"/root/boot/vmlinuz-*)
  [ -f "$vmlinuz" ] || die 101 "no /boot/vmlinuz-* in $kpkg"
  off=$(LC_ALL=C grep -m1 -obUaP '\xfd7zXZ\x00' "$vmlinuz" | cut -d: -f1)
  [ -n "$off" ] || die 101 "no XZ payload found in $vmlinuz"
  tail -c +$((off + 1)) "$vmlinuz" > "$tmp/vmlinux.xz"   # no pipe: xz stops early -> SIGPIPE
  xz -dc --single-stream "$tmp/vmlinux.xz" > "$tmp/vmlinux" || die 101 "cannot decompress the kernel"
  rm -f "$tmp/vmlinux.xz"
  [ "$(head -c 4 "$tmp/vmlinux" | od -An -c | tr -d ' ')" = '177ELF' ] ||
    die 101 "decompressed kernel is not an ELF vmlinux"

  # Base initramfs: busybox + the modules (the per-run archive adds /init etc.)
  local ir=$tmp/ir kdir f m
  kdir=$(echo "$tmp"/root/lib/modules/*/kernel)
  mkdir -p "$ir"/{bin,proc,sys,dev,host,mods}
  cp "$tmp/root/bin/busybox" "$ir/bin/"
  for m in "${MODS[@]}"; do
    f=$(find "$kdir" \( -name "$m.ko" -o -name "$m.ko.xz" \) -print -quit)
    [ -n "$f" ] || die 101 "kernel module $m not found in $kpkg"
    case $f in
      *.xz) xz -dc "$f" > "$ir/mods/$m.ko" ;;
      *)    cp "$f" "$ir/mods/" ;;
    esac
  done
  printf '%s\n' "${MODS[@]}" > "$ir/mods/order"
  (cd "$ir" && find . | "$tmp/root/bin/busybox" cpio -o -H newc 2>/dev/null | gzip -1) > "$tmp/base.cpio.gz"
  rm -rf "$ir" "$tmp"/root/lib/modules "$tmp"/root/boot "$tmp"/root/usr/share/doc  # ~400 MB not needed

  mv "$tmp/root" "$ROOT"
  mv "$tmp/vmlinux" "$tmp/base.cpio.gz" "$CACHE/"
  rm -rf "$tmp"
  echo "$ASSET_KEY" > "$CACHE/.ready"
  log "assets ready in $CACHE ($(du -sh "$CACHE" | cut -f1), $(elapsed "$t0") s)"
}

# Check/build the cache under an exclusive lock, then keep a shared lock for
# the rest of this process so a concurrent rebuild never pulls it from under a
# running guest.
setup_assets() {
  mkdir -p "$CACHE" || die 101 "cannot create cache dir $CACHE"
  exec 9>"$CACHE/.lock"
  flock 9
  if [ "$(cat "$CACHE/.ready" 2>/dev/null || true)" != "$ASSET_KEY" ]; then
    fetch_assets
  fi
  flock -s 9
  if command -v qemu-system-x86_64 >/dev/null; then
    QEMU=(qemu-system-x86_64)
  elif [ -x "$ROOT/usr/bin/qemu-system-x86_64" ]; then
    QEMU=(env "LD_LIBRARY_PATH=$ROOT/usr/lib/x86_64-linux-gnu:$ROOT/lib/x86_64-linux-gnu"
          "$ROOT/usr/bin/qemu-system-x86_64" -L "$ROOT/usr/share/seabios" -L "$ROOT/usr/share/qemu")
  else
    die 101 "no qemu-system-x86_64 on the host nor in $CACHE (the host had one when the cache was built?); remove $CACHE/.ready and retry"
  fi
  "${QEMU[@]}" --version >/dev/null 2>&1 || die 101 "${QEMU[*]} does not run (missing libraries?); remove $CACHE/.ready and retry"
}

case ${1:-} in
  -h|--help) usage; exit 0 ;;
  --setup)   setup_assets; log "setup OK: $CACHE"; exit 0 ;;
  "")        usage >&2; exit 2 ;;
  -*)        die 2 "unknown option $1 (try --help)" ;;
esac

T0=$(now)
setup_assets
[ -n "${OLDBF_VM_VERBOSE:-}" ] && log "assets checked in $(elapsed "$T0") s"

# ------------------------------------------------------------------ 2. per-run initramfs
WORK=$(mktemp -d "${TMPDIR:-/tmp}/oldbf-vm.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
IR=$WORK/ir
mkdir -p "$IR"

# RW dirs: the configured list, plus cwd / CMD's dir if the guest tmpfs would
# hide them. Nested or duplicate entries are dropped (the outer share has them).
rw=()
covered() { local x; for x in "${rw[@]}"; do case $1/ in "$x"/*) return 0 ;; esac; done; return 1; }
add_rw() {
  local d
  d=$(realpath -e "$1" 2>/dev/null) || die 2 "read-write dir '$1' does not exist"
  [ -d "$d" ] || die 2 "read-write dir '$d' is not a directory"
  [ "$d" != / ] || die 2 "refusing to share / read-write"
  covered "$d" || rw+=("$d")
}
IFS=: read -r -a cfg_rw <<< "$RW_DIRS"
for d in "${cfg_rw[@]}"; do [ -z "$d" ] || add_rw "$d"; done
hidden_candidates=("$PWD")
case $1 in */*) hidden_candidates+=("$(dirname "$1")") ;; esac
for d in "${hidden_candidates[@]}"; do
  d=$(realpath -e "$d" 2>/dev/null) || continue
  case $d/ in /tmp/*|/run/*|/dev/shm/*) covered "$d" || add_rw "$d" ;; esac
done

# pyenv-style shims re-resolve the interpreter with a dozen forks on every
# call: ~6 s per python3 start under emulation. Resolve it once here (same cwd,
# so the same .python-version applies) and put the real bin dir first on PATH.
PY_PATH=
py=$(command -v python3 || true)
if [ -n "$py" ] && [ "${OLDBF_VM_PY_SHIMS:-resolve}" = resolve ] && [[ $py == */shims/* ]]; then
  real=$("$py" -c 'import sys; print(sys.executable)' 2>/dev/null || true)
  [ -x "$real" ] && PY_PATH=$(dirname "$real")
fi
{
  export -p | grep -vE '^declare -x (OLDPWD|SHLVL|_)=' || true
  # shellcheck disable=SC2016 # $PATH must expand in the guest
  [ -z "$PY_PATH" ] || printf 'export PATH=%q:"$PATH"\n' "$PY_PATH"
  printf 'cd %q || { echo "run-in-vm: cannot cd to %q in the guest" >&2; exit 97; }\n' "$PWD" "$PWD"
  printf 'exec'; printf ' %q' "$@"; printf '\n'
} > "$IR/cmd.sh"
echo "$VCAN" > "$IR/vcan"
printf '%s\n' "${rw[@]}" > "$IR/rw_dirs"
if [ -t 1 ]; then : > "$IR/stdout_is_tty"; fi

cat > "$IR/init" <<'EOF'
#!/bin/busybox sh
/bin/busybox --install -s /bin
export PATH=/bin
mount -t proc proc /proc; mount -t sysfs sys /sys; mount -t devtmpfs dev /dev
fail() { echo "@@VM_FAIL=$*@@"; poweroff -f; sleep 30; }
for m in $(cat /mods/order); do
  [ -e "/mods/$m.ko" ] || fail "module $m missing from the initramfs"
  insmod "/mods/$m.ko" || fail "insmod $m failed"
done
[ -d /proc/net/can ] || fail "no /proc/net/can after loading the CAN modules"
o=trans=virtio,version=9p2000.L,msize=512000
mount -t 9p -o $o,cache=loose,ro hostroot /host || fail "9p mount of host / failed"
mount -t proc proc /host/proc || fail "mount /proc"
mount -t sysfs sys /host/sys || fail "mount /sys"
mount -t devtmpfs dev /host/dev || fail "mount /dev"
mkdir -p /host/dev/pts /host/dev/shm
mount -t devpts devpts /host/dev/pts
mount -t tmpfs tmp /host/dev/shm
mount -t tmpfs -o mode=1777 tmp /host/tmp || fail "mount /tmp"
mount -t tmpfs run /host/run || fail "mount /run"
i=0
while read -r d; do
  [ -n "$d" ] || continue
  mkdir -p "/host$d" && mount -t 9p -o $o "rw$i" "/host$d" || fail "9p mount of $d failed"
  i=$((i+1))
done < /rw_dirs
ip link set lo up
for c in $(cat /vcan); do
  { ip link add dev "$c" type vcan && ip link set "$c" up; } || fail "creating $c failed"
done
cp /cmd.sh /host/run/vm-cmd.sh
[ -x /host/bin/bash ] || fail "no /bin/bash in the host root"
if [ -e /stdout_is_tty ]; then
  chroot /host /bin/bash /run/vm-cmd.sh </dev/null
  rc=$?
else  # host output is not a terminal: don't let CMD see one (no colours etc.)
  { chroot /host /bin/bash /run/vm-cmd.sh </dev/null 2>&1; echo $? > /rc; } | cat
  rc=$(cat /rc 2>/dev/null || echo 99)
fi
echo "@@VM_EXIT=$rc@@"
poweroff -f
EOF
chmod +x "$IR/init"
# The uncompressed per-run archive must come first, then the gzipped base.
(cd "$IR" && find . | "$ROOT/bin/busybox" cpio -o -H newc 2>/dev/null) > "$WORK/run.cpio"
cat "$WORK/run.cpio" "$CACHE/base.cpio.gz" > "$WORK/initrd"

# ------------------------------------------------------------------ 3. boot
XAPPEND=
case $MACHINE in
  pc)      M=(-M pc);      VDEV=virtio-9p-pci ;;
  # microvm (virtio-mmio, no SeaBIOS/PCI) saves ~0.5-1 s but has no HPET/PM
  # timer: under TCG + host load the PIT TSC calibration fails and the guest
  # hangs at boot unless the TSC rate is given (TCG guest TSC = host TSC).
  microvm) M=(-M microvm); VDEV=virtio-9p-device
           XAPPEND="tsc_early_khz=$(awk -F: '/^cpu MHz/{printf "%d", $2*1000; exit}' /proc/cpuinfo)" ;;
  *) die 2 "bad OLDBF_VM_MACHINE=$MACHINE (pc|microvm)" ;;
esac
VIRTFS=(-fsdev "local,id=fs0,path=/,security_model=none,readonly=on,multidevs=remap"
        -device "$VDEV,fsdev=fs0,mount_tag=hostroot")
for i in "${!rw[@]}"; do
  VIRTFS+=(-fsdev "local,id=fs$((i+1)),path=${rw[$i]},security_model=none,multidevs=remap"
           -device "$VDEV,fsdev=fs$((i+1)),mount_tag=rw$i")
done

ACCEL=${OLDBF_VM_ACCEL:-auto}
if [ "$ACCEL" = auto ]; then
  ACCEL=tcg
  # Some CI images expose /dev/kvm backed by kvm_pvm (software nested virt, no
  # VMX/SVM): a stock kernel crawls for >60 s, then dies with "KVM internal
  # error ... emulation failure". Only use KVM with kvm_intel/kvm_amd loaded.
  if [ -w /dev/kvm ] && { [ -d /sys/module/kvm_intel ] || [ -d /sys/module/kvm_amd ]; }; then ACCEL=kvm; fi
fi
case $ACCEL in
  kvm) ACC=(-accel kvm -cpu "${OLDBF_VM_CPU:-host}") ;;
  tcg) ACC=(-accel "tcg,thread=multi" -cpu "${OLDBF_VM_CPU:-max}") ;;
  *) die 2 "bad OLDBF_VM_ACCEL=$ACCEL (auto|kvm|tcg)" ;;
esac
KLOG="quiet loglevel=1"; [ -n "${OLDBF_VM_VERBOSE:-}" ] && KLOG="loglevel=7"
read -r -a QEXTRA <<< "${OLDBF_VM_QEMU_EXTRA:-}"

[ -n "${OLDBF_VM_VERBOSE:-}" ] && log "booting ($ACCEL, $MACHINE, rw: ${rw[*]:-none}) after $(elapsed "$T0") s"
set +e; trap - ERR
timeout --foreground -k 5 "$TIMEOUT" "${QEMU[@]}" "${ACC[@]}" \
  "${M[@]}" -m "$MEM" -smp "$SMP" -nodefaults -no-user-config -display none \
  -serial stdio -no-reboot \
  -kernel "$CACHE/vmlinux" -initrd "$WORK/initrd" \
  -append "console=ttyS0 $KLOG panic=-1 mitigations=off tsc=reliable 8250.nr_uarts=1 $XAPPEND ${OLDBF_VM_APPEND:-}" \
  "${VIRTFS[@]}" "${QEXTRA[@]}" </dev/null 9>&- 2>&1 |
  sed -u 's/\r$//' | tee "$WORK/console.log" |
  sed -u -e '/^@@VM_[A-Z]*=[^@]*@@$/d' -e 's/@@VM_[A-Z]*=[^@]*@@$//' \
         -e '/^\[ *[0-9.]*\] reboot: Power down$/d'
qrc=${PIPESTATUS[0]}
set -e
[ -n "${OLDBF_VM_VERBOSE:-}" ] && log "guest done after $(elapsed "$T0") s (qemu rc=$qrc)"

fail_msg=$(grep -ao '@@VM_FAIL=[^@]*@@' "$WORK/console.log" | tail -1 || true)
if [ -n "$fail_msg" ]; then
  fail_msg=${fail_msg#@@VM_FAIL=}
  die 100 "guest setup failed: ${fail_msg%@@}"
fi
rc=$(grep -ao '@@VM_EXIT=[0-9]*@@' "$WORK/console.log" | tail -1 | tr -dc 0-9 || true)
if [ -n "$rc" ]; then
  exit "$rc"
fi
case $qrc in
  124|137) die 103 "timed out after ${TIMEOUT}s (OLDBF_VM_TIMEOUT); CMD: $*" ;;
  0) die 102 "guest powered off without reporting CMD's exit status (kernel panic? rerun with OLDBF_VM_VERBOSE=1)" ;;
  *) die 102 "qemu failed (rc=$qrc) before the guest reported CMD's exit status; rerun with OLDBF_VM_VERBOSE=1" ;;
esac

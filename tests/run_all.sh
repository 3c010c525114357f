#!/usr/bin/env bash
# tests/run_all.sh: the README test command (and what .ci/run runs).
#
# Installs what the tests need, idempotently, then runs every test group and
# prints a timing table. Any failure, or a missing component a group needs,
# makes the script exit non-zero: nothing is skipped silently.
#
#   tests/run_all.sh            all groups
#   tests/run_all.sh GROUP...   some of: lint rust run soak fuzz ros can e2e faults
#
# Groups
#   lint  cargo fmt --check (also fuzz/); cargo clippy --all-targets -D warnings (with and without the
#         ros/socketcan features, and the ROS-only build); the core and the ROS-only build free of
#         the evaluation and adapter dependencies (cargo tree)
#   rust  unit, property, closed-loop scenario, real-data (CARMEN log),
#         zero-allocation and CLI tests: cargo test --release --workspace
#   run   the README run command (the paper_line scenario), outputs checked
#   ros   the ROS 1 nodes against Debian's real ROS tools (tests/ros_group.sh:
#         installs the ROS packages and catkin, roscore on a private port,
#         launch files, rosbag, latency, dynamic_reconfigure, a fresh catkin
#         workspace, rviz under Xvfb)
#   can   the CAN bridge in a real Linux kernel: one QEMU guest boot with
#         vcan0 (this machine's kernel has no CAN) runs the vcan test
#         groups, the candump + python cantools decoding checks and the
#         cia402 protocol against python-canopen CiA 402 drives
#         (tests/can_group.sh; installs can-utils, cantools, canopen, the guest kernel)
#   e2e   one guest boot: roscore + simulator + filter + CAN bridge + virtual
#         drive on vcan0, the loop closed through CAN, generic then cia402
#         (tests/e2e_group.sh)
#   soak  the short soak: random worlds with moving obstacles for a stretch of
#         simulated time; no panic, no NaN, live heap flat
#         (tests/soak_group.sh; the full hour is `oldbf soak`, see docs/SAFETY.md)
#   fuzz  every fuzz target's committed corpus replayed, then a time-boxed
#         coverage-guided run of each, one per core at a time
#         (tests/fuzz_group.sh; installs cargo-fuzz)
#   faults  one guest boot: faults injected into the running ROS + CAN system,
#         each timed from fault to zero setpoints on vcan0 (tests/faults_group.sh)
#
# With ros in the run, lint and soak run beside it, in the background at idle
# priority (see "Groups beside ros" below; OLDBF_BESIDE_ROS=0: in turn).
#
# Needs: a Rust toolchain >= 1.85 (rustup) and, for `vcan`, root for apt.
set -Eeuo pipefail
trap 'echo "run_all: ERROR at line $LINENO: $BASH_COMMAND" >&2' ERR

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd -P)
cd "$ROOT"
export CARGO_TERM_COLOR=${CARGO_TERM_COLOR:-never}

ALL_GROUPS=(lint rust run soak fuzz ros can e2e faults)
# Groups that can be named but are not in the default run.
EXTRA_GROUPS=()
GROUPS_TO_RUN=("$@")
[ ${#GROUPS_TO_RUN[@]} -gt 0 ] || GROUPS_TO_RUN=("${ALL_GROUPS[@]}")

say() { printf '\n=== %s\n' "$*"; }
die() { echo "run_all: $*" >&2; exit 1; }
now() { date +%s; }

need_cargo() {
  command -v cargo >/dev/null || die "cargo not found. Install Rust >= 1.85 with rustup (https://rustup.rs): Debian's own cargo is too old."
  local v
  v=$(rustc --version | awk '{print $2}')
  # Compare major.minor with 1.85.
  awk -v v="$v" 'BEGIN{split(v,a,"."); exit !((a[1]>1)||(a[1]==1&&a[2]>=85))}' \
    || die "rustc $v is older than 1.85 (rustup update)"
}

group_lint() {
  need_cargo
  cargo fmt --all -- --check
  # The fuzz crate is its own workspace (cargo-fuzz), outside --all.
  (cd fuzz && cargo fmt -- --check)
  cargo clippy --workspace --all-targets --locked --release -- -D warnings
  cargo clippy --workspace --all-targets --locked --release --all-features -- -D warnings
  # The ROS nodes alone, without the evaluation tree (what can_bridge's node links).
  cargo clippy -p oldbf_ros --lib --bins --locked --release --no-default-features --features ros -- -D warnings
  # What the compiler must keep out: of the core, anything but the pure math;
  # of the ROS-only build, the evaluation dependencies.
  local banned
  banned=$(cargo tree -p oldbf -e normal --locked --prefix none \
    | grep -E '^(rosrust|socketcan|plotters|clarabel|dodgy_2d|rayon|clap|indicatif) ' || true)
  [ -z "$banned" ] || die "the core crate oldbf depends on: $banned"
  banned=$(cargo tree -p oldbf_ros -e normal --locked --prefix none --no-default-features --features ros \
    | grep -E '^(plotters|clarabel|dodgy_2d|rayon|clap|indicatif) ' || true)
  [ -z "$banned" ] || die "oldbf_ros --features ros (no eval) depends on: $banned"
}

group_rust() {
  need_cargo
  cargo test --workspace --locked --release
}

group_run() {
  need_cargo
  local out="$ROOT/out/paper_line"
  rm -rf "$out"
  mkdir -p "$ROOT/out"
  # Exactly the README run command.
  cargo run --release --locked --bin oldbf -- sim config/scenarios/paper_line.yaml --out out/paper_line | tee "$ROOT/out/paper_line.log"
  grep -q "collisions 0 " "$ROOT/out/paper_line.log" || die "the main job reported collisions"
  grep -q "goal reached" "$ROOT/out/paper_line.log" || die "the main job did not reach its goal"
  for f in steps.csv summary.json trajectory.png trajectory.svg barriers.png barriers.svg velocities.png velocities.svg; do
    [ -s "$out/$f" ] || die "the main job did not write $f"
  done
}

group_ros() {
  need_cargo
  "$ROOT/tests/ros_group.sh"
}

group_can() {
  need_cargo
  "$ROOT/tests/vm/setup-host.sh"
  "$ROOT/tests/can_group.sh"
}

group_e2e() {
  need_cargo
  "$ROOT/tests/e2e_group.sh"
}

group_soak() {
  need_cargo
  "$ROOT/tests/soak_group.sh"
}

group_fuzz() {
  need_cargo
  "$ROOT/tests/fuzz_group.sh"
}

group_faults() {
  need_cargo
  "$ROOT/tests/faults_group.sh"
}

declare -A TOOK
FAILED=()
GROUP_LOGS=$ROOT/target/test-logs
mkdir -p "$GROUP_LOGS"
selected() { case " ${GROUPS_TO_RUN[*]} " in *" $1 "*) return 0 ;; esac; return 1; }

# Groups beside ros. lint and soak are pure computation: clippy's verdict and
# the soak's figures (which depend only on template, seed and hours) do not
# depend on how fast they run. The ros group spends most of its time waiting
# on real-time ROS runs, with the CPU nearly idle (0.1-0.4 of a core). So
# when ros runs, lint and soak (those of them selected) run one after the
# other in the background while it does, under SCHED_IDLE: they get only CPU
# time that nothing else wants, and a ROS process that wakes up preempts them
# at once, so the ros group runs as if alone. lint uses its own target dir
# (target/lint: clippy shares no build with the tests), so its cargo lock
# never holds up the ros group's builds; the soak runs a copy of its binary
# made before ros starts. Each keeps its own log, shown after ros's, and
# passes or fails on its own, as when run alone. If they have not finished
# when ros does, the run waits for them before the next group.
# OLDBF_BESIDE_ROS=0 runs them in their turn instead.
BESIDE_ROS=()
if selected ros && [ "${OLDBF_BESIDE_ROS:-1}" = 1 ]; then
  for g in lint soak; do selected "$g" && BESIDE_ROS+=("$g"); done
fi
BG_PID=
start_beside() { # the groups of BESIDE_ROS, one after the other, in the background at idle priority
  local g
  say "groups ${BESIDE_ROS[*]}: started beside ros, at idle priority (SCHED_IDLE); their output follows ros's"
  for g in "${BESIDE_ROS[@]}"; do : > "$GROUP_LOGS/$g.log"; rm -f "$GROUP_LOGS/$g.status"; done
  if selected soak; then
    # The soak's binary is built now and copied: the ros group's builds link
    # target/release/oldbf to its ROS build (carmen-play needs it), which a
    # cargo build in the soak group would undo under the ros group's feet.
    # (If this fails, the soak group builds, and fails, on its own.)
    if ( need_cargo && cargo build --release --locked --bin oldbf && mkdir -p "$ROOT/target/soak" \
         && cp "${CARGO_TARGET_DIR:-$ROOT/target}/release/oldbf" "$ROOT/target/soak/oldbf" ) > "$GROUP_LOGS/soak.log" 2>&1; then
      export OLDBF_SOAK_BIN=$ROOT/target/soak/oldbf
    fi
  fi
  (
    set +e
    chrt --idle -p 0 "$BASHPID" > /dev/null 2>&1 || renice -n 19 -p "$BASHPID" > /dev/null
    for g in "${BESIDE_ROS[@]}"; do
      t0=$(now)
      if [ "$g" = lint ]; then
        ( set -e; export CARGO_TARGET_DIR=$ROOT/target/lint; "group_$g" ) >> "$GROUP_LOGS/$g.log" 2>&1
      else
        ( set -e; "group_$g" ) >> "$GROUP_LOGS/$g.log" 2>&1
      fi
      echo "$? $(( $(now) - t0 ))" > "$GROUP_LOGS/$g.status"
    done
  ) &
  BG_PID=$!
}
finish_beside() { # waits for the groups beside ros; shows their output, records their status
  local g rc took t0
  t0=$(now)
  wait "$BG_PID" || true
  [ "$(( $(now) - t0 ))" -lt 2 ] || say "waited $(( $(now) - t0 )) s after ros for: ${BESIDE_ROS[*]}"
  for g in "${BESIDE_ROS[@]}"; do
    say "group $g (ran beside ros)"
    cat "$GROUP_LOGS/$g.log"
    read -r rc took < "$GROUP_LOGS/$g.status" || { rc=1; took=0; }
    if [ "$rc" -eq 0 ]; then status=ok; else status="FAILED (exit $rc)"; FAILED+=("$g"); fi
    TOOK[$g]="$status $took s (beside ros)"
  done
}

for g in "${GROUPS_TO_RUN[@]}"; do
  case " ${ALL_GROUPS[*]} ${EXTRA_GROUPS[*]} " in *" $g "*) ;; *) die "unknown group '$g' (groups: ${ALL_GROUPS[*]} ${EXTRA_GROUPS[*]})" ;; esac
  if [ ${#BESIDE_ROS[@]} -gt 0 ] && [[ " ${BESIDE_ROS[*]} " == *" $g "* ]]; then say "group $g: runs beside ros (below)"; continue; fi
  [ "$g" != ros ] || [ ${#BESIDE_ROS[@]} -eq 0 ] || start_beside
  say "group $g"
  t0=$(now)
  # Not `if ( … )`: errexit is ignored in a condition, even inside the function.
  set +e
  # Each group's output is also kept, so the summary can repeat why it failed
  # (a CI log is often read from its tail).
  ( set -e; "group_$g" ) 2>&1 | tee "$GROUP_LOGS/$g.log"
  rc=${PIPESTATUS[0]}
  set -e
  if [ "$rc" -eq 0 ]; then status=ok; else status="FAILED (exit $rc)"; FAILED+=("$g"); fi
  TOOK[$g]="$status $(( $(now) - t0 )) s"
  [ "$g" != ros ] || [ ${#BESIDE_ROS[@]} -eq 0 ] || finish_beside
done

say "summary"
for g in "${GROUPS_TO_RUN[@]}"; do printf '  %-6s %s\n' "$g" "${TOOK[$g]}"; done
if [ ${#FAILED[@]} -gt 0 ]; then
  for g in "${FAILED[@]}"; do
    say "why $g failed (the lines that say so, from $GROUP_LOGS/$g.log)"
    grep -E 'FAIL|[Ff]ailed|check failed|panicked|error(\[|:)|ERROR|Traceback|timed out|no summary' "$GROUP_LOGS/$g.log" | tail -25 || true
    echo "  -- last lines:"
    tail -15 "$GROUP_LOGS/$g.log"
  done
  echo "run_all: FAILED groups: ${FAILED[*]}" >&2
  exit 1
fi
echo "run_all: all groups passed"

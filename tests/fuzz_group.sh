#!/usr/bin/env bash
# tests/fuzz_group.sh: the fuzz targets of fuzz/ (cargo-fuzz, libFuzzer) as
# regression tests.
#
#   1. installs cargo-fuzz (pinned) if missing, builds every target once;
#   2. replays every committed input (fuzz/corpus/<target>/ and
#      fuzz/regressions/<target>/) through its target: any crash fails;
#   3. a time-boxed coverage-guided run of each target (FUZZ_SMOKE_S
#      seconds, default 15), new inputs to a scratch dir (the committed
#      corpus is not modified). A crash fails and leaves the input under
#      fuzz/artifacts/<target>/.
# Steps 2 and 3 run one target per core at a time (FUZZ_JOBS, default
# nproc): a libFuzzer run uses one core, so each target keeps a whole core
# for its smoke seconds, and the group takes half the time on 2 cores.
#
# The stable toolchain builds the targets with RUSTC_BOOTSTRAP=1 (cargo-fuzz
# passes nightly-only -Z flags). No sanitizer (-s none): the code under test
# is safe Rust, and the build is the slow part of this group.
#
#   tests/fuzz_group.sh                 everything
#   FUZZ_SMOKE_S=0 tests/fuzz_group.sh  replay only
#   FUZZ_TARGETS="config_parse" ...     some targets
#   FUZZ_JOBS=1 tests/fuzz_group.sh     one target at a time
set -Eeuo pipefail
trap 'echo "fuzz_group: ERROR at line $LINENO: $BASH_COMMAND" >&2' ERR

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd -P)
FUZZ="$ROOT/fuzz"
CARGO_FUZZ_VERSION=0.13.1
SMOKE_S=${FUZZ_SMOKE_S:-15}
read -r -a TARGETS <<< "${FUZZ_TARGETS:-scan_pipeline carmen_parse can_decode_generic can_decode_odrive can_decode_cia402 config_parse}"

die() { echo "fuzz_group: $*" >&2; exit 1; }
t0=$(date +%s)

# 1. Tools and build.
command -v cargo > /dev/null || die "cargo not found (install Rust with rustup)"
command -v c++ > /dev/null || die "no C++ compiler: libfuzzer-sys builds libFuzzer from source (apt-get install g++)"
if ! cargo fuzz --version 2> /dev/null | grep -q " $CARGO_FUZZ_VERSION\$"; then
  echo "fuzz_group: installing cargo-fuzz $CARGO_FUZZ_VERSION"
  cargo install cargo-fuzz --locked --version "$CARGO_FUZZ_VERSION" \
    || die "cannot install cargo-fuzz $CARGO_FUZZ_VERSION"
fi
export RUSTC_BOOTSTRAP=1
cd "$FUZZ"
cargo fuzz build -s none || die "the fuzz targets do not build"
HOST=$(rustc -vV | sed -n 's/^host: //p')
BIN="$FUZZ/target/$HOST/release"
t_built=$(date +%s)
echo "fuzz_group: built in $((t_built - t0)) s"

# libFuzzer's final stats of one run: "execs cov ft" (cov/ft from the last status line).
stats() {
  local log=$1 execs cov ft
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | awk '{print $2}')
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | awk '{print $2}')
  echo "${execs:-?} ${cov:-?} ${ft:-?}"
}

SCRATCH=$(mktemp -d)
trap 'rm -rf "$SCRATCH"' EXIT
# One target: replay, then smoke; its table row to $SCRATCH/$t.row. Run in a
# subshell, so `die` ends only this target's run.
one_target() {
  local t=$1 corpus n_corpus log done_runs ran execs cov ft
  local -a inputs regress
  [ -x "$BIN/$t" ] || die "target $t was not built ($BIN/$t)"
  corpus="$FUZZ/corpus/$t"
  [ -d "$corpus" ] && [ -n "$(ls -A "$corpus")" ] || die "no committed corpus for $t ($corpus)"

  # 2. Replay: every committed input once (-runs=0: no mutation).
  inputs=("$corpus")
  regress=()
  if [ -d "$FUZZ/regressions/$t" ]; then
    mapfile -t regress < <(find "$FUZZ/regressions/$t" -type f | sort)
  fi
  n_corpus=$(find "$corpus" -type f | wc -l)
  log="$SCRATCH/$t.replay.log"
  if ! "$BIN/$t" -runs=0 -timeout=20 "${inputs[@]}" > "$log" 2>&1; then
    tail -40 "$log"
    die "$t: a committed corpus input fails (log above)"
  fi
  done_runs=$(sed -n 's/^Done \([0-9]*\) runs.*/\1/p' "$log")
  [ "${done_runs:-0}" -ge "$n_corpus" ] || { tail -20 "$log"; die "$t: replayed ${done_runs:-0} of $n_corpus corpus inputs"; }
  if [ ${#regress[@]} -gt 0 ]; then
    if ! "$BIN/$t" -timeout=20 "${regress[@]}" > "$log.regress" 2>&1; then
      tail -40 "$log.regress"
      die "$t: a regression input fails again (log above)"
    fi
    ran=$(grep -c '^Executed ' "$log.regress" || true)
    [ "$ran" -eq ${#regress[@]} ] || { tail -20 "$log.regress"; die "$t: ran $ran of ${#regress[@]} regression inputs"; }
  fi

  # 3. Smoke: coverage-guided, time-boxed, from the committed corpus.
  execs="-" cov="-" ft="-"
  if [ "$SMOKE_S" -gt 0 ]; then
    mkdir -p "$SCRATCH/$t" "$FUZZ/artifacts/$t"
    log="$SCRATCH/$t.smoke.log"
    if ! nice -n 10 "$BIN/$t" -max_total_time="$SMOKE_S" -timeout=20 -rss_limit_mb=2048 -print_final_stats=1 \
        -artifact_prefix="$FUZZ/artifacts/$t/" "$SCRATCH/$t" "$corpus" > "$log" 2>&1; then
      tail -60 "$log"
      die "$t: the fuzzer found a failure; input under fuzz/artifacts/$t/ (log above)"
    fi
    read -r execs cov ft <<< "$(stats "$log")"
  fi
  printf '%-20s %8s %8s %12s %8s %8s\n' "$t" "$n_corpus" "${#regress[@]}" "$execs" "$cov" "$ft" > "$SCRATCH/$t.row"
}

# The targets run side by side, one per core (FUZZ_JOBS, default nproc):
# libFuzzer runs one process on one core, so each target still gets its own
# core for its whole SMOKE_S seconds, as it did one after the other. Each
# target's output is printed after all have finished, in order; any failure
# fails the group, naming its target.
JOBS=${FUZZ_JOBS:-$(nproc)}
running=0
for t in "${TARGETS[@]}"; do
  if [ "$running" -ge "$JOBS" ]; then wait -n || true; running=$((running - 1)); fi
  ( set +e; ( set -e; one_target "$t" ) > "$SCRATCH/$t.out" 2>&1; echo $? > "$SCRATCH/$t.rc" ) &
  running=$((running + 1))
done
wait
failed=()
for t in "${TARGETS[@]}"; do
  cat "$SCRATCH/$t.out"
  [ "$(cat "$SCRATCH/$t.rc" 2>/dev/null)" = 0 ] && [ -s "$SCRATCH/$t.row" ] || failed+=("$t")
done
[ ${#failed[@]} -eq 0 ] || die "failed: ${failed[*]} (each one's output above)"

printf '\n%-20s %8s %8s %12s %8s %8s\n' target corpus regress smoke_execs cov ft
for t in "${TARGETS[@]}"; do cat "$SCRATCH/$t.row"; done
echo "fuzz_group: OK in $(($(date +%s) - t0)) s (build $((t_built - t0)) s, smoke ${SMOKE_S} s per target, $JOBS at a time)"

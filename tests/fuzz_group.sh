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
#
# The stable toolchain builds the targets with RUSTC_BOOTSTRAP=1 (cargo-fuzz
# passes nightly-only -Z flags). No sanitizer (-s none): the code under test
# is safe Rust, and the build is the slow part of this group.
#
#   tests/fuzz_group.sh                 everything
#   FUZZ_SMOKE_S=0 tests/fuzz_group.sh  replay only
#   FUZZ_TARGETS="config_parse" ...     some targets
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
declare -a ROWS
for t in "${TARGETS[@]}"; do
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
  ROWS+=("$(printf '%-20s %8s %8s %12s %8s %8s' "$t" "$n_corpus" "${#regress[@]}" "$execs" "$cov" "$ft")")
done

printf '\n%-20s %8s %8s %12s %8s %8s\n' target corpus regress smoke_execs cov ft
printf '%s\n' "${ROWS[@]}"
echo "fuzz_group: OK in $(($(date +%s) - t0)) s (build $((t_built - t0)) s, smoke ${SMOKE_S} s per target)"

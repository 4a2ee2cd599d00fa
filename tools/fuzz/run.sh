#!/usr/bin/env bash
# The project's fuzzing (issue 14). Builds the libFuzzer targets with clang + ASan + UBSan
# into build-fuzz/ and runs them:
#
#   tools/fuzz/run.sh build            only build them (CI builds while other work runs)
#   tools/fuzz/run.sh regress          every input of fuzz/regressions/<target>/ once
#   tools/fuzz/run.sh smoke [SECONDS]  regressions, then each target SECONDS (default 10)
#   tools/fuzz/run.sh fuzz [SECONDS]   each target SECONDS (default 120) from fuzz/corpus
#
# A finding (crash, sanitizer report, an exception other than InputError, a hang over
# 10 s, more than 2 GB) stops the target; its input is kept in build-fuzz/findings/ and the
# script exits 1. New interesting inputs go to build-fuzz/corpus/<target>/ (not the repo).
set -euo pipefail
shopt -s nullglob
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
cd "$ROOT"
MODE=${1:-fuzz}
SECONDS_PER_TARGET=${2:-$([ "$MODE" = smoke ] && echo 10 || echo 120)}
JOBS=${JOBS:-2}
BUILD=build-fuzz
TARGETS=(sites_io tsplib npy render_job ply recon_inputs verdict_model exif scene_kernel_job
  scene_kernel_stream)

if [ ! -f "$BUILD/build.ninja" ]; then
  CC=clang CXX=clang++ cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DMOUND_FUZZ=ON > /dev/null
fi
if ! cmake --build "$BUILD" -j "$JOBS" > "$BUILD/build.log" 2>&1; then
  tail -n 40 "$BUILD/build.log" >&2
  echo "$0: the fuzz build failed ($BUILD/build.log)" >&2
  exit 1
fi
[ "$MODE" = build ] && exit 0
mkdir -p "$BUILD/findings"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

status=0
regress() {
  for t in "${TARGETS[@]}"; do
    files=(fuzz/regressions/"$t"/* fuzz/corpus/"$t"/*)
    if "$BUILD/fuzz/fuzz_$t" -timeout=10 -rss_limit_mb=2048 "${files[@]}" \
        > "$BUILD/findings/regress_$t.log" 2>&1; then
      printf '%-14s regression + seed inputs: %3d run, 0 findings\n' "$t" "${#files[@]}"
    else
      printf '%-14s FINDING (see %s)\n' "$t" "$BUILD/findings/regress_$t.log"
      status=1
    fi
  done
}

fuzz_one() {
  local t=$1 secs=$2
  # The sites target also plans every small instance it reads: 2.5 times the time, so that
  # it too passes a million executions in a full run.
  if [ "$t" = sites_io ]; then secs=$((secs * 5 / 2)); fi
  mkdir -p "$BUILD/corpus/$t"
  local log="$BUILD/findings/fuzz_$t.log"
  local rc=0
  "$BUILD/fuzz/fuzz_$t" -max_total_time="$secs" -timeout=10 -rss_limit_mb=2048 \
    -max_len=65536 -print_final_stats=1 -artifact_prefix="$BUILD/findings/${t}-" \
    "$BUILD/corpus/$t" "fuzz/corpus/$t" "fuzz/regressions/$t" > "$log" 2>&1 || rc=$?
  local execs
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | tail -1 | grep -o '[0-9]*$' || true)
  execs=${execs:-0}
  local per_s=$((execs / (secs > 0 ? secs : 1)))
  if [ "$rc" -eq 0 ]; then
    printf '%-14s %10d executions in %4d s (%6d/s), 0 crashes, 0 hangs, 0 non-InputError\n' \
      "$t" "$execs" "$secs" "$per_s"
  else
    printf '%-14s FINDING after %d executions (exit %d): %s\n' "$t" "$execs" "$rc" "$log"
    return 1
  fi
}

case "$MODE" in
  regress) regress ;;
  smoke|fuzz)
    [ "$MODE" = smoke ] && regress
    export -f fuzz_one
    export BUILD
    # Two targets at a time (one per core); each line as it finishes.
    printf '%s\n' "${TARGETS[@]}" | xargs -P "$JOBS" -I{} bash -c "fuzz_one {} $SECONDS_PER_TARGET" \
      || status=1
    ;;
  *) echo "usage: $0 build | regress | smoke [SECONDS] | fuzz [SECONDS]" >&2; exit 2 ;;
esac
exit $status

#!/usr/bin/env bash
# The whole test suite: installs what is missing, builds, runs every unit test and rostest through ctest; then
# the sanitizer stage: the unit tests and the VO nodelet's rostests again in an AddressSanitizer +
# UndefinedBehaviorSanitizer build ($PLANETARY_VO_BUILD/sanitize). PLANETARY_VO_SKIP_SANITIZE=1 skips that
# stage (for a quick local run; CI runs it). The wall time of each stage is printed at the end.
# Exit code: ctest's (non-zero when a test fails), non-zero when no test ran at all, and non-zero when a
# sanitizer wrote a report (even one from a process whose test passed, e.g. a leak at the manager's exit).
set -euo pipefail
source "$(dirname "$0")/env.sh"
"$PLANETARY_VO_ROOT/scripts/install_deps.sh"

timings=()
stage_start=$SECONDS
stage_done() {  # $1: stage name
  timings+=("$1: $((SECONDS - stage_start)) s")
  stage_start=$SECONDS
}
print_timings() {
  echo "run_tests: wall time per stage (nproc $(nproc)):"
  for t in "${timings[@]}"; do echo "  $t"; done
}

# Runs ctest in the current folder with the given extra arguments, output in ctest.log; returns ctest's rc,
# or 1 when no test ran.
run_ctest() {
  rm -rf test_results
  # Two at a time (2-core CI: ~56 s of tests instead of ~97 s serially). Every rostest starts its own master
  # on a free port, and the rostests wait until the publisher side of each connection is up before anything
  # is published, so a loaded machine only makes them slower (vo_reload and aligned_path were flaky at -j2
  # before).
  # (Called as `run_ctest || rc=$?`, so set -e does not end the script when ctest fails.)
  ctest --output-on-failure --timeout 900 -j2 "$@" </dev/null | tee ctest.log
  local rc=${PIPESTATUS[0]}
  if ! grep -Eq '^[0-9]+% tests passed, [0-9]+ tests failed out of [1-9]' ctest.log; then
    echo "run_tests: no test ran" >&2
    return 1
  fi
  return "$rc"
}

# ---- stage 1: the normal (Release) build and every test ----------------------------------------------------
planetary_vo_build tests
stage_done "build"
mkdir -p "$ROS_LOG_DIR"
cd "$PLANETARY_VO_BUILD"
rc=0
run_ctest || rc=$?
stage_done "tests"
if [ "$rc" -ne 0 ]; then
  print_timings
  echo "run_tests: the test suite failed; the sanitizer stage is not run" >&2
  exit "$rc"
fi
if [ "${PLANETARY_VO_SKIP_SANITIZE:-0}" = 1 ]; then
  print_timings
  echo "run_tests: sanitizer stage skipped (PLANETARY_VO_SKIP_SANITIZE=1)"
  exit 0
fi

# ---- stage 2: ASan + UBSan (docs: README, "Tests") -----------------------------------------------------------
# Only what the stage runs is built (target sanitize_tests); the rendered test sequence of the VO rostests is
# the stage 1 one, not rendered again.
SANITIZE_BUILD="$PLANETARY_VO_BUILD/sanitize"
cmake -S "$PLANETARY_VO_ROOT" -B "$SANITIZE_BUILD" -DCMAKE_BUILD_TYPE=Debug -DPLANETARY_VO_SANITIZE=ON \
  -DPLANETARY_VO_TEST_DATASET="$PLANETARY_VO_BUILD/test_output/vo_lunar_approach_down" \
  -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 >/dev/null
cmake --build "$SANITIZE_BUILD" -j"$(nproc)" --target sanitize_tests
stage_done "sanitizer build"

# Every report goes to a file: a finding in a process whose test does not notice (a leak at the nodelet
# manager's exit, after the test ended) still fails the stage. abort_on_error: a finding ends the process with
# SIGABRT, which the tests see as a crash (not as the exit code 1 of a clean error).
reports="$SANITIZE_BUILD/sanitizer_reports"
rm -rf "$reports"
mkdir -p "$reports"
export ASAN_OPTIONS="halt_on_error=1:abort_on_error=1:detect_leaks=1:check_initialization_order=1:strict_init_order=1:detect_stack_use_after_return=1:log_path=$reports/asan"
export UBSAN_OPTIONS="halt_on_error=1:abort_on_error=1:print_stacktrace=1:log_path=$reports/ubsan"
export LSAN_OPTIONS="suppressions=$PLANETARY_VO_ROOT/test/sanitizer/lsan.supp:print_suppressions=0"
# The nodelet manager is Debian's /usr/lib/nodelet/nodelet, not instrumented: the ASan runtime must be loaded
# before everything else in it, or the instrumented nodelet library refuses to load. The rostests start it
# with launch-prefix="$(optenv PLANETARY_VO_LAUNCH_PREFIX)" (test/ros/vo_*.test).
export PLANETARY_VO_LAUNCH_PREFIX="env LD_PRELOAD=$(g++ -print-file-name=libasan.so)"
cd "$SANITIZE_BUILD"
rc=0
run_ctest -L sanitize || rc=$?
unset ASAN_OPTIONS UBSAN_OPTIONS LSAN_OPTIONS PLANETARY_VO_LAUNCH_PREFIX
stage_done "sanitizer tests"
if compgen -G "$reports/*" >/dev/null; then
  echo "run_tests: sanitizer reports (in $reports):" >&2
  for f in "$reports"/*; do
    echo "==== $f" >&2
    head -c 20000 "$f" >&2
  done
  [ "$rc" -ne 0 ] || rc=1
fi
print_timings
exit "$rc"

#!/usr/bin/env bash
# The whole test suite: installs what is missing, builds, runs every unit test and rostest through ctest.
# Exit code: ctest's (non-zero when a test fails), and non-zero when no test ran at all.
set -euo pipefail
source "$(dirname "$0")/env.sh"
"$PLANETARY_VO_ROOT/scripts/install_deps.sh"
planetary_vo_build tests
mkdir -p "$ROS_LOG_DIR"
cd "$PLANETARY_VO_BUILD"
rm -rf test_results
# Two at a time (2-core CI: ~56 s of tests instead of ~97 s serially). Every rostest starts its own master on
# a free port, and the rostests wait until the publisher side of each connection is up before anything is
# published, so a loaded machine only makes them slower (vo_reload and aligned_path were flaky at -j2 before).
ctest_args=(--output-on-failure --timeout 900 -j2)
ctest "${ctest_args[@]}" </dev/null | tee ctest.log
rc=${PIPESTATUS[0]}
if ! grep -Eq '^[0-9]+% tests passed, [0-9]+ tests failed out of [1-9]' ctest.log; then
  echo "run_tests: no test ran" >&2
  exit 1
fi
exit "$rc"

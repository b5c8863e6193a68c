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
# Serially: two rostests (vo_reload, aligned_path) each failed once in ~8 runs under -j2 load (timing-sensitive
# waits); they pass alone. Run them one at a time until those waits are made robust.
ctest_args=(--output-on-failure --timeout 900 -j1)
ctest "${ctest_args[@]}" </dev/null | tee ctest.log
rc=${PIPESTATUS[0]}
if ! grep -Eq '^[0-9]+% tests passed, [0-9]+ tests failed out of [1-9]' ctest.log; then
  echo "run_tests: no test ran" >&2
  exit 1
fi
exit "$rc"

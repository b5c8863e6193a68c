# Sourced by the scripts in this folder: one place for the build folder and the ROS environment fixes.
# shellcheck shell=bash
PLANETARY_VO_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export PLANETARY_VO_ROOT
export PLANETARY_VO_BUILD="${PLANETARY_VO_BUILD:-$PLANETARY_VO_ROOT/build}"
export PLANETARY_VO_OUTPUT="${PLANETARY_VO_OUTPUT:-$PLANETARY_VO_ROOT/output}"
# Debian's ROS tooling needs the system python, not a pyenv one first on PATH.
export PATH="/usr/bin:$PATH"
# Logs and the ROS home inside the build folder; localhost because the host name may not resolve.
export ROS_HOME="$PLANETARY_VO_BUILD/ros_home"
export ROS_LOG_DIR="$ROS_HOME/log"
export ROS_HOSTNAME=localhost
export ROS_LANG_DISABLE=genlisp

# Configures and builds everything (and the test executables when $1 == tests).
planetary_vo_build() {
  local jobs
  jobs="$(nproc)"
  cmake -S "$PLANETARY_VO_ROOT" -B "$PLANETARY_VO_BUILD" -DCMAKE_BUILD_TYPE=Release \
    -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 >/dev/null
  cmake --build "$PLANETARY_VO_BUILD" -j"$jobs"
  if [ "${1:-}" = tests ]; then cmake --build "$PLANETARY_VO_BUILD" -j"$jobs" --target tests; fi
}

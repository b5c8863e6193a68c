#!/usr/bin/env bash
# Installs every Debian 12 package planetary_vo needs to build, run and test.
# Idempotent: apt-get skips what is already installed. Run as root (or through sudo).
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

PACKAGES=(
  # toolchain and test framework
  build-essential cmake pkg-config libgtest-dev libgmock-dev
  # ROS 1 (Debian's own "ros-*" packages; see docs/ros1-on-debian notes in README)
  ros-core-dev python3-rostest rosbash
  libnodeletlib-dev libnodeletlib-tools
  libimage-transport-dev libcv-bridge-dev libtf2-ros-dev libtf2-geometry-msgs-dev
  libimage-geometry-dev libdiagnostic-updater-dev libdynamic-reconfigure-config-init-mutex-dev
  python3-dynamic-reconfigure
  libstd-srvs-dev python3-std-srvs libvisualization-msgs-dev
  python3-nav-msgs python3-sensor-msgs python3-geometry-msgs python3-tf2-msgs python3-std-msgs
  catkin-lint
  # core library dependencies
  libopencv-dev libeigen3-dev libceres-dev libyaml-cpp-dev
  # glog: Ceres logs through it; vo_run sets its level
  libgoogle-glog-dev
  # plots of the trajectory evaluator; PyYAML for the sensitivity sweep's configurations (scripts/vo_sensitivity.py);
  # SciPy for the hazard map's error breakdown (scripts/terrain_errors.py, test terrain_errors_tool); PIL writes the
  # float TIFFs of that test's slope_weight_check.py case
  python3-matplotlib python3-numpy python3-yaml python3-scipy python3-pil
  # GUI parts: rviz, headless X for screenshots in CI
  rviz xvfb xauth imagemagick
  # Monte Carlo campaigns on Slurm (scripts/vo_campaign.py --scheduler slurm; the campaign_slurm test starts a
  # private single-node cluster with scripts/slurm_local.sh)
  munge slurmctld slurmd slurm-client
)

# apt-get update only when the lists are missing or older than a day: keeps re-runs fast.
if [ -z "$(find /var/lib/apt/lists -maxdepth 1 -name '*Packages*' -mmin -1440 2>/dev/null | head -1)" ]; then
  $SUDO apt-get update
fi

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages already installed"
else
  echo "install_deps: installing ${#missing[@]} packages: ${missing[*]}"
  $SUDO apt-get install -y --no-install-recommends "${missing[@]}"
fi

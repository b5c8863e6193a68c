/// @file trajectory_io.cpp
/// TUM and KITTI trajectory files, and pose interpolation.

#include <cmath>
#include <cstdio>
#include <memory>

#include "dataset_internal.h"
#include "planetary_vo/dataset/dataset.h"

namespace planetary_vo {

using namespace dataset_internal;

namespace {

/// `t tx ty tz qx qy qz qw` from tokens [first, first + 8) of a row.
StampedPose tumPoseFromRow(const std::string& path, const TextRow& row) {
  StampedPose pose;
  pose.timestamp_s = parseDouble(path, row, 0);
  const Eigen::Vector3d t(parseDouble(path, row, 1), parseDouble(path, row, 2), parseDouble(path, row, 3));
  Eigen::Quaterniond q(parseDouble(path, row, 7), parseDouble(path, row, 4), parseDouble(path, row, 5),
                       parseDouble(path, row, 6));
  const double norm = q.norm();
  if (std::abs(norm - 1.0) > 1e-3)
    throw DatasetError(path + ":" + std::to_string(row.line_number) + ": quaternion norm " +
                       std::to_string(norm) + " is not 1");
  q.normalize();
  pose.T_world_cam = Pose::Identity();
  pose.T_world_cam.linear() = q.toRotationMatrix();
  pose.T_world_cam.translation() = t;
  return pose;
}

Pose kittiPoseFromRow(const std::string& path, const TextRow& row) {
  Eigen::Matrix<double, 3, 4> P;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) P(r, c) = parseDouble(path, row, 4 * r + c);
  const Eigen::Matrix3d R = P.leftCols<3>();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-3 || R.determinant() < 0.0)
    throw DatasetError(path + ":" + std::to_string(row.line_number) + ": the 3x3 block is not a rotation");
  Pose T = Pose::Identity();
  T.linear() = orthonormalized(R);  // printed with 7 digits: project back onto SO(3)
  T.translation() = P.col(3);
  return T;
}

}  // namespace

Trajectory readTumTrajectory(const std::string& path) {
  Trajectory trajectory;
  for (const TextRow& row : readTextTable(path, false)) {
    requireColumns(path, row, 8, true);
    StampedPose pose = tumPoseFromRow(path, row);
    if (!trajectory.empty()) requireIncreasing(path, row, trajectory.back().timestamp_s, pose.timestamp_s);
    trajectory.push_back(pose);
  }
  return trajectory;
}

void writeTumTrajectory(const std::string& path, const Trajectory& trajectory) {
  std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "w"), &std::fclose);
  if (!file) throw DatasetError("cannot write " + path);
  std::fprintf(file.get(),
               "# timestamp[s] tx ty tz[m] qx qy qz qw: T_world_cam, camera optical frame in world\n");
  for (const StampedPose& p : trajectory) {
    const Eigen::Vector3d& t = p.T_world_cam.translation();
    const Eigen::Quaterniond q(p.T_world_cam.rotation());
    std::fprintf(file.get(), "%.9f %.9f %.9f %.9f %.12f %.12f %.12f %.12f\n", p.timestamp_s, t.x(), t.y(),
                 t.z(), q.x(), q.y(), q.z(), q.w());
  }
  if (std::ferror(file.get())) throw DatasetError("error while writing " + path);
}

Trajectory readKittiTrajectory(const std::string& path, double rate_hz) {
  if (!(rate_hz > 0.0)) throw DatasetError("readKittiTrajectory: rate must be positive for " + path);
  Trajectory trajectory;
  for (const TextRow& row : readTextTable(path, false)) {
    requireColumns(path, row, 12, true);
    StampedPose pose;
    pose.timestamp_s = static_cast<double>(trajectory.size()) / rate_hz;
    pose.T_world_cam = kittiPoseFromRow(path, row);
    trajectory.push_back(pose);
  }
  return trajectory;
}

Trajectory readTrajectory(const std::string& path) {
  const std::vector<TextRow> rows = readTextTable(path, false);
  if (rows.empty()) throw DatasetError(path + ": no pose in the file");
  const size_t columns = rows.front().tokens.size();
  if (columns == 8) return readTumTrajectory(path);
  if (columns == 12) return readKittiTrajectory(path);
  throw DatasetError(path + ":" + std::to_string(rows.front().line_number) + ": " + std::to_string(columns) +
                     " values: neither TUM (8: t tx ty tz qx qy qz qw) nor KITTI (12: 3x4 pose)");
}

bool interpolatePose(const Trajectory& samples, double timestamp_s, Pose* T_world_cam) {
  if (samples.empty() || timestamp_s < samples.front().timestamp_s ||
      timestamp_s > samples.back().timestamp_s)
    return false;
  // First sample at or after the stamp.
  size_t lo = 0, hi = samples.size() - 1;
  while (hi - lo > 1) {
    const size_t mid = (lo + hi) / 2;
    (samples[mid].timestamp_s <= timestamp_s ? lo : hi) = mid;
  }
  const StampedPose& a = samples[lo];
  const StampedPose& b = samples[hi];
  const double span = b.timestamp_s - a.timestamp_s;
  const double alpha = span > 0.0 ? std::min(1.0, std::max(0.0, (timestamp_s - a.timestamp_s) / span)) : 0.0;
  const Eigen::Quaterniond qa(a.T_world_cam.rotation()), qb(b.T_world_cam.rotation());
  Pose T = Pose::Identity();
  T.linear() = qa.slerp(alpha, qb).toRotationMatrix();
  T.translation() = (1.0 - alpha) * a.T_world_cam.translation() + alpha * b.T_world_cam.translation();
  *T_world_cam = T;
  return true;
}

}  // namespace planetary_vo

/// @file evaluation_inputs.cpp
/// Readers of the evaluator's optional inputs: groundtruth_state.txt, estimated velocities and covariances.

#include "planetary_vo/eval/evaluation_inputs.h"

#include <sys/stat.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

namespace planetary_vo {

namespace {

/// Calls `row(line_number, values)` for every non-empty, non-comment line of `path`; all values must be
/// finite numbers. Throws EvalError naming the file and line.
void forEachRow(const std::string& path, const std::function<void(int, const std::vector<double>&)>& row) {
  std::ifstream in(path);
  if (!in) throw EvalError("cannot open " + path);
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream tokens(line);
    std::vector<double> values;
    for (std::string token; tokens >> token;) {
      char* end = nullptr;
      errno = 0;
      const double v = std::strtod(token.c_str(), &end);
      if (end == token.c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(v))
        throw EvalError(path + ":" + std::to_string(line_number) + ": '" + token +
                        "' is not a finite number");
      values.push_back(v);
    }
    row(line_number, values);
  }
  if (in.bad()) throw EvalError("error while reading " + path);
}

std::string where(const std::string& path, int line_number) {
  return path + ":" + std::to_string(line_number) + ": ";
}

void requireCount(const std::string& path, int line_number, const std::vector<double>& values, size_t count) {
  if (values.size() != count)
    throw EvalError(where(path, line_number) + "expected " + std::to_string(count) + " values, got " +
                    std::to_string(values.size()));
}

void requireIncreasing(const std::string& path, int line_number, bool has_previous, double previous,
                       double stamp) {
  if (has_previous && !(stamp > previous))
    throw EvalError(where(path, line_number) + "time stamps must increase strictly");
}

/// The N x N covariance stored row-major at `values`: symmetric (to 1e-9 of its largest entry, then
/// symmetrised) and positive definite, else an error naming the line.
template <int N>
Eigen::Matrix<double, N, N> checkedCovariance(const std::string& path, int line_number, const double* values) {
  Eigen::Matrix<double, N, N> P;
  for (int r = 0; r < N; ++r)
    for (int c = 0; c < N; ++c) P(r, c) = values[N * r + c];
  const double largest = P.cwiseAbs().maxCoeff();
  if ((P - P.transpose()).cwiseAbs().maxCoeff() > 1e-9 * largest)
    throw EvalError(where(path, line_number) + "the covariance is not symmetric");
  P = (0.5 * (P + P.transpose())).eval();
  if (!(largest > 0.0) || P.llt().info() != Eigen::Success)
    throw EvalError(where(path, line_number) + "the covariance is not positive definite");
  return P;
}

bool isDirectory(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

bool exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0;
}

}  // namespace

std::vector<GroundTruthState> readGroundTruthStates(const std::string& path) {
  std::vector<GroundTruthState> states;
  forEachRow(path, [&](int line_number, const std::vector<double>& v) {
    requireCount(path, line_number, v, 17);
    requireIncreasing(path, line_number, !states.empty(), states.empty() ? 0.0 : states.back().timestamp_s,
                      v[0]);
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);  // file order x y z w
    if (std::abs(q.norm() - 1.0) > 1e-3)
      throw EvalError(where(path, line_number) + "quaternion norm " + std::to_string(q.norm()) + " is not 1");
    q.normalize();
    GroundTruthState s;
    s.timestamp_s = v[0];
    s.T_world_body = Pose::Identity();
    s.T_world_body.linear() = q.toRotationMatrix();
    s.T_world_body.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
    s.velocity_world_mps = Eigen::Vector3d(v[8], v[9], v[10]);
    s.gyro_bias_radps = Eigen::Vector3d(v[11], v[12], v[13]);
    s.accel_bias_mps2 = Eigen::Vector3d(v[14], v[15], v[16]);
    states.push_back(s);
  });
  return states;
}

std::vector<StampedVelocity> readEstimateVelocities(const std::string& path) {
  std::vector<StampedVelocity> velocities;
  forEachRow(path, [&](int line_number, const std::vector<double>& v) {
    // t vx vy vz, optionally followed by the six bias estimates (vo_run --output-velocity, camera + IMU) or
    // the velocity's 3x3 covariance, row-major (the motion filter's, without the IMU): the velocity NEES.
    if (v.size() != 10 && v.size() != 13) requireCount(path, line_number, v, 4);
    requireIncreasing(path, line_number, !velocities.empty(),
                      velocities.empty() ? 0.0 : velocities.back().timestamp_s, v[0]);
    StampedVelocity s{v[0], Eigen::Vector3d(v[1], v[2], v[3])};
    if (v.size() == 13) {
      s.has_covariance = true;
      s.covariance = checkedCovariance<3>(path, line_number, v.data() + 4);
    }
    velocities.push_back(s);
  });
  return velocities;
}

std::vector<StampedCovariance> readEstimateCovariances(const std::string& path) {
  std::vector<StampedCovariance> covariances;
  forEachRow(path, [&](int line_number, const std::vector<double>& v) {
    const size_t expected =
        covariances.empty() ? (v.size() == 10 ? 10 : 37) : 1 + covariances.front().covariance.size();
    if (v.size() != expected)
      throw EvalError(where(path, line_number) + "expected " +
                      (covariances.empty() ? std::string("10 or 37") : std::to_string(expected)) +
                      " values (t and a 3x3 or 6x6 covariance, the same size on every line), got " +
                      std::to_string(v.size()));
    requireIncreasing(path, line_number, !covariances.empty(),
                      covariances.empty() ? 0.0 : covariances.back().timestamp_s, v[0]);
    Eigen::MatrixXd P;
    if (v.size() == 10)
      P = checkedCovariance<3>(path, line_number, v.data() + 1);
    else
      P = checkedCovariance<6>(path, line_number, v.data() + 1);
    covariances.push_back({v[0], P});
  });
  return covariances;
}

GroundTruthFiles findGroundTruthFiles(const std::string& path) {
  if (!exists(path)) throw EvalError("cannot open " + path);
  GroundTruthFiles files;
  if (!isDirectory(path)) {
    files.trajectory_path = path;
    return files;
  }
  const std::string dir = path.back() == '/' ? path : path + "/";
  files.trajectory_path = dir + "groundtruth.txt";
  if (!exists(files.trajectory_path))
    throw EvalError(path + " is a folder without groundtruth.txt (expected a planetary_vo dataset)");
  if (exists(dir + "groundtruth_state.txt")) files.state_path = dir + "groundtruth_state.txt";
  return files;
}

Eigen::Vector3d parseAxis(const std::string& text) {
  if (text.empty() || text.size() > 2) throw EvalError("bad axis '" + text + "' (expected +x, -x, ..., -z)");
  const double sign = text.size() == 2 && text[0] == '-' ? -1.0 : 1.0;
  if (text.size() == 2 && text[0] != '-' && text[0] != '+')
    throw EvalError("bad axis '" + text + "' (expected +x, -x, ..., -z)");
  const char axis = text.back();
  if (axis < 'x' || axis > 'z') throw EvalError("bad axis '" + text + "' (expected +x, -x, ..., -z)");
  return sign * Eigen::Vector3d::Unit(axis - 'x');
}

}  // namespace planetary_vo

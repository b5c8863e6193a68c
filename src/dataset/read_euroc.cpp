/// @file read_euroc.cpp
/// Reader of a EuRoC ASL folder (the sequence folder holding mav0/, or mav0/ itself): cam0 images and
/// intrinsics, imu0, and state_groundtruth_estimate0 body poses turned into camera poses through cam0's T_BS.

#include <cmath>

#include <yaml-cpp/yaml.h>

#include "dataset_internal.h"
#include "planetary_vo/dataset/dataset.h"

namespace planetary_vo {

using namespace dataset_internal;

namespace {

struct EurocCamera {
  PinholeCamera camera;
  Pose T_body_cam = Pose::Identity();
};

std::vector<double> yamlDoubles(const std::string& path, const YAML::Node& node, const std::string& key) {
  if (!node[key]) throw DatasetError(path + ": missing '" + key + "'");
  const YAML::Node list = node[key].IsMap() ? node[key]["data"] : node[key];
  if (!list || !list.IsSequence()) throw DatasetError(path + ": '" + key + "' is not a list");
  std::vector<double> values;
  for (const YAML::Node& v : list) values.push_back(v.as<double>());
  return values;
}

EurocCamera readSensorYaml(const std::string& path) {
  const YAML::Node root = loadYamlFile(path);
  try {
    const std::vector<double> intrinsics = yamlDoubles(path, root, "intrinsics");  // fu fv cu cv
    const std::vector<double> resolution = yamlDoubles(path, root, "resolution");  // width height
    const std::vector<double> T = yamlDoubles(path, root, "T_BS");
    if (intrinsics.size() != 4) throw DatasetError(path + ": 'intrinsics' must be [fu, fv, cu, cv]");
    if (resolution.size() != 2) throw DatasetError(path + ": 'resolution' must be [width, height]");
    if (T.size() != 16) throw DatasetError(path + ": 'T_BS' must have 16 values");

    std::string model;
    std::vector<double> distortion;
    if (root["distortion_coefficients"]) distortion = yamlDoubles(path, root, "distortion_coefficients");
    const std::string euroc_model =
        root["distortion_model"] ? root["distortion_model"].as<std::string>() : "";
    if (euroc_model == "radial-tangential" || euroc_model == "radtan") {
      model = "plumb_bob";  // k1 k2 p1 p2 (k3 = 0)
      distortion.resize(5, 0.0);
    } else if (euroc_model == "equidistant") {
      model = "equidistant";
    } else if (!euroc_model.empty() && euroc_model != "none") {
      throw DatasetError(path + ": unsupported distortion_model '" + euroc_model + "'");
    }
    EurocCamera result;
    result.camera =
        PinholeCamera(static_cast<int>(resolution[0]), static_cast<int>(resolution[1]), intrinsics[0],
                      intrinsics[1], intrinsics[2], intrinsics[3], model, distortion);
    Eigen::Matrix4d M;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) M(r, c) = T[4 * r + c];
    result.T_body_cam.linear() = orthonormalized(M.topLeftCorner<3, 3>());
    result.T_body_cam.translation() = M.topRightCorner<3, 1>();
    return result;
  } catch (const YAML::Exception& e) {
    throw DatasetError(path + ": bad value: " + e.what());
  }
}

/// state_groundtruth_estimate0/data.csv: `t_ns, px, py, pz, qw, qx, qy, qz, ...` (T_world_body, w first).
Trajectory readBodyGroundTruth(const std::string& path) {
  Trajectory poses;
  for (const TextRow& row : readTextTable(path, true)) {
    requireColumns(path, row, 8, false);
    StampedPose p;
    p.timestamp_s = nanosecondsToSeconds(parseInt64(path, row, 0));
    const Eigen::Vector3d t(parseDouble(path, row, 1), parseDouble(path, row, 2), parseDouble(path, row, 3));
    Eigen::Quaterniond q(parseDouble(path, row, 4), parseDouble(path, row, 5), parseDouble(path, row, 6),
                         parseDouble(path, row, 7));
    if (std::abs(q.norm() - 1.0) > 1e-3)
      throw DatasetError(path + ":" + std::to_string(row.line_number) + ": quaternion is not unit");
    p.T_world_cam.linear() = q.normalized().toRotationMatrix();
    p.T_world_cam.translation() = t;
    if (!poses.empty()) requireIncreasing(path, row, poses.back().timestamp_s, p.timestamp_s);
    poses.push_back(p);
  }
  return poses;
}

std::vector<ImuSample> readImuCsv(const std::string& path) {
  std::vector<ImuSample> samples;
  for (const TextRow& row : readTextTable(path, true)) {
    requireColumns(path, row, 7, true);
    ImuSample s;
    s.timestamp_s = nanosecondsToSeconds(parseInt64(path, row, 0));
    for (int k = 0; k < 3; ++k) {
      s.angular_velocity_radps[k] = parseDouble(path, row, 1 + k);
      s.specific_force_mps2[k] = parseDouble(path, row, 4 + k);
    }
    if (!samples.empty()) requireIncreasing(path, row, samples.back().timestamp_s, s.timestamp_s);
    samples.push_back(s);
  }
  return samples;
}

}  // namespace

Dataset DatasetReaders::readEuroc(const std::string& directory) {
  const std::string mav0 = isFile(directory + "/mav0/cam0/data.csv") ? directory + "/mav0/" : directory + "/";
  Dataset dataset;
  dataset.format_ = DatasetFormat::kEuroc;
  dataset.directory_ = directory;
  dataset.name_ = baseName(directory) == "mav0" ? baseName(directory + "/..") : baseName(directory);

  const EurocCamera cam = readSensorYaml(mav0 + "cam0/sensor.yaml");
  dataset.camera_ = cam.camera;

  const std::string images_csv = mav0 + "cam0/data.csv";
  for (const TextRow& row : readTextTable(images_csv, true)) {
    requireColumns(images_csv, row, 2, true);
    const double t = nanosecondsToSeconds(parseInt64(images_csv, row, 0));
    if (!dataset.timestamps_s_.empty()) requireIncreasing(images_csv, row, dataset.timestamps_s_.back(), t);
    const std::string image_path = mav0 + "cam0/data/" + row.tokens[1];
    if (!isFile(image_path))
      throw DatasetError(images_csv + ":" + std::to_string(row.line_number) + ": image " + image_path +
                         " does not exist");
    dataset.timestamps_s_.push_back(t);
    dataset.image_paths_.push_back(image_path);
  }

  if (isFile(mav0 + "imu0/data.csv")) dataset.imu_ = readImuCsv(mav0 + "imu0/data.csv");

  const std::string gt_csv = mav0 + "state_groundtruth_estimate0/data.csv";
  if (isFile(gt_csv)) {
    Trajectory camera_poses = readBodyGroundTruth(gt_csv);
    for (StampedPose& p : camera_poses)
      p.T_world_cam = p.T_world_cam * cam.T_body_cam;  // T_world_body * T_BS
    setInterpolatedGroundTruth(&dataset, camera_poses);
  }
  checkConsistent(dataset);
  return dataset;
}

}  // namespace planetary_vo

/// @file read_planetary_vo.cpp
/// Reader of the planetary_vo format (docs/dataset_format.md).

#include <cmath>

#include <yaml-cpp/yaml.h>

#include "dataset_internal.h"
#include "planetary_vo/dataset/dataset.h"

namespace planetary_vo {

namespace {

/// sensors.yaml -> SensorSpecification. Throws DatasetError naming the file on a malformed value.
SensorSpecification readSensorSpecification(const std::string& path) {
  SensorSpecification spec;
  try {
    const YAML::Node root = YAML::LoadFile(path);
    auto number = [&](const YAML::Node& section, const char* key, double* out) {
      if (section[key]) *out = section[key].as<double>();
    };
    if (const YAML::Node imu = root["imu"]; imu && imu.IsMap()) {
      spec.has_imu = true;
      number(imu, "rate_hz", &spec.imu_rate_hz);
      number(imu, "gyro_noise_density_radps_per_sqrt_hz", &spec.gyro_noise_density_radps_per_sqrt_hz);
      number(imu, "accel_noise_density_mps2_per_sqrt_hz", &spec.accel_noise_density_mps2_per_sqrt_hz);
    }
    if (const YAML::Node alt = root["altimeter"]; alt && alt.IsMap()) {
      spec.has_altimeter = true;
      number(alt, "min_range_m", &spec.altimeter_min_range_m);
      number(alt, "max_range_m", &spec.altimeter_max_range_m);
      number(alt, "beam_divergence_rad", &spec.altimeter_beam_divergence_rad);
      number(alt, "range_noise_floor_m", &spec.altimeter_range_noise_floor_m);
      number(alt, "range_noise_fraction", &spec.altimeter_range_noise_fraction);
    }
  } catch (const YAML::Exception& e) {
    throw DatasetError(path + ": " + e.what());
  }
  for (double v : {spec.imu_rate_hz, spec.gyro_noise_density_radps_per_sqrt_hz,
                   spec.accel_noise_density_mps2_per_sqrt_hz, spec.altimeter_min_range_m,
                   spec.altimeter_beam_divergence_rad, spec.altimeter_range_noise_floor_m,
                   spec.altimeter_range_noise_fraction})
    if (!std::isfinite(v) || v < 0.0) throw DatasetError(path + ": negative or non-finite sensor value");
  if (!(spec.altimeter_max_range_m > spec.altimeter_min_range_m))
    throw DatasetError(path + ": altimeter max_range_m must exceed min_range_m");
  return spec;
}

}  // namespace

using namespace dataset_internal;

namespace {

std::vector<double> readTimes(const std::string& path) {
  std::vector<double> stamps;
  for (const TextRow& row : readTextTable(path, false)) {
    requireColumns(path, row, 1, true);
    const double t = parseDouble(path, row, 0);
    if (!stamps.empty()) requireIncreasing(path, row, stamps.back(), t);
    stamps.push_back(t);
  }
  return stamps;
}

std::vector<ImuSample> readImu(const std::string& path) {
  std::vector<ImuSample> samples;
  for (const TextRow& row : readTextTable(path, false)) {
    requireColumns(path, row, 7, true);
    ImuSample s;
    s.timestamp_s = parseDouble(path, row, 0);
    for (int k = 0; k < 3; ++k) {
      s.angular_velocity_radps[k] = parseDouble(path, row, 1 + k);
      s.specific_force_mps2[k] = parseDouble(path, row, 4 + k);
    }
    if (!samples.empty()) requireIncreasing(path, row, samples.back().timestamp_s, s.timestamp_s);
    samples.push_back(s);
  }
  return samples;
}

std::vector<AltimeterSample> readAltimeter(const std::string& path) {
  std::vector<AltimeterSample> samples;
  for (const TextRow& row : readTextTable(path, false)) {
    // `t range` (range +inf = no return). Files of renderer versions before 1.3 carried a third column, the
    // true altitude: it is ground truth, not a measurement, and is ignored.
    if (row.tokens.size() != 2 && row.tokens.size() != 3)
      throw DatasetError(path + ":" + std::to_string(row.line_number) +
                         ": expected 2 values (t slant_range_m), got " + std::to_string(row.tokens.size()));
    AltimeterSample s;
    s.timestamp_s = parseDouble(path, row, 0);
    s.slant_range_m = parseRangeOrInf(path, row, 1);
    if (!samples.empty()) requireIncreasing(path, row, samples.back().timestamp_s, s.timestamp_s);
    samples.push_back(s);
  }
  return samples;
}

/// `name` from sequence.yaml, "" when absent. Throws DatasetError when the text is not YAML.
std::string sequenceName(const std::string& path, const std::string& text) {
  try {
    const YAML::Node root = YAML::Load(text);
    if (root.IsMap() && root["name"] && root["name"].IsScalar()) return root["name"].as<std::string>();
    return "";
  } catch (const YAML::Exception& e) {
    throw DatasetError(path + ": not valid YAML: " + e.what());
  }
}

}  // namespace

Dataset DatasetReaders::readPlanetaryVo(const std::string& directory) {
  const std::string d = directory + "/";
  Dataset dataset;
  dataset.format_ = DatasetFormat::kPlanetaryVo;
  dataset.directory_ = directory;
  dataset.name_ = baseName(directory);
  dataset.camera_ = readCameraInfoYaml(d + "camera.yaml");
  dataset.image_paths_ = listImages(d + "images");

  if (isFile(d + "groundtruth.txt")) dataset.ground_truth_ = readTumTrajectory(d + "groundtruth.txt");
  if (isFile(d + "times.txt")) {
    dataset.timestamps_s_ = readTimes(d + "times.txt");
    if (dataset.ground_truth_.size() == dataset.timestamps_s_.size()) {
      for (size_t i = 0; i < dataset.timestamps_s_.size(); ++i)
        if (std::abs(dataset.ground_truth_[i].timestamp_s - dataset.timestamps_s_[i]) > 1e-6)
          throw DatasetError(d + "groundtruth.txt: pose " + std::to_string(i) +
                             " is not at the stamp of image " + std::to_string(i) + " in times.txt");
    }
  } else if (!dataset.ground_truth_.empty()) {
    for (const StampedPose& p : dataset.ground_truth_) dataset.timestamps_s_.push_back(p.timestamp_s);
  } else {
    throw DatasetError(directory + ": neither times.txt nor groundtruth.txt gives the image time stamps");
  }

  if (isFile(d + "imu.txt")) dataset.imu_ = readImu(d + "imu.txt");
  if (isFile(d + "altimeter.txt")) dataset.altimeter_ = readAltimeter(d + "altimeter.txt");
  if (isFile(d + "sequence.yaml")) {
    dataset.sequence_yaml_ = readWholeFile(d + "sequence.yaml");
    const std::string name = sequenceName(d + "sequence.yaml", dataset.sequence_yaml_);
    if (!name.empty()) dataset.name_ = name;
  }
  if (isFile(d + "sensors.yaml")) dataset.sensor_spec_ = readSensorSpecification(d + "sensors.yaml");
  checkConsistent(dataset);
  return dataset;
}

}  // namespace planetary_vo

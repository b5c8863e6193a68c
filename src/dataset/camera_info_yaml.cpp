/// @file camera_info_yaml.cpp
/// ROS camera_info YAML (the format of camera_calibration_parsers), read with yaml-cpp and written by hand.

#include <algorithm>
#include <fstream>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "dataset_internal.h"
#include "planetary_vo/dataset/dataset.h"

namespace planetary_vo {

using namespace dataset_internal;

namespace {

/// `node[key].data` as doubles, checking rows*cols when given.
std::vector<double> matrixData(const std::string& path, const YAML::Node& root, const std::string& key,
                               size_t expected_size) {
  const YAML::Node node = root[key];
  if (!node) throw DatasetError(path + ": missing '" + key + "'");
  const YAML::Node data = node["data"];
  if (!data || !data.IsSequence()) throw DatasetError(path + ": '" + key + "' has no 'data' list");
  std::vector<double> values;
  for (const YAML::Node& v : data) values.push_back(v.as<double>());
  if (expected_size > 0 && values.size() != expected_size)
    throw DatasetError(path + ": '" + key + "' has " + std::to_string(values.size()) + " values, expected " +
                       std::to_string(expected_size));
  if (node["rows"] && node["cols"] && node["rows"].as<size_t>() * node["cols"].as<size_t>() != values.size())
    throw DatasetError(path + ": '" + key + "' rows*cols does not match its data");
  return values;
}

std::string yamlList(const std::vector<double>& values) {
  std::string text = "[";
  for (size_t i = 0; i < values.size(); ++i) text += (i ? ", " : "") + formatDouble(values[i]);
  return text + "]";
}

void writeMatrix(std::ostream& out, const std::string& key, int rows, int cols,
                 const std::vector<double>& data) {
  out << key << ":\n  rows: " << rows << "\n  cols: " << cols << "\n  data: " << yamlList(data) << "\n";
}

}  // namespace

PinholeCamera readCameraInfoYaml(const std::string& path) {
  const YAML::Node root = loadYamlFile(path);
  try {
    if (!root["image_width"] || !root["image_height"])
      throw DatasetError(path + ": missing 'image_width' or 'image_height'");
    const int width = root["image_width"].as<int>();
    const int height = root["image_height"].as<int>();
    const std::vector<double> K = matrixData(path, root, "camera_matrix", 9);
    std::string model = root["distortion_model"] ? root["distortion_model"].as<std::string>() : "";
    std::vector<double> distortion;
    if (root["distortion_coefficients"]) distortion = matrixData(path, root, "distortion_coefficients", 0);
    // ROS writes "plumb_bob" with zeros for an ideal camera: read that back as no distortion.
    if (std::all_of(distortion.begin(), distortion.end(), [](double d) { return d == 0.0; })) {
      model.clear();
      distortion.clear();
    }
    PinholeCamera camera(width, height, K[0], K[4], K[2], K[5], model, distortion);
    std::string why;
    if (!camera.isValid(&why)) throw DatasetError(path + ": invalid camera: " + why);
    return camera;
  } catch (const YAML::Exception& e) {
    throw DatasetError(path + ": bad value: " + e.what());
  }
}

void writeCameraInfoYaml(const std::string& path, const PinholeCamera& camera,
                         const std::string& camera_name) {
  std::ostringstream out;
  out << "image_width: " << camera.width() << "\n";
  out << "image_height: " << camera.height() << "\n";
  out << "camera_name: " << (camera_name.empty() ? "camera" : camera_name) << "\n";
  writeMatrix(out, "camera_matrix", 3, 3,
              {camera.fx(), 0.0, camera.cx(), 0.0, camera.fy(), camera.cy(), 0.0, 0.0, 1.0});
  std::string model = camera.distortionModel();
  std::vector<double> distortion = camera.distortion();
  if (model.empty()) {  // ROS has no "none": an ideal camera is plumb_bob with zero coefficients
    model = "plumb_bob";
    distortion.assign(5, 0.0);
  }
  out << "distortion_model: " << model << "\n";
  writeMatrix(out, "distortion_coefficients", 1, static_cast<int>(distortion.size()), distortion);
  writeMatrix(out, "rectification_matrix", 3, 3, {1, 0, 0, 0, 1, 0, 0, 0, 1});
  writeMatrix(out, "projection_matrix", 3, 4,
              {camera.fx(), 0.0, camera.cx(), 0.0, 0.0, camera.fy(), camera.cy(), 0.0, 0.0, 0.0, 1.0, 0.0});
  std::ofstream file(path);
  if (!file || !(file << out.str()) || !file.flush()) throw DatasetError("cannot write " + path);
}

}  // namespace planetary_vo

#include "planetary_vo/render/dem.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <yaml-cpp/yaml.h>
#include <opencv2/imgcodecs.hpp>

namespace planetary_vo::render {

std::shared_ptr<const LunarDem> LunarDem::load(const std::string& yaml_path) {
  YAML::Node node;
  try {
    node = YAML::LoadFile(yaml_path);
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot read DEM sidecar " + yaml_path + ": " + e.what());
  }
  for (const char* key : {"image", "pixel_size_east_m", "pixel_size_north_m"}) {
    if (!node[key]) throw std::runtime_error("DEM sidecar " + yaml_path + " has no '" + key + "'");
  }
  const std::string dir =
      yaml_path.find('/') == std::string::npos ? "." : yaml_path.substr(0, yaml_path.rfind('/'));
  const std::string image_path = dir + "/" + node["image"].as<std::string>();
  const cv::Mat raw = cv::imread(image_path, cv::IMREAD_UNCHANGED);
  if (raw.empty()) throw std::runtime_error("cannot read DEM image " + image_path);
  if (raw.type() != CV_16UC1)
    throw std::runtime_error("DEM image " + image_path + " is not 16-bit single channel");
  cv::Mat1f elevation;
  raw.convertTo(elevation, CV_32F, 1.0, -10000.0);  // encoding: elevation_m = png_value - 10000
  std::string name = yaml_path.substr(yaml_path.rfind('/') + 1);
  name = name.substr(0, name.rfind('.'));
  auto dem = std::make_shared<LunarDem>(elevation, node["pixel_size_east_m"].as<double>(),
                                        node["pixel_size_north_m"].as<double>(), name);
  dem->path_ = yaml_path;
  return dem;
}

LunarDem::LunarDem(cv::Mat1f elevation_m, double pixel_east_m, double pixel_north_m, std::string name)
    : elevation_(std::move(elevation_m)),
      pixel_east_m_(pixel_east_m),
      pixel_north_m_(pixel_north_m),
      name_(std::move(name)) {
  if (elevation_.rows < 4 || elevation_.cols < 4 || !(pixel_east_m > 0) || !(pixel_north_m > 0))
    throw std::runtime_error("DEM " + name_ + ": grid too small or bad pixel size");
}

namespace {
// Catmull-Rom weights: C1 interpolation that passes through the samples (no smoothing of the real relief).
inline void cubicWeights(double t, double w[4]) {
  const double t2 = t * t, t3 = t2 * t;
  w[0] = 0.5 * (-t3 + 2 * t2 - t);
  w[1] = 0.5 * (3 * t3 - 5 * t2 + 2);
  w[2] = 0.5 * (-3 * t3 + 4 * t2 + t);
  w[3] = 0.5 * (t3 - t2);
}
}  // namespace

double LunarDem::height(double east_m, double north_m) const {
  const double col = (east_m + halfWidthEastM()) / pixel_east_m_ - 0.5;
  const double row = (halfHeightNorthM() - north_m) / pixel_north_m_ - 0.5;
  const double c0 = std::floor(col), r0 = std::floor(row);
  double wc[4], wr[4];
  cubicWeights(col - c0, wc);
  cubicWeights(row - r0, wr);
  const int ci = static_cast<int>(c0), ri = static_cast<int>(r0);
  double sum = 0.0;
  for (int a = 0; a < 4; ++a) {
    const int r = std::clamp(ri - 1 + a, 0, elevation_.rows - 1);
    const float* line = elevation_[r];
    double s = 0.0;
    for (int b = 0; b < 4; ++b) s += wc[b] * line[std::clamp(ci - 1 + b, 0, elevation_.cols - 1)];
    sum += wr[a] * s;
  }
  return sum;
}

Eigen::Vector2d DemPlacement::worldToDem(double x, double y) const {
  const double c = std::cos(heading_rad), s = std::sin(heading_rad);
  return {origin_east_m + c * x + s * y, origin_north_m - s * x + c * y};
}

}  // namespace planetary_vo::render

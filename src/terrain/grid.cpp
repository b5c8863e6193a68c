#include "planetary_vo/terrain/grid.h"

#include <cctype>
#include <cmath>
#include <fstream>

#include <yaml-cpp/yaml.h>
#include <opencv2/imgcodecs.hpp>

namespace planetary_vo::terrain {

GridGeometry GridGeometry::centeredOnOrigin(double half_extent_m, double cell_size_m) {
  if (!(cell_size_m > 0.0) || !(half_extent_m >= cell_size_m))
    throw std::invalid_argument("grid: need 0 < cell size <= half extent");
  const int half_cells = static_cast<int>(std::lround(half_extent_m / cell_size_m));
  GridGeometry g;
  g.cell_size_m = cell_size_m;
  g.cols = g.rows = 2 * half_cells + 1;
  g.x0_m = g.y0_m = -half_cells * cell_size_m;
  return g;
}

bool GridGeometry::cellAt(double x_m, double y_m, int* col, int* row) const {
  const double c = std::floor((x_m - x0_m) / cell_size_m + 0.5);
  const double r = std::floor((y_m - y0_m) / cell_size_m + 0.5);
  if (!(c >= 0.0 && r >= 0.0 && c < cols && r < rows)) return false;  // also false for NaN
  *col = static_cast<int>(c);
  *row = static_cast<int>(r);
  return true;
}

cv::Mat GridGeometry::newLayer(float value) const { return cv::Mat(rows, cols, CV_32FC1, cv::Scalar(value)); }

namespace {

constexpr const char* kFormat = "planetary_vo terrain grids 1";

std::string layerFile(const std::string& name, const std::string& layer) {
  return name + "_" + layer + ".tiff";
}

bool validName(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) return false;
  return true;
}

}  // namespace

void writeGridSet(const std::string& dir, const std::string& name, const GridSet& grids) {
  const std::string yaml_path = dir + "/" + name + ".yaml";
  if (!validName(name)) throw GridFileError(yaml_path + ": grid set name must be [A-Za-z0-9_]+");
  const GridGeometry& g = grids.geometry;
  if (g.cols <= 0 || g.rows <= 0 || !(g.cell_size_m > 0.0))
    throw GridFileError(yaml_path + ": empty grid or non-positive cell size");
  for (const auto& [layer, mat] : grids.layers) {
    if (!validName(layer))
      throw GridFileError(yaml_path + ": layer name '" + layer + "' must be [A-Za-z0-9_]+");
    if (mat.type() != CV_32FC1 || mat.rows != g.rows || mat.cols != g.cols)
      throw GridFileError(yaml_path + ": layer '" + layer + "' is not a " + std::to_string(g.rows) + "x" +
                          std::to_string(g.cols) + " CV_32FC1 matrix");
  }

  YAML::Emitter y;
  y.SetDoublePrecision(17);
  y << YAML::BeginMap;
  y << YAML::Key << "format" << YAML::Value << kFormat;
  y << YAML::Key << "description" << YAML::Value << grids.description;
  y << YAML::Key << "frame" << YAML::Value
    << "landing-site world frame: origin at the landing site, x crossrange, y downrange, z up";
  y << YAML::Key << "geometry" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "x0_m" << YAML::Value << g.x0_m << YAML::Comment("world x of the centre of cell (0, 0)");
  y << YAML::Key << "y0_m" << YAML::Value << g.y0_m << YAML::Comment("world y of the centre of cell (0, 0)");
  y << YAML::Key << "cell_size_m" << YAML::Value << g.cell_size_m;
  y << YAML::Key << "cols" << YAML::Value << g.cols << YAML::Comment("along +x");
  y << YAML::Key << "rows" << YAML::Value << g.rows << YAML::Comment("along +y (row 0 = smallest y)");
  y << YAML::EndMap;
  y << YAML::Key << "unknown_value" << YAML::Value << "nan";
  y << YAML::Key << "layers" << YAML::Value << YAML::BeginMap;
  for (const auto& entry : grids.layers)
    y << YAML::Key << entry.first << YAML::Value << layerFile(name, entry.first);
  y << YAML::EndMap;
  y << YAML::Key << "parameters" << YAML::Value << YAML::BeginMap;
  for (const auto& [key, value] : grids.parameters) y << YAML::Key << key << YAML::Value << value;
  y << YAML::EndMap;
  y << YAML::EndMap;
  if (!y.good()) throw GridFileError(yaml_path + ": " + y.GetLastError());

  // 32-bit float TIFF, lossless: every float (and NaN) reads back bit for bit.
  for (const auto& [layer, mat] : grids.layers) {
    const std::string path = dir + "/" + layerFile(name, layer);
    bool ok = false;
    try {
      ok = cv::imwrite(path, mat);
    } catch (const cv::Exception& e) {
      throw GridFileError(path + ": " + e.what());
    }
    if (!ok) throw GridFileError(path + ": cannot write");
  }
  std::ofstream out(yaml_path);
  out << "# Terrain grids (planetary_vo terrain/grid.h): one 32-bit float TIFF per layer, NaN = unknown\n";
  out << y.c_str() << "\n";
  if (!out) throw GridFileError(yaml_path + ": cannot write");
}

GridSet readGridSet(const std::string& dir, const std::string& name) {
  const std::string yaml_path = dir + "/" + name + ".yaml";
  YAML::Node y;
  try {
    y = YAML::LoadFile(yaml_path);
  } catch (const YAML::Exception& e) {
    throw GridFileError(yaml_path + ": " + e.what());
  }
  GridSet grids;
  try {
    if (!y["format"] || y["format"].as<std::string>() != kFormat)
      throw GridFileError(yaml_path + ": not a '" + kFormat + "' file");
    const YAML::Node g = y["geometry"];
    if (!g) throw GridFileError(yaml_path + ": no geometry");
    grids.geometry.x0_m = g["x0_m"].as<double>();
    grids.geometry.y0_m = g["y0_m"].as<double>();
    grids.geometry.cell_size_m = g["cell_size_m"].as<double>();
    grids.geometry.cols = g["cols"].as<int>();
    grids.geometry.rows = g["rows"].as<int>();
    if (y["description"]) grids.description = y["description"].as<std::string>();
    for (const auto& p : y["parameters"]) grids.parameters[p.first.as<std::string>()] = p.second.as<double>();
    for (const auto& l : y["layers"]) {
      const std::string layer = l.first.as<std::string>();
      const std::string path = dir + "/" + l.second.as<std::string>();
      std::ifstream probe(path);  // imread only warns on a missing file
      if (!probe) throw GridFileError(path + ": missing or unreadable");
      cv::Mat mat = cv::imread(path, cv::IMREAD_UNCHANGED);
      if (mat.empty()) throw GridFileError(path + ": missing or unreadable");
      if (mat.type() != CV_32FC1 || mat.rows != grids.geometry.rows || mat.cols != grids.geometry.cols)
        throw GridFileError(path + ": expected a " + std::to_string(grids.geometry.rows) + "x" +
                            std::to_string(grids.geometry.cols) + " 32-bit float single-channel image");
      grids.layers[layer] = mat;
    }
  } catch (const YAML::Exception& e) {
    throw GridFileError(yaml_path + ": " + e.what());
  }
  if (grids.geometry.cols <= 0 || grids.geometry.rows <= 0 || !(grids.geometry.cell_size_m > 0.0))
    throw GridFileError(yaml_path + ": empty grid or non-positive cell size");
  return grids;
}

}  // namespace planetary_vo::terrain

#include "dataset_internal.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include <Eigen/SVD>
#include <opencv2/imgcodecs.hpp>

namespace planetary_vo {
namespace dataset_internal {

namespace fs = std::filesystem;

namespace {
std::string where(const std::string& path, const TextRow& row) {
  return path + ":" + std::to_string(row.line_number) + ": ";
}
}  // namespace

std::vector<TextRow> readTextTable(const std::string& path, bool comma_separated) {
  std::ifstream in(path);
  if (!in) throw DatasetError("cannot open " + path);
  std::vector<TextRow> rows;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();  // files written on Windows
    const size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    if (comma_separated) std::replace(line.begin(), line.end(), ',', ' ');
    TextRow row;
    row.line_number = line_number;
    std::istringstream tokens(line);
    for (std::string token; tokens >> token;) row.tokens.push_back(token);
    rows.push_back(std::move(row));
  }
  return rows;
}

double parseDouble(const std::string& path, const TextRow& row, size_t index) {
  requireColumns(path, row, index + 1, false);
  const std::string& token = row.tokens[index];
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(token.c_str(), &end);
  if (end == token.c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(value))
    throw DatasetError(where(path, row) + "value " + std::to_string(index + 1) + " '" + token +
                       "' is not a finite number");
  return value;
}

double parseRangeOrInf(const std::string& path, const TextRow& row, size_t index) {
  requireColumns(path, row, index + 1, false);
  const std::string& token = row.tokens[index];
  if (token == "inf" || token == "+inf" || token == "Inf") return std::numeric_limits<double>::infinity();
  const double value = parseDouble(path, row, index);
  if (value < 0.0)
    throw DatasetError(where(path, row) + "value " + std::to_string(index + 1) + " '" + token +
                       "' is a negative range");
  return value;
}

long long parseInt64(const std::string& path, const TextRow& row, size_t index) {
  requireColumns(path, row, index + 1, false);
  const std::string& token = row.tokens[index];
  char* end = nullptr;
  errno = 0;
  const long long value = std::strtoll(token.c_str(), &end, 10);
  if (end == token.c_str() || *end != '\0' || errno == ERANGE)
    throw DatasetError(where(path, row) + "value " + std::to_string(index + 1) + " '" + token +
                       "' is not an integer");
  return value;
}

void requireColumns(const std::string& path, const TextRow& row, size_t n, bool exact) {
  const size_t got = row.tokens.size();
  if (got < n || (exact && got != n))
    throw DatasetError(where(path, row) + "expected " + (exact ? "" : "at least ") + std::to_string(n) +
                       " values, got " + std::to_string(got));
}

void requireIncreasing(const std::string& path, const TextRow& row, double previous_s, double current_s) {
  if (!(current_s > previous_s)) {
    char text[128];
    std::snprintf(text, sizeof(text), "time stamp %.9f is not after the previous one (%.9f)", current_s,
                  previous_s);
    throw DatasetError(where(path, row) + text);
  }
}

double nanosecondsToSeconds(long long stamp_ns) {
  const long long seconds = stamp_ns / 1000000000LL;
  const long long remainder_ns = stamp_ns % 1000000000LL;
  return static_cast<double>(seconds) + static_cast<double>(remainder_ns) * 1e-9;
}

std::string formatDouble(double value) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.15g", value);
  if (std::strtod(text, nullptr) != value) std::snprintf(text, sizeof(text), "%.17g", value);
  return text;
}

Eigen::Matrix3d orthonormalized(const Eigen::Matrix3d& R) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

bool isFile(const std::string& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

bool isDirectory(const std::string& path) {
  std::error_code ec;
  return fs::is_directory(path, ec);
}

std::vector<std::string> listImages(const std::string& directory) {
  std::vector<std::string> paths;
  std::error_code ec;
  for (fs::directory_iterator it(directory, ec), end; !ec && it != end; it.increment(ec)) {
    if (!it->is_regular_file()) continue;
    std::string ext = it->path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".pgm" || ext == ".ppm")
      paths.push_back(it->path().string());
  }
  if (ec) throw DatasetError("cannot list " + directory + ": " + ec.message());
  std::sort(paths.begin(), paths.end());
  return paths;
}

std::string baseName(const std::string& path) {
  fs::path p = fs::absolute(path).lexically_normal();  // "a/b/", "a/b/." -> ".../a/b/"
  if (p.filename().empty()) p = p.parent_path();
  return p.filename().string();
}

cv::Size imageSize(const std::string& path) {
  const cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (image.empty()) throw DatasetError("cannot read image " + path);
  return image.size();
}

std::string readWholeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw DatasetError("cannot open " + path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

YAML::Node loadYamlFile(const std::string& path) {
  try {
    return YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw DatasetError("cannot open " + path);
  } catch (const YAML::Exception& e) {
    throw DatasetError(path + ": not valid YAML: " + e.what());
  }
}

}  // namespace dataset_internal

}  // namespace planetary_vo

#pragma once
/// @file dataset_internal.h
/// Helpers shared by the dataset readers and writer (not installed, not part of the public API).

#include <yaml-cpp/yaml.h>
#include <string>
#include <vector>

#include "planetary_vo/dataset/dataset.h"

namespace planetary_vo {
namespace dataset_internal {

/// One non-empty, non-comment line of a text table, split into tokens.
struct TextRow {
  int line_number = 0;  ///< 1-based line number in the file
  std::vector<std::string> tokens;
};

/// Reads a text table: '#' starts a comment line, blank lines are skipped, tokens are separated by whitespace
/// and, if `comma_separated`, by commas. Throws DatasetError if the file cannot be opened.
std::vector<TextRow> readTextTable(const std::string& path, bool comma_separated);

/// Parses tokens[index] as a double; throws DatasetError "path:line: ..." if it is not a finite number.
double parseDouble(const std::string& path, const TextRow& row, size_t index);
/// A range: a finite number >= 0, or "inf" (no return); throws DatasetError otherwise.
double parseRangeOrInf(const std::string& path, const TextRow& row, size_t index);
/// Parses tokens[index] as a signed 64-bit integer (EuRoC nanosecond stamps); throws DatasetError otherwise.
long long parseInt64(const std::string& path, const TextRow& row, size_t index);
/// Throws DatasetError "path:line: expected N values, got M" unless the row has at least `n` tokens (exactly
/// `n` when `exact`).
void requireColumns(const std::string& path, const TextRow& row, size_t n, bool exact);
/// Throws DatasetError "path:line: time stamp ... is not after the previous one" unless stamps increase
/// strictly.
void requireIncreasing(const std::string& path, const TextRow& row, double previous_s, double current_s);

/// EuRoC nanosecond stamp to seconds, exact to the double's resolution.
double nanosecondsToSeconds(long long stamp_ns);

/// Formats a double with the fewest significant digits (15 or 17) that read back to the same value.
std::string formatDouble(double value);

/// Nearest rotation matrix (SVD projection) to a slightly non-orthonormal 3x3 matrix such as a printed one.
Eigen::Matrix3d orthonormalized(const Eigen::Matrix3d& R);

bool isFile(const std::string& path);
bool isDirectory(const std::string& path);
/// Paths of the regular files in `directory` whose extension (lower case) is .png, .jpg, .jpeg, .pgm or .ppm,
/// sorted by name.
std::vector<std::string> listImages(const std::string& directory);
/// Last component of a path, ignoring trailing slashes.
std::string baseName(const std::string& path);
/// Image size read from the file (throws DatasetError if unreadable).
cv::Size imageSize(const std::string& path);
/// Reads the whole file as text; throws DatasetError if it cannot be opened.
std::string readWholeFile(const std::string& path);

/// Parses a YAML file; a missing file or bad YAML becomes a DatasetError naming the file.
YAML::Node loadYamlFile(const std::string& path);

}  // namespace dataset_internal

/// The format readers; a friend of Dataset so that they fill its fields directly.
class DatasetReaders {
 public:
  static Dataset readPlanetaryVo(const std::string& directory);
  static Dataset readKitti(const std::string& directory);
  static Dataset readEuroc(const std::string& directory);
  static Dataset readTumRgbd(const std::string& directory);

  /// Keeps only the images whose stamp lies within the span of `samples` and sets their ground truth by
  /// interpolation. Used by the readers whose ground truth is sampled at other stamps than the images.
  static void setInterpolatedGroundTruth(Dataset* dataset, const Trajectory& samples);
  static void checkConsistent(const Dataset& dataset);
};

}  // namespace planetary_vo

/// @file read_kitti.cpp
/// Reader of a KITTI odometry sequence folder: image_0/ (or image_l/, image_2/), calib.txt, optional
/// times.txt, poses from poses.txt in the folder or from ../../poses/<sequence>.txt (the benchmark's own
/// layout).

#include "dataset_internal.h"
#include "planetary_vo/dataset/dataset.h"

namespace planetary_vo {

using namespace dataset_internal;

namespace {

constexpr double kKittiRateHz = 10.0;

/// P0 from calib.txt: the line labelled "P0:" or, in files without labels, the first line.
Eigen::Matrix<double, 3, 4> readP0(const std::string& path) {
  const std::vector<TextRow> rows = readTextTable(path, false);
  for (const TextRow& row : rows) {
    const bool labelled = !row.tokens.empty() && row.tokens[0].back() == ':';
    if (labelled && row.tokens[0] != "P0:") continue;
    if (!labelled && &row != &rows.front()) continue;
    const size_t first = labelled ? 1 : 0;
    requireColumns(path, row, first + 12, true);
    Eigen::Matrix<double, 3, 4> P;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) P(r, c) = parseDouble(path, row, first + 4 * r + c);
    return P;
  }
  throw DatasetError(path + ": no P0 projection matrix");
}

}  // namespace

Dataset DatasetReaders::readKitti(const std::string& directory) {
  const std::string d = directory + "/";
  Dataset dataset;
  dataset.format_ = DatasetFormat::kKitti;
  dataset.directory_ = directory;
  dataset.name_ = baseName(directory);

  std::string image_dir;
  for (const char* candidate : {"image_0", "image_l", "image_2"})
    if (isDirectory(d + candidate)) {
      image_dir = d + candidate;
      break;
    }
  if (image_dir.empty())
    throw DatasetError(directory + ": KITTI folder without image_0/, image_l/ or image_2/");
  dataset.image_paths_ = listImages(image_dir);
  if (dataset.image_paths_.empty()) throw DatasetError(image_dir + ": no image");

  const Eigen::Matrix<double, 3, 4> P0 = readP0(d + "calib.txt");
  const cv::Size size = imageSize(dataset.image_paths_.front());
  dataset.camera_ = PinholeCamera(size.width, size.height, P0(0, 0), P0(1, 1), P0(0, 2), P0(1, 2));

  if (isFile(d + "times.txt")) {
    const std::string path = d + "times.txt";
    for (const TextRow& row : readTextTable(path, false)) {
      requireColumns(path, row, 1, true);
      const double t = parseDouble(path, row, 0);
      if (!dataset.timestamps_s_.empty()) requireIncreasing(path, row, dataset.timestamps_s_.back(), t);
      dataset.timestamps_s_.push_back(t);
    }
  } else {
    for (size_t i = 0; i < dataset.image_paths_.size(); ++i)
      dataset.timestamps_s_.push_back(static_cast<double>(i) / kKittiRateHz);
  }

  std::string poses_path = d + "poses.txt";
  if (!isFile(poses_path)) poses_path = d + "../../poses/" + dataset.name_ + ".txt";
  if (isFile(poses_path)) {
    dataset.ground_truth_ = readKittiTrajectory(poses_path, kKittiRateHz);
    if (dataset.ground_truth_.size() != dataset.timestamps_s_.size())
      throw DatasetError(poses_path + ": " + std::to_string(dataset.ground_truth_.size()) + " poses for " +
                         std::to_string(dataset.timestamps_s_.size()) + " images");
    for (size_t i = 0; i < dataset.ground_truth_.size(); ++i)
      dataset.ground_truth_[i].timestamp_s = dataset.timestamps_s_[i];
  }
  checkConsistent(dataset);
  return dataset;
}

}  // namespace planetary_vo

/// @file dataset.cpp
/// Format detection, image loading and the checks shared by all readers.

#include "planetary_vo/dataset/dataset.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dataset_internal.h"

namespace planetary_vo {

using namespace dataset_internal;

const char* toString(DatasetFormat format) {
  switch (format) {
    case DatasetFormat::kPlanetaryVo:
      return "planetary_vo";
    case DatasetFormat::kKitti:
      return "kitti";
    case DatasetFormat::kEuroc:
      return "euroc";
    case DatasetFormat::kTumRgbd:
      return "tum_rgbd";
  }
  return "unknown";
}

Dataset Dataset::open(const std::string& directory) {
  if (!isDirectory(directory)) throw DatasetError("dataset folder " + directory + " does not exist");
  const std::string d = directory + "/";
  // The planetary_vo layout first: its groundtruth.txt would otherwise look like a TUM folder's.
  if (isDirectory(d + "images") && isFile(d + "camera.yaml"))
    return DatasetReaders::readPlanetaryVo(directory);
  if (isFile(d + "mav0/cam0/data.csv") || isFile(d + "cam0/data.csv"))
    return DatasetReaders::readEuroc(directory);
  if (isFile(d + "rgb.txt")) return DatasetReaders::readTumRgbd(directory);
  if (isFile(d + "calib.txt")) return DatasetReaders::readKitti(directory);
  throw DatasetError("unknown dataset layout in " + directory +
                     ": expected images/ + camera.yaml (planetary_vo), mav0/cam0/data.csv (EuRoC), rgb.txt "
                     "(TUM RGB-D) or calib.txt + image_0/ (KITTI)");
}

cv::Mat Dataset::loadImageUnchanged(size_t i) const {
  const std::string& path = imagePath(i);
  cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (image.empty()) throw DatasetError("cannot read image " + path);
  return image;
}

cv::Mat Dataset::loadImage(size_t i) const {
  cv::Mat image = loadImageUnchanged(i);
  if (image.channels() == 3) {
    cv::cvtColor(image, image, cv::COLOR_BGR2GRAY);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, image, cv::COLOR_BGRA2GRAY);
  }
  if (image.depth() == CV_16U) {
    image.convertTo(image, CV_8U, 1.0 / 257.0);  // 65535 -> 255
  } else if (image.depth() != CV_8U) {
    throw DatasetError("image " + imagePath(i) + " has an unsupported pixel depth");
  }
  if (image.channels() != 1)
    throw DatasetError("image " + imagePath(i) + " has an unsupported channel count");
  return image;
}

void DatasetReaders::setInterpolatedGroundTruth(Dataset* dataset, const Trajectory& samples) {
  std::vector<double> stamps;
  std::vector<std::string> paths;
  Trajectory ground_truth;
  for (size_t i = 0; i < dataset->size(); ++i) {
    StampedPose pose;
    pose.timestamp_s = dataset->timestamps_s_[i];
    if (!interpolatePose(samples, pose.timestamp_s, &pose.T_world_cam)) continue;
    stamps.push_back(pose.timestamp_s);
    paths.push_back(dataset->image_paths_[i]);
    ground_truth.push_back(pose);
  }
  if (ground_truth.empty())
    throw DatasetError(dataset->directory_ + ": no image stamp lies within the ground-truth time span");
  dataset->timestamps_s_ = std::move(stamps);
  dataset->image_paths_ = std::move(paths);
  dataset->ground_truth_ = std::move(ground_truth);
}

void DatasetReaders::checkConsistent(const Dataset& dataset) {
  const std::string& dir = dataset.directory_;
  if (dataset.timestamps_s_.empty()) throw DatasetError(dir + ": the dataset has no image");
  if (dataset.image_paths_.size() != dataset.timestamps_s_.size())
    throw DatasetError(dir + ": " + std::to_string(dataset.image_paths_.size()) + " images but " +
                       std::to_string(dataset.timestamps_s_.size()) + " time stamps");
  if (!dataset.ground_truth_.empty() && dataset.ground_truth_.size() != dataset.timestamps_s_.size())
    throw DatasetError(dir + ": " + std::to_string(dataset.image_paths_.size()) + " images but " +
                       std::to_string(dataset.ground_truth_.size()) + " ground-truth poses");
  for (size_t i = 1; i < dataset.timestamps_s_.size(); ++i)
    if (!(dataset.timestamps_s_[i] > dataset.timestamps_s_[i - 1]))
      throw DatasetError(dir + ": image time stamps do not increase at image " + std::to_string(i));
  std::string why;
  if (!dataset.camera_.isValid(&why)) throw DatasetError(dir + ": invalid camera: " + why);
}

}  // namespace planetary_vo

/// @file dataset_writer.cpp
/// Writer of the planetary_vo format (docs/dataset_format.md).

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include <yaml-cpp/yaml.h>
#include <opencv2/imgcodecs.hpp>

#include "dataset_internal.h"
#include "planetary_vo/dataset/dataset.h"

namespace planetary_vo {

using namespace dataset_internal;

namespace {

using File = std::unique_ptr<FILE, int (*)(FILE*)>;

File openForWriting(const std::string& path) {
  File file(std::fopen(path.c_str(), "w"), &std::fclose);
  if (!file) throw DatasetError("cannot write " + path);
  return file;
}

void closeChecked(File& file, const std::string& path) {
  const bool failed = std::ferror(file.get()) != 0;
  if (std::fclose(file.release()) != 0 || failed) throw DatasetError("error while writing " + path);
}

std::string sequenceName(const std::string& yaml_text) {
  try {
    const YAML::Node root = YAML::Load(yaml_text);
    if (root.IsMap() && root["name"] && root["name"].IsScalar()) return root["name"].as<std::string>();
  } catch (const YAML::Exception&) {
  }
  return "";
}

}  // namespace

DatasetWriter::DatasetWriter(const std::string& directory, const PinholeCamera& camera)
    : directory_(directory), camera_(camera) {
  std::string why;
  if (!camera.isValid(&why)) throw DatasetError("DatasetWriter(" + directory + "): invalid camera: " + why);
  std::error_code ec;
  std::filesystem::create_directories(directory + "/images", ec);
  if (ec || !isDirectory(directory + "/images"))
    throw DatasetError("cannot create " + directory + "/images: " + ec.message());
}

DatasetWriter::~DatasetWriter() {
  try {
    finish();
  } catch (const std::exception& e) {
    std::cerr << "DatasetWriter: " << e.what() << std::endl;  // a destructor must not throw
  }
}

void DatasetWriter::addFrame(double timestamp_s, const cv::Mat& image, const Pose& T_world_cam) {
  if (image.empty() || image.channels() != 1 || (image.depth() != CV_8U && image.depth() != CV_16U))
    throw DatasetError("DatasetWriter::addFrame: image must be 8- or 16-bit single-channel");
  if (image.cols != camera_.width() || image.rows != camera_.height())
    throw DatasetError("DatasetWriter::addFrame: image is " + std::to_string(image.cols) + "x" +
                       std::to_string(image.rows) + ", the camera " + std::to_string(camera_.width()) + "x" +
                       std::to_string(camera_.height()));
  if (!timestamps_s_.empty() && !(timestamp_s > timestamps_s_.back()))
    throw DatasetError("DatasetWriter::addFrame: time stamps must increase");
  char name[32];
  std::snprintf(name, sizeof(name), "/images/%06zu.png", timestamps_s_.size());
  const std::string path = directory_ + name;
  bool written = false;
  try {
    written = cv::imwrite(path, image, {cv::IMWRITE_PNG_COMPRESSION, 3});
  } catch (const cv::Exception& e) {
    throw DatasetError("cannot write " + path + ": " + e.what());
  }
  if (!written) throw DatasetError("cannot write " + path);
  timestamps_s_.push_back(timestamp_s);
  ground_truth_.push_back({timestamp_s, T_world_cam});
  finished_ = false;
}

void DatasetWriter::addImu(const ImuSample& sample) {
  imu_.push_back(sample);
  finished_ = false;
}

void DatasetWriter::addAltimeter(const AltimeterSample& sample) {
  altimeter_.push_back(sample);
  finished_ = false;
}

void DatasetWriter::setSequenceYaml(const std::string& yaml_text) {
  sequence_yaml_ = yaml_text;
  finished_ = false;
}

void DatasetWriter::finish() {
  if (finished_) return;
  const std::string d = directory_ + "/";
  writeTumTrajectory(d + "groundtruth.txt", ground_truth_);

  File times = openForWriting(d + "times.txt");
  std::fprintf(times.get(), "# timestamp[s] of images/NNNNNN.png, one line per image\n");
  for (double t : timestamps_s_) std::fprintf(times.get(), "%.9f\n", t);
  closeChecked(times, d + "times.txt");

  std::string camera_name = sequenceName(sequence_yaml_);
  writeCameraInfoYaml(d + "camera.yaml", camera_, camera_name.empty() ? "planetary_vo_camera" : camera_name);

  File imu = openForWriting(d + "imu.txt");
  std::fprintf(
      imu.get(),
      "# timestamp[s] wx wy wz[rad/s] ax ay az[m/s^2]: body angular rate and specific force, body = camera "
      "optical frame\n");
  for (const ImuSample& s : imu_) {
    const Eigen::Vector3d& w = s.angular_velocity_radps;
    const Eigen::Vector3d& a = s.specific_force_mps2;
    std::fprintf(imu.get(), "%.9f %s %s %s %s %s %s\n", s.timestamp_s, formatDouble(w.x()).c_str(),
                 formatDouble(w.y()).c_str(), formatDouble(w.z()).c_str(), formatDouble(a.x()).c_str(),
                 formatDouble(a.y()).c_str(), formatDouble(a.z()).c_str());
  }
  closeChecked(imu, d + "imu.txt");

  File altimeter = openForWriting(d + "altimeter.txt");
  std::fprintf(altimeter.get(), "# timestamp[s] slant_range_m altitude_m\n");
  for (const AltimeterSample& s : altimeter_)
    std::fprintf(altimeter.get(), "%.9f %s %s\n", s.timestamp_s, formatDouble(s.slant_range_m).c_str(),
                 formatDouble(s.altitude_m).c_str());
  closeChecked(altimeter, d + "altimeter.txt");

  std::ofstream sequence(d + "sequence.yaml", std::ios::binary);
  if (!sequence || !(sequence << sequence_yaml_) || !sequence.flush())
    throw DatasetError("cannot write " + d + "sequence.yaml");
  finished_ = true;
}

}  // namespace planetary_vo

/// @file dataset_writer.cpp
/// Writer of the planetary_vo format (docs/dataset_format.md).

#include <cmath>
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

void DatasetWriter::addExistingFrame(double timestamp_s, const Pose& T_world_cam) {
  if (!timestamps_s_.empty() && !(timestamp_s > timestamps_s_.back()))
    throw DatasetError("DatasetWriter::addExistingFrame: time stamps must increase");
  char name[32];
  std::snprintf(name, sizeof(name), "/images/%06zu.png", timestamps_s_.size());
  if (!isFile(directory_ + name))
    throw DatasetError("DatasetWriter::addExistingFrame: no " + directory_ + name);
  timestamps_s_.push_back(timestamp_s);
  ground_truth_.push_back({timestamp_s, T_world_cam});
  finished_ = false;
}

void DatasetWriter::addGroundTruthState(const GroundTruthState& state) {
  if (!ground_truth_state_.empty() && !(state.timestamp_s > ground_truth_state_.back().timestamp_s))
    throw DatasetError("DatasetWriter::addGroundTruthState: time stamps must increase");
  ground_truth_state_.push_back(state);
  finished_ = false;
}

void DatasetWriter::addAltimeterTruth(const AltimeterTruth& truth) {
  altimeter_truth_.push_back(truth);
  finished_ = false;
}

void DatasetWriter::setTrueCamera(const PinholeCamera& camera) {
  true_camera_ = camera;
  has_true_camera_ = true;
  finished_ = false;
}

void DatasetWriter::setTextFile(const std::string& file_name, const std::string& text) {
  if (file_name.empty() || file_name.find('/') != std::string::npos)
    throw DatasetError("DatasetWriter::setTextFile: '" + file_name + "' is not a plain file name");
  text_files_[file_name] = text;
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
  std::fprintf(altimeter.get(),
               "# timestamp[s] slant_range_m (measured along the boresight; inf = no return)\n");
  for (const AltimeterSample& s : altimeter_)
    std::fprintf(altimeter.get(), "%.9f %s\n", s.timestamp_s,
                 s.hasReturn() ? formatDouble(s.slant_range_m).c_str() : "inf");
  closeChecked(altimeter, d + "altimeter.txt");

  if (!ground_truth_state_.empty()) {
    File gt = openForWriting(d + "groundtruth_state.txt");
    std::fprintf(
        gt.get(),
        "# GROUND TRUTH (evaluator only) timestamp[s] px py pz[m] qx qy qz qw: T_world_body; vx vy vz[m/s] "
        "world; bgx bgy bgz[rad/s] bax bay baz[m/s^2]: true IMU biases, IMU frame\n");
    for (const GroundTruthState& g : ground_truth_state_) {
      const Eigen::Vector3d& p = g.T_world_body.translation();
      const Eigen::Quaterniond q(g.T_world_body.linear());
      std::fprintf(gt.get(), "%.9f %.9f %.9f %.9f %.12f %.12f %.12f %.12f", g.timestamp_s, p.x(), p.y(),
                   p.z(), q.x(), q.y(), q.z(), q.w());
      for (const Eigen::Vector3d* v : {&g.velocity_world_mps, &g.gyro_bias_radps, &g.accel_bias_mps2})
        for (int k = 0; k < 3; ++k) std::fprintf(gt.get(), " %s", formatDouble((*v)[k]).c_str());
      std::fprintf(gt.get(), "\n");
    }
    closeChecked(gt, d + "groundtruth_state.txt");
  }
  if (!altimeter_truth_.empty()) {
    File gt = openForWriting(d + "groundtruth_altimeter.txt");
    std::fprintf(
        gt.get(),
        "# GROUND TRUTH (evaluator only) timestamp[s] true_range_m altitude_m incidence_deg returned "
        "outlier\n");
    for (const AltimeterTruth& a : altimeter_truth_)
      std::fprintf(gt.get(), "%.9f %s %s %s %d %d\n", a.timestamp_s,
                   std::isfinite(a.true_range_m) ? formatDouble(a.true_range_m).c_str() : "inf",
                   formatDouble(a.altitude_m).c_str(),
                   std::isfinite(a.incidence_deg) ? formatDouble(a.incidence_deg).c_str() : "nan",
                   a.returned ? 1 : 0, a.outlier ? 1 : 0);
    closeChecked(gt, d + "groundtruth_altimeter.txt");
  }
  if (has_true_camera_) {
    std::string camera_name = sequenceName(sequence_yaml_);
    writeCameraInfoYaml(d + "groundtruth_camera.yaml", true_camera_,
                        (camera_name.empty() ? "planetary_vo_camera" : camera_name) + "_true");
  }
  for (const auto& [name, text] : text_files_) {
    std::ofstream out(d + name, std::ios::binary);
    if (!out || !(out << text) || !out.flush()) throw DatasetError("cannot write " + d + name);
  }

  std::ofstream sequence(d + "sequence.yaml", std::ios::binary);
  if (!sequence || !(sequence << sequence_yaml_) || !sequence.flush())
    throw DatasetError("cannot write " + d + "sequence.yaml");
  finished_ = true;
}

}  // namespace planetary_vo

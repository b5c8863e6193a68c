#pragma once
/// @file dataset.h
/// The dataset format of planetary_vo (see docs/dataset_format.md) and readers for the public formats the VO
/// is checked on (KITTI odometry, EuRoC ASL, TUM RGB-D). One reader, one writer, plain value types out.
///
/// Ground truth is always given as T_world_cam of the camera optical frame (REP-103: z forward, x right, y
/// down), one pose per image, whatever the source format stores (EuRoC's body poses are composed with the
/// camera extrinsic).

#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "planetary_vo/fusion/measurements.h"
#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/geometry/pose.h"

namespace planetary_vo {

/// Thrown with a message that names the file and what is wrong with it.
class DatasetError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// ImuSample and AltimeterSample: planetary_vo/fusion/measurements.h (core types the dataset converts to).

/// Ground truth of the navigation state at one instant (groundtruth_state.txt, at the IMU rate). Written by
/// the renderer for the evaluator only: nothing here may reach an estimator.
struct GroundTruthState {
  double timestamp_s = 0.0;
  Pose T_world_body = Pose::Identity();  ///< body = camera optical frame for the Lunar sequences
  Eigen::Vector3d velocity_world_mps = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias_radps = Eigen::Vector3d::Zero();  ///< true total gyro bias, IMU frame
  Eigen::Vector3d accel_bias_mps2 = Eigen::Vector3d::Zero();  ///< true total accelerometer bias, IMU frame
};

/// Ground truth of one altimeter sample (groundtruth_altimeter.txt), for the evaluator only.
struct AltimeterTruth {
  double timestamp_s = 0.0;
  double true_range_m = 0.0;  ///< exact range along the boresight (+inf: no terrain within the search range)
  double altitude_m = 0.0;    ///< height of the sensor above the terrain directly below it
  double incidence_deg =
      0.0;                ///< angle between the beam and the terrain normal at the boresight hit (NaN: none)
  bool returned = false;  ///< the instrument reported a range
  bool outlier = false;   ///< the reported range is a false return
};

/// What sensors.yaml of a planetary_vo dataset says about the instruments (their data sheets, not the errors
/// of one run): enough for a driver to fill the uncertainty and limits of its messages.
struct SensorSpecification {
  bool has_imu = false;
  double imu_rate_hz = 0.0;
  double gyro_noise_density_radps_per_sqrt_hz = 0.0;  ///< angle random walk
  double accel_noise_density_mps2_per_sqrt_hz = 0.0;  ///< velocity random walk
  bool has_altimeter = false;
  double altimeter_min_range_m = 0.0;
  double altimeter_max_range_m = std::numeric_limits<double>::infinity();
  double altimeter_beam_divergence_rad = 0.0;  ///< full angle of the beam
  double altimeter_range_noise_floor_m = 0.0;
  double altimeter_range_noise_fraction = 0.0;
};

enum class DatasetFormat { kPlanetaryVo, kKitti, kEuroc, kTumRgbd };
const char* toString(DatasetFormat format);

/// A read-only sequence of images with optional ground truth, IMU and altimeter streams. Images are loaded on
/// demand.
class Dataset {
 public:
  /// Opens `directory`, detecting its format. Throws DatasetError (missing folder, unknown layout, bad file).
  static Dataset open(const std::string& directory);

  DatasetFormat format() const { return format_; }
  const std::string& directory() const { return directory_; }
  const std::string& name() const { return name_; }  ///< folder name, or `name` from sequence.yaml
  const PinholeCamera& camera() const { return camera_; }

  size_t size() const { return timestamps_s_.size(); }
  double timestamp(size_t i) const { return timestamps_s_.at(i); }
  const std::vector<double>& timestamps() const { return timestamps_s_; }
  const std::string& imagePath(size_t i) const { return image_paths_.at(i); }
  /// Image i as 8-bit single-channel gray (converted if stored otherwise). Throws DatasetError if unreadable.
  cv::Mat loadImage(size_t i) const;
  /// Image i exactly as stored (e.g. 16-bit gray or BGR), without any conversion. Throws DatasetError if
  /// unreadable.
  cv::Mat loadImageUnchanged(size_t i) const;

  bool hasGroundTruth() const { return !ground_truth_.empty(); }
  /// Ground truth pose of image i (same indices and stamps as the images); empty when the dataset has none.
  const Trajectory& groundTruth() const { return ground_truth_; }
  const std::vector<ImuSample>& imu() const { return imu_; }
  const std::vector<AltimeterSample>& altimeter() const { return altimeter_; }
  /// The text of sequence.yaml (planetary_vo format only), "" otherwise.
  const std::string& sequenceYaml() const { return sequence_yaml_; }
  /// The instruments as sensors.yaml describes them (planetary_vo format); has_imu / has_altimeter false when
  /// the dataset does not say.
  const SensorSpecification& sensorSpecification() const { return sensor_spec_; }

 private:
  friend class DatasetReaders;
  DatasetFormat format_ = DatasetFormat::kPlanetaryVo;
  std::string directory_;
  std::string name_;
  PinholeCamera camera_;
  std::vector<double> timestamps_s_;
  std::vector<std::string> image_paths_;
  Trajectory ground_truth_;
  std::vector<ImuSample> imu_;
  std::vector<AltimeterSample> altimeter_;
  std::string sequence_yaml_;
  SensorSpecification sensor_spec_;
};

/// Writes a dataset in the planetary_vo format. Images are written as they are added (so long renders can be
/// resumed or inspected); the text files are written by finish() (also called by the destructor).
class DatasetWriter {
 public:
  /// Creates `directory` and `directory/images`. Throws DatasetError if it cannot.
  DatasetWriter(const std::string& directory, const PinholeCamera& camera);
  ~DatasetWriter();
  DatasetWriter(const DatasetWriter&) = delete;
  DatasetWriter& operator=(const DatasetWriter&) = delete;

  /// Writes images/NNNNNN.png (8- or 16-bit gray) and records its stamp and ground-truth pose.
  void addFrame(double timestamp_s, const cv::Mat& image, const Pose& T_world_cam);
  /// Records frame i = numFrames() whose images/NNNNNN.png is already on disk (a cached render whose streams
  /// are written again). Throws DatasetError if the image file is missing.
  void addExistingFrame(double timestamp_s, const Pose& T_world_cam);
  void addImu(const ImuSample& sample);
  void addAltimeter(const AltimeterSample& sample);
  /// Ground-truth-only streams (groundtruth_state.txt, groundtruth_altimeter.txt); written when non-empty.
  void addGroundTruthState(const GroundTruthState& state);
  void addAltimeterTruth(const AltimeterTruth& truth);
  /// The camera the images were really taken with (groundtruth_camera.yaml), when it differs from the
  /// calibration given to the estimator in camera.yaml.
  void setTrueCamera(const PinholeCamera& camera);
  /// Any further text file written as given by finish() (e.g. sensors.yaml, groundtruth_sensors.yaml).
  void setTextFile(const std::string& file_name, const std::string& text);
  /// Text of sequence.yaml (trajectory, camera mode, Sun, DEM, seed, rate, resolution...), written as given.
  void setSequenceYaml(const std::string& yaml_text);
  /// Writes groundtruth.txt, times.txt, camera.yaml, imu.txt, altimeter.txt, sequence.yaml. Idempotent.
  void finish();

  size_t numFrames() const { return timestamps_s_.size(); }

 private:
  std::string directory_;
  PinholeCamera camera_;
  std::vector<double> timestamps_s_;
  Trajectory ground_truth_;
  std::vector<ImuSample> imu_;
  std::vector<AltimeterSample> altimeter_;
  std::vector<GroundTruthState> ground_truth_state_;
  std::vector<AltimeterTruth> altimeter_truth_;
  PinholeCamera true_camera_;
  bool has_true_camera_ = false;
  std::map<std::string, std::string> text_files_;
  std::string sequence_yaml_;
  bool finished_ = false;
};

/// TUM trajectory files: `t tx ty tz qx qy qz qw` per line, '#' comments. Throws DatasetError on a bad line.
Trajectory readTumTrajectory(const std::string& path);
void writeTumTrajectory(const std::string& path, const Trajectory& trajectory);
/// KITTI pose files: 12 numbers (3x4 row-major T_world_cam) per line; stamps are index / rate_hz.
Trajectory readKittiTrajectory(const std::string& path, double rate_hz = 10.0);
/// Reads a trajectory in TUM or KITTI format, deciding from the number of columns.
Trajectory readTrajectory(const std::string& path);

/// Pose at `timestamp_s` interpolated between the two samples of `samples` (sorted by time) around it: linear
/// in position, slerp in rotation. Returns false (and leaves `T_world_cam` alone) outside [first, last]
/// stamp.
bool interpolatePose(const Trajectory& samples, double timestamp_s, Pose* T_world_cam);

/// ROS camera_info YAML (image_width, image_height, camera_matrix, distortion_model,
/// distortion_coefficients).
PinholeCamera readCameraInfoYaml(const std::string& path);
void writeCameraInfoYaml(const std::string& path, const PinholeCamera& camera,
                         const std::string& camera_name);

}  // namespace planetary_vo

#pragma once
/// @file altimeter_aiding.h
/// Stage of the vision + altimeter mode: the altimeter readings given to the pipeline, buffered by stamp, and
/// the metric scale of a map from them. The map predicts the range along the beam (a plane fitted to the map
/// points around the beam's hit, fusion/altimeter_range.h); the measured slant range over that prediction is
/// the map's metric scale in metres per map unit, with a 1-sigma from the instrument noise and the fit.
///
/// Readings are used causally: the reading for an image at t is interpolated between the two readings around
/// t when both are already in the buffer and returned, else the newest reading at or before t within
/// max_time_offset_s is taken. So the live node never waits for a later reading.

#include <deque>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "planetary_vo/fusion/altimeter_range.h"
#include "planetary_vo/fusion/measurements.h"
#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/vo/config.h"

namespace planetary_vo {

/// The metric scale of a map from one altimeter reading.
struct AltimeterScaleFix {
  bool valid = false;
  std::string reason;  ///< why not valid
  double metres_per_map_unit = std::numeric_limits<double>::quiet_NaN();
  double relative_sigma = std::numeric_limits<double>::infinity();  ///< 1-sigma / metres_per_map_unit
  double measured_range_m = std::numeric_limits<double>::quiet_NaN();
  RangePrediction prediction;  ///< in map units
};

class AltimeterAiding {
 public:
  explicit AltimeterAiding(const AltimeterAidingConfig& config);

  /// Buffers a reading. Throws std::invalid_argument for a non-finite stamp, a NaN or negative range, or a
  /// stamp earlier than the newest buffered one (the caller reorders by stamp); the buffer is unchanged then.
  /// Readings older than kHistoryS before the newest are dropped (flat memory).
  void add(const AltimeterSample& sample);
  /// The reading for an image at t_s (see the file comment); nullopt when there is none close enough, or
  /// when the instrument did not return or read outside its range gate.
  std::optional<AltimeterSample> readingAt(double t_s) const;
  /// Metres per map unit of a map (points in world coordinates, map units) seen from the camera pose
  /// T_world_cam (map units) at t_s, from readingAt(t_s).
  AltimeterScaleFix scaleAt(double t_s, const std::vector<Eigen::Vector3d>& points_world,
                            const Pose& T_world_cam) const;

  void clear() { readings_.clear(); }
  size_t size() const { return readings_.size(); }
  const AltimeterAidingConfig& config() const { return config_; }

  static constexpr double kHistoryS = 10.0;

 private:
  AltimeterAidingConfig config_;
  std::deque<AltimeterSample> readings_;  // ascending stamps
};

}  // namespace planetary_vo

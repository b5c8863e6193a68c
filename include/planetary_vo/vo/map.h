#pragma once
/// @file map.h
/// Stage 5: the windowed sparse map. Keyframes (pose + the ideal pixels of every live KLT track at that
/// moment) and map points (world position + their keyframe observations), linked to the KLT tracks by track
/// id so that a frame can be matched to the map without descriptors: a live track that carries a map point is
/// a 3D-2D correspondence.
///
/// Memory stays flat over a sequence: only the newest `window` keyframes are kept, and a point disappears
/// once no kept keyframe observes it and its track has died.

#include <cstdint>
#include <deque>
#include <limits>
#include <memory>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "planetary_vo/fusion/imu_preintegration.h"
#include "planetary_vo/fusion/nav_state.h"
#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/vo/bundle_adjuster.h"
#include "planetary_vo/vo/config.h"
#include "planetary_vo/vo/frame_result.h"
#include "planetary_vo/vo/map_events.h"

namespace planetary_vo {

/// Track ids from here up are map-only tracks (keyframe_tracker.h), followed at keyframes only; the frame
/// tracker's ids stay below.
constexpr uint64_t kFirstMapOnlyTrackId = uint64_t{1} << 62;

struct Keyframe {
  uint64_t id = 0;
  double timestamp_s = 0.0;
  Pose T_world_cam = Pose::Identity();
  /// Ideal (undistorted) pixel of every track alive when the keyframe was taken, by track id. New points are
  /// triangulated from these, also for tracks that did not yet carry a point.
  std::unordered_map<uint64_t, Eigen::Vector2d> px_by_track;
  /// How many of px_by_track are the frame tracker's tracks (the rest are map-only tracks,
  /// keyframe_tracker.h; the keyframe policy's track ratio counts these only). addKeyframe() counts all; the
  /// mapper sets it.
  int num_frame_tracks = 0;
  /// The altimeter's slant range at the keyframe's time (vision + altimeter mode), NaN when there was none.
  double altimeter_range_m = std::numeric_limits<double>::quiet_NaN();
  /// Camera + IMU mode: the IMU body's velocity (world) and biases at the keyframe (has_inertial_state), and
  /// the IMU preintegrated from the previous keyframe of the map (nullptr: none, e.g. across an IMU gap).
  bool has_inertial_state = false;
  Eigen::Vector3d v_world_mps = Eigen::Vector3d::Zero();
  ImuBias imu_bias;
  std::shared_ptr<const ImuPreintegration> imu_from_previous;
  /// Covariance of [position, attitude, velocity] (BaInertialState::covariance) from the first window solve
  /// that had the keyframe free, the one in which it was the newest: later windows would count again the
  /// measurements its anchor's covariance already holds.
  bool has_covariance = false;
  Eigen::Matrix<double, 9, 9> covariance = Eigen::Matrix<double, 9, 9>::Zero();
  /// From the same window (with has_covariance): the biases it estimated and their covariance
  /// (BaInertialState::bias_covariance), the prior of the biases when the keyframe is a window's oldest.
  ImuBias imu_bias_at_covariance;
  Eigen::Matrix<double, 6, 6> bias_covariance = Eigen::Matrix<double, 6, 6>::Zero();
};

struct MapObservation {
  uint64_t keyframe_id = 0;
  Eigen::Vector2d px = Eigen::Vector2d::Zero();  ///< ideal pixel
};

struct MapPoint {
  uint64_t id = 0;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  std::vector<MapObservation> observations;  ///< kept keyframes only, oldest first
  /// The KLT track that follows the point in new frames; valid while has_track (false once it died or was
  /// detached).
  uint64_t track_id = 0;
  bool has_track = false;
  int times_visible = 0;  ///< frames in which its track was alive and it was given to PnP
  int times_found = 0;    ///< ... and it was a PnP inlier
};

/// The windowed map. Not thread-safe: owned and used by the tracking thread; bundle adjustment works on a
/// copy (makeBaProblem / applyBaResult).
///
/// Every change is also recorded as a map event (map_events.h) until takeEvents(): points triangulated
/// (addPoint), refined or re-observed (applyBaResult, addObservation, scaleAbout, transformAbout), retired
/// with their last state (they left the window: dropKeyframesOutsideWindow, cull of unsupported points,
/// clear) or rejected (BA outliers, cull of points PnP keeps rejecting, removePoint).
class Map {
 public:
  /// Retires every point (map event) and empties the map; ids keep increasing.
  void clear();
  /// What changed since the last call (map_events.h); the record is emptied.
  MapEvents takeEvents();
  /// 1-sigma of one observation as an angle (rad), for the points' covariance in the map events: the
  /// pixel noise over the focal length. Default 1e-3.
  void setObservationSigma(double sigma_rad) { observation_sigma_rad_ = sigma_rad; }

  /// Appends a keyframe (newest) holding the given ideal pixels of the live tracks; returns its id.
  uint64_t addKeyframe(double timestamp_s, const Pose& T_world_cam, const std::vector<uint64_t>& track_ids,
                       const std::vector<Eigen::Vector2d>& px);
  /// Adds a point followed by `track_id` (replacing any point that track carried) with its observations.
  uint64_t addPoint(uint64_t track_id, const Eigen::Vector3d& p_world,
                    std::vector<MapObservation> observations);
  /// Records that keyframe `keyframe_id` sees point `point_id` at `px` (ignored for unknown ids or
  /// duplicates).
  void addObservation(uint64_t point_id, uint64_t keyframe_id, const Eigen::Vector2d& px);
  void removePoint(uint64_t point_id);

  /// The point carried by a live track, or nullptr.
  MapPoint* pointForTrack(uint64_t track_id);
  const MapPoint* pointForTrack(uint64_t track_id) const;
  MapPoint* point(uint64_t point_id);
  const Keyframe* keyframe(uint64_t keyframe_id) const;
  Keyframe* keyframe(uint64_t keyframe_id);

  /// The track of a point stops following it (tracking outlier, or the track died): the point stays for
  /// bundle adjustment while keyframes observe it but is never matched to a frame again.
  void detachTrack(uint64_t track_id);
  /// Detaches every track that is not in `live_track_ids` (sorted ascending). With a range, only the tracks
  /// whose id lies in [first_id, end_id) are looked at (e.g. the frame tracks only, below
  /// kFirstMapOnlyTrackId); the others keep their point.
  void retainTracks(const std::vector<uint64_t>& live_track_ids_sorted, uint64_t first_id = 0,
                    uint64_t end_id = std::numeric_limits<uint64_t>::max());

  /// Drops the oldest keyframes beyond `window_keyframes` and the points nothing holds any more. Returns the
  /// number of points removed.
  int dropKeyframesOutsideWindow(int window_keyframes);
  /// Removes points that PnP keeps rejecting (found / visible < cull_min_found_ratio after 5 visible frames;
  /// rejected) and detached points with fewer than min_observations keyframe observations (retired: their
  /// keyframes left). Returns how many.
  int cull(const MapConfig& config);

  /// Scales the map about `centre` (world): every keyframe position and point p becomes centre + s (p -
  /// centre), velocities s v; attitudes are unchanged. A change of the map's unit, e.g. to metres once the
  /// altimeter fixed it.
  void scaleAbout(const Eigen::Vector3d& centre, double s);
  /// Rotates and scales the map about `centre`: p -> centre + R s (p - centre) for keyframe positions and
  /// points, attitudes R_world_cam -> R R_world_cam, velocities v -> R v (metric already). E.g. the map
  /// frame turned gravity-aligned and metric by the visual-inertial alignment.
  void transformAbout(const Eigen::Vector3d& centre, const Eigen::Matrix3d& R, double s);

  /// Copy of the newest `window_keyframes` keyframes and the points with >= 2 observations in them. The
  /// `num_fixed_oldest` oldest window keyframes are held fixed (gauge and scale); keyframes outside the
  /// window that observe the points enter as fixed too.
  BaProblem makeBaProblem(int window_keyframes, int num_fixed_oldest, double fx, double fy, double cx,
                          double cy) const;
  /// Writes optimised poses, points and inertial states back (ids that no longer exist are skipped) and
  /// removes the outlier observations; points left with fewer than 2 observations are removed. Returns the
  /// points removed.
  int applyBaResult(const BaProblem& problem, const std::vector<BaObservation>& outliers);

  /// Stores the covariances of the states that have one, on keyframes without one yet (keyframes that no
  /// longer exist are skipped).
  void applyCovariances(const std::vector<BaInertialState>& states);

  const std::deque<Keyframe>& keyframes() const { return keyframes_; }
  const std::unordered_map<uint64_t, MapPoint>& points() const { return points_; }
  size_t numPoints() const { return points_.size(); }
  size_t numKeyframes() const { return keyframes_.size(); }
  /// World positions and observation counts of all points (cleared first).
  void pointViews(std::vector<MapPointView>* out) const;

 private:
  std::deque<Keyframe> keyframes_;  // oldest first
  std::unordered_map<uint64_t, MapPoint> points_;
  std::unordered_map<uint64_t, uint64_t> point_by_track_;
  uint64_t next_keyframe_id_ = 0;
  uint64_t next_point_id_ = 0;

  // Map events since the last takeEvents().
  MapPointState stateOf(const MapPoint& p) const;
  void markUpdated(uint64_t point_id);
  void markRemoved(uint64_t point_id);
  void markRetired(const MapPoint& p);
  double observation_sigma_rad_ = 1e-3;
  std::unordered_map<uint64_t, bool> pending_points_;  // id -> added this frame (else updated)
  std::vector<MapPointState> pending_retired_;
  std::vector<uint64_t> pending_removed_;
  std::vector<uint64_t> pending_keyframes_;
  std::vector<MapKeyframeState> pending_keyframes_retired_;
  bool pending_restart_ = false;
};

}  // namespace planetary_vo

#include "planetary_vo/vo/altimeter_aiding.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace planetary_vo {

AltimeterAiding::AltimeterAiding(const AltimeterAidingConfig& config) : config_(config) {
  config_.mounting.boresight_body.normalize();  // validated to within 1e-3 of unit length by VoConfig
  validate(config_.noise);
  validate(config_.mounting);
}

void AltimeterAiding::add(const AltimeterSample& sample) {
  if (!std::isfinite(sample.timestamp_s))
    throw std::invalid_argument("altimeter reading: non-finite timestamp");
  if (std::isnan(sample.slant_range_m) || sample.slant_range_m < 0.0)
    throw std::invalid_argument("altimeter reading at t = " + std::to_string(sample.timestamp_s) +
                                " s: invalid range " + std::to_string(sample.slant_range_m) +
                                " m (no return is +inf)");
  if (!readings_.empty() && sample.timestamp_s < readings_.back().timestamp_s)
    throw std::invalid_argument("altimeter reading at t = " + std::to_string(sample.timestamp_s) +
                                " s is older than the last one (" +
                                std::to_string(readings_.back().timestamp_s) + " s)");
  readings_.push_back(sample);
  while (readings_.front().timestamp_s < sample.timestamp_s - kHistoryS) readings_.pop_front();
}

std::optional<AltimeterSample> AltimeterAiding::readingAt(double t_s) const {
  // First reading after t (upper_bound) and the last one at or before it.
  const auto after = std::upper_bound(readings_.begin(), readings_.end(), t_s,
                                      [](double t, const AltimeterSample& s) { return t < s.timestamp_s; });
  if (after == readings_.begin()) return std::nullopt;
  const AltimeterSample& before = *(after - 1);
  if (t_s - before.timestamp_s > config_.max_time_offset_s || !config_.noise.accepts(before))
    return std::nullopt;
  if (after == readings_.end() || before.timestamp_s == t_s) return before;
  if (after->timestamp_s - t_s > config_.max_time_offset_s || !config_.noise.accepts(*after)) return before;
  const double w = (t_s - before.timestamp_s) / (after->timestamp_s - before.timestamp_s);
  AltimeterSample interpolated;
  interpolated.timestamp_s = t_s;
  interpolated.slant_range_m = (1.0 - w) * before.slant_range_m + w * after->slant_range_m;
  return interpolated;
}

AltimeterScaleFix AltimeterAiding::scaleAt(double t_s, const std::vector<Eigen::Vector3d>& points_world,
                                           const Pose& T_world_cam) const {
  AltimeterScaleFix fix;
  const std::optional<AltimeterSample> reading = readingAt(t_s);
  if (!reading) {
    fix.reason = "no altimeter reading within " + std::to_string(config_.max_time_offset_s) + " s";
    return fix;
  }
  fix.measured_range_m = reading->slant_range_m;
  RangePredictionOptions options;
  // The lever arm (metres) cannot be converted before the scale is known; the Lunar instruments are
  // co-located, and a lever arm of centimetres against ranges of hundreds of metres is far below the noise.
  options.beam_divergence_rad = 0.0;
  fix.prediction = predictRange(points_world, {}, T_world_cam, config_.mounting, options);
  if (!fix.prediction.valid()) {
    fix.reason = "no range prediction from the map: " + fix.prediction.reason;
    return fix;
  }
  fix.metres_per_map_unit = fix.measured_range_m / fix.prediction.range;
  const double rel_measured = config_.noise.sigmaM(fix.measured_range_m) / fix.measured_range_m;
  const double rel_predicted = fix.prediction.sigma / fix.prediction.range;
  fix.relative_sigma = std::hypot(rel_measured, rel_predicted);
  fix.valid = std::isfinite(fix.metres_per_map_unit) && fix.metres_per_map_unit > 0.0;
  if (!fix.valid) fix.reason = "non-positive scale";
  return fix;
}

}  // namespace planetary_vo

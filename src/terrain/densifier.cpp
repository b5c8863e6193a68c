#include "planetary_vo/terrain/densifier.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

namespace planetary_vo::terrain {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

/// Where the ray of a measured pixel meets the plane z = ground_z (world); false when it points away.
bool rayOnPlane(const PinholeCamera& camera, const Pose& T_world_cam, const cv::Point2f& px, double ground_z,
                Eigen::Vector3d* out) {
  const Eigen::Vector3d d = T_world_cam.linear() * camera.distortedPixelToBearing({px.x, px.y});
  const Eigen::Vector3d c = T_world_cam.translation();
  if (!(std::abs(d.z()) > 1e-9)) return false;
  const double s = (ground_z - c.z()) / d.z();
  if (!(s > 0.0)) return false;
  *out = c + s * d;
  return true;
}

/// Measured (distorted) pixel of a world point in a camera; false behind it or outside the image.
bool projectWorld(const PinholeCamera& camera, const Pose& T_world_cam, const Eigen::Vector3d& p_world,
                  cv::Point2f* px) {
  const Eigen::Vector3d p_cam = T_world_cam.inverse() * p_world;
  if (!(p_cam.z() > 0.0)) return false;
  const Eigen::Vector2d ideal = camera.project(p_cam);
  if (!camera.isInImage(ideal, 2.0)) return false;
  const Eigen::Vector2d distorted = camera.distortPixel(ideal);
  *px = cv::Point2f(static_cast<float>(distorted.x()), static_cast<float>(distorted.y()));
  return camera.isInImage(distorted, 2.0);
}

}  // namespace

Densifier::Densifier(const PinholeCamera& camera, const DensifierConfig& config)
    : camera_(camera), config_(config) {
  std::string why;
  if (!camera_.isValid(&why)) throw std::invalid_argument("Densifier: invalid camera: " + why);
  if (config_.grid_step_px < 1 || config_.max_corners < 1 || config_.max_keyframe_gap < 1 ||
      config_.partners_per_keyframe < 1 || !(config_.pixel_sigma_px > 0.0) ||
      !(config_.min_parallax_deg > 0.0) || !(config_.max_forward_backward_px > 0.0) ||
      config_.klt_window_px < 5 || config_.klt_levels < 0 ||
      !(std::isfinite(config_.max_window_footprint_m) && config_.max_window_footprint_m >= 0.0) ||
      !(config_.min_corner_quality > 0.0 && config_.min_corner_quality < 1.0))
    throw std::invalid_argument("Densifier: invalid configuration");
}

std::vector<MapPointState> Densifier::addKeyframe(double timestamp_s, const Pose& T_world_cam,
                                                  const cv::Mat& gray, double ground_z_m,
                                                  DensifierStats* stats) {
  if (gray.empty() || gray.type() != CV_8UC1 || gray.cols != camera_.width() || gray.rows != camera_.height())
    throw std::invalid_argument("Densifier::addKeyframe: expected an 8-bit gray image of the camera's size");
  DensifierStats local;
  DensifierStats& st = stats != nullptr ? *stats : local;
  st = DensifierStats();
  std::vector<MapPointState> points;
  const GridGeometry area = config_.area.geometry();
  const double half = 0.5 * area.cell_size_m;
  const double x_lo = area.x_m(0) - half - config_.area_margin_m,
               x_hi = area.x_m(area.cols - 1) + half + config_.area_margin_m;
  const double y_lo = area.y_m(0) - half - config_.area_margin_m,
               y_hi = area.y_m(area.rows - 1) + half + config_.area_margin_m;
  auto inArea = [&](const Eigen::Vector3d& p) {
    return p.x() >= x_lo && p.x() <= x_hi && p.y() >= y_lo && p.y() <= y_hi;
  };

  // The mask of the pixels of a stored keyframe whose ground (plane z = ground_z_m) is in the area and
  // seen by the new keyframe, on a coarse grid (every 8 px) then dilated: cheap and conservative.
  auto overlapMask = [&](const StoredKeyframe& kf, int* count, double* median_parallax_deg) {
    constexpr int kStep = 8;
    cv::Mat coarse = cv::Mat::zeros((gray.rows + kStep - 1) / kStep, (gray.cols + kStep - 1) / kStep, CV_8U);
    *count = 0;
    std::vector<double> parallax_deg;
    for (int r = 0; r < coarse.rows; ++r) {
      for (int c = 0; c < coarse.cols; ++c) {
        const cv::Point2f px(static_cast<float>(c * kStep + kStep / 2),
                             static_cast<float>(r * kStep + kStep / 2));
        Eigen::Vector3d ground;
        cv::Point2f in_new;
        if (rayOnPlane(camera_, kf.T_world_cam, px, ground_z_m, &ground) && inArea(ground) &&
            projectWorld(camera_, T_world_cam, ground, &in_new)) {
          coarse.at<uint8_t>(r, c) = 255;
          ++*count;
          const Eigen::Vector3d a = (ground - kf.T_world_cam.translation()).normalized();
          const Eigen::Vector3d b = (ground - T_world_cam.translation()).normalized();
          parallax_deg.push_back(std::acos(std::clamp(a.dot(b), -1.0, 1.0)) / kDegToRad);
        }
      }
    }
    *median_parallax_deg = 0.0;
    if (!parallax_deg.empty()) {
      std::nth_element(parallax_deg.begin(),
                       parallax_deg.begin() + static_cast<std::ptrdiff_t>(parallax_deg.size() / 2),
                       parallax_deg.end());
      *median_parallax_deg = parallax_deg[parallax_deg.size() / 2];
    }
    cv::Mat mask;
    cv::resize(coarse, mask, gray.size(), 0, 0, cv::INTER_NEAREST);
    return mask;
  };

  // The partner: the stored keyframe that sees most of the area together with the new one, its overlap
  // weighted down while the parallax is below the target (a short baseline gives poor depths, a long one
  // a small overlap and a harder track).
  struct Candidate {
    double score;
    size_t index;
    cv::Mat mask;
  };
  std::vector<Candidate> candidates;
  const int min_cells = std::max(1, config_.min_seeds / 4);
  for (size_t k = 0; k < keyframes_.size(); ++k) {
    int cells = 0;
    double parallax_deg = 0.0;
    cv::Mat m = overlapMask(keyframes_[k], &cells, &parallax_deg);
    const double score = cells * std::min(1.0, parallax_deg / config_.target_parallax_deg);
    if (cells >= min_cells && parallax_deg >= config_.min_parallax_deg) candidates.push_back({score, k, m});
  }
  std::sort(candidates.begin(), candidates.end(),
            [](const Candidate& x, const Candidate& y) { return x.score > y.score; });
  if (static_cast<int>(candidates.size()) > config_.partners_per_keyframe)
    candidates.resize(static_cast<size_t>(config_.partners_per_keyframe));
  if (!candidates.empty()) st.partner_gap = static_cast<int>(keyframes_.size() - candidates.front().index);

  for (const Candidate& candidate : candidates) {
    const StoredKeyframe* partner = &keyframes_[candidate.index];
    const cv::Mat& mask = candidate.mask;
    std::vector<cv::Point2f> seeds;
    cv::goodFeaturesToTrack(partner->gray, seeds, config_.max_corners, config_.min_corner_quality,
                            config_.grid_step_px, mask, 5);
    st.seeds += static_cast<int>(seeds.size());
    // Predicted positions through the plane; corners whose ray misses it are dropped.
    std::vector<cv::Point2f> from, guess;
    from.reserve(seeds.size());
    guess.reserve(seeds.size());
    for (const cv::Point2f& s : seeds) {
      Eigen::Vector3d ground;
      cv::Point2f g;
      if (rayOnPlane(camera_, partner->T_world_cam, s, ground_z_m, &ground) &&
          projectWorld(camera_, T_world_cam, ground, &g)) {
        from.push_back(s);
        guess.push_back(g);
      }
    }
    if (static_cast<int>(from.size()) >= config_.min_seeds) {
      const cv::Size window(config_.klt_window_px, config_.klt_window_px);
      const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
      // The tracked image: the partner's, or the partner's warped by the ground plane's homography onto
      // the new view (then the windows differ only by the relief, not by the views' scale and rotation).
      cv::Mat source = partner->gray;
      std::vector<cv::Point2f> start = from;
      if (config_.warp_partner) {
        const cv::Mat H = cv::findHomography(from, guess, 0);
        if (!H.empty()) {
          cv::warpPerspective(partner->gray, source, H, gray.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT);
          cv::perspectiveTransform(from, start, H);
        }
      }
      std::vector<cv::Point2f> to = guess, back(from.size());
      std::vector<uint8_t> status, back_status;
      std::vector<float> error;
      cv::calcOpticalFlowPyrLK(source, gray, start, to, status, error, window, config_.klt_levels, criteria,
                               cv::OPTFLOW_USE_INITIAL_FLOW);
      // Backward from where the forward track ended minus the predicted motion (see vo/klt_tracker.cpp: a
      // backward start at the original position would "return" by construction).
      for (size_t i = 0; i < from.size(); ++i) back[i] = to[i] - (guess[i] - start[i]);
      cv::calcOpticalFlowPyrLK(gray, source, to, back, back_status, error, window, config_.klt_levels,
                               criteria, cv::OPTFLOW_USE_INITIAL_FLOW);
      const double fb_max2 = config_.max_forward_backward_px * config_.max_forward_backward_px;
      std::vector<cv::Point2f> kept_from, kept_to;
      for (size_t i = 0; i < from.size(); ++i) {
        if (!status[i] || !back_status[i]) continue;
        const double dx = back[i].x - start[i].x, dy = back[i].y - start[i].y;
        if (dx * dx + dy * dy > fb_max2) continue;
        if (!camera_.isInImage({to[i].x, to[i].y}, 2.0)) continue;
        kept_from.push_back(from[i]);
        kept_to.push_back(to[i]);
      }
      st.tracked += static_cast<int>(kept_from.size());

      const Eigen::Vector3d c0 = partner->T_world_cam.translation(), c1 = T_world_cam.translation();
      const double sigma_rad = config_.pixel_sigma_px / camera_.fx();
      const double min_cos = std::cos(config_.min_parallax_deg * kDegToRad);
      for (size_t i = 0; i < kept_from.size(); ++i) {
        const Eigen::Vector3d d0 =
            partner->T_world_cam.linear() * camera_.distortedPixelToBearing({kept_from[i].x, kept_from[i].y});
        const Eigen::Vector3d d1 =
            T_world_cam.linear() * camera_.distortedPixelToBearing({kept_to[i].x, kept_to[i].y});
        if (d0.dot(d1) > min_cos) continue;  // too little parallax
        // Closest points of the two rays c0 + s d0, c1 + u d1.
        const Eigen::Vector3d w = c0 - c1;
        const double b = d0.dot(d1), d = d0.dot(w), e = d1.dot(w);
        const double denom = 1.0 - b * b;
        if (!(denom > 1e-12)) continue;
        const double s = (b * e - d) / denom, u = (e - b * d) / denom;
        if (!(s > 0.0 && u > 0.0)) continue;
        const Eigen::Vector3d q0 = c0 + s * d0, q1 = c1 + u * d1;
        // The rays must pass within a few pixel sigmas of each other at their range.
        if ((q0 - q1).norm() > 4.0 * sigma_rad * std::max(s, u)) continue;
        const Eigen::Vector3d p = 0.5 * (q0 + q1);
        if (!inArea(p)) continue;
        // The ground the tracking window covers, in the worse of the two views (range x window / focal
        // length, stretched by the incidence on level ground): the relief the point averages over.
        if (config_.max_window_footprint_m > 0.0) {
          const double window_rad = config_.klt_window_px / camera_.fx();
          const double f0 = s * window_rad / std::max(0.1, std::abs(d0.z()));
          const double f1 = u * window_rad / std::max(0.1, std::abs(d1.z()));
          if (std::max(f0, f1) > config_.max_window_footprint_m) continue;
        }
        // Two-ray covariance (as the VO's map events: Gauss-Newton information of both observations).
        Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
        for (const Pose* T : {&partner->T_world_cam, &T_world_cam}) {
          const Eigen::Matrix3d R_cw = T->linear().transpose();
          const Eigen::Vector3d pc = R_cw * (p - T->translation());
          Eigen::Matrix<double, 2, 3> J;
          J << 1.0, 0.0, -pc.x() / pc.z(), 0.0, 1.0, -pc.y() / pc.z();
          J = (J / pc.z()) * R_cw;
          information += J.transpose() * J / (sigma_rad * sigma_rad);
        }
        MapPointState point;
        point.id = next_id_++;
        point.p_world = p;
        point.covariance_world = information.ldlt().solve(Eigen::Matrix3d::Identity());
        point.num_observations = 2;
        points.push_back(point);
      }
      st.triangulated = static_cast<int>(points.size());
    }
  }

  keyframes_.push_back({timestamp_s, T_world_cam, gray.clone()});
  while (static_cast<int>(keyframes_.size()) > config_.max_keyframe_gap) keyframes_.pop_front();
  return points;
}

}  // namespace planetary_vo::terrain

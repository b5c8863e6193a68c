/// @file grid_detector.cpp
/// Grid-distributed FAST/ORB detection with budget redistribution and replenishment masks.

#include "planetary_vo/vo/grid_detector.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <opencv2/imgproc.hpp>

namespace planetary_vo {
namespace {

/// FAST reads a 3-pixel ring around each pixel and non-maximum suppression one pixel more, so a cell's search
/// region is widened by this much to find corners right up to the cell's edge.
constexpr int kFastMarginPx = 4;

double msSince(int64 start_ticks) {
  return 1e3 * static_cast<double>(cv::getTickCount() - start_ticks) / cv::getTickFrequency();
}

bool strongerFirst(const cv::KeyPoint& a, const cv::KeyPoint& b) {
  if (a.response != b.response) return a.response > b.response;
  // Deterministic order among equal scores (FAST scores are small integers, ties are common).
  if (a.pt.y != b.pt.y) return a.pt.y < b.pt.y;
  return a.pt.x < b.pt.x;
}

/// ORB's intensity-centroid orientation (Rublee et al. 2011) on a disc of radius `half_patch_px` in `image`,
/// in degrees. Pixels outside the image are skipped rather than mirrored.
float intensityCentroidAngleDeg(const cv::Mat& image, const cv::Point2f& px, int half_patch_px) {
  const int cx = cvRound(px.x), cy = cvRound(px.y);
  double m01 = 0.0, m10 = 0.0;
  for (int dy = -half_patch_px; dy <= half_patch_px; ++dy) {
    const int y = cy + dy;
    if (y < 0 || y >= image.rows) continue;
    const int dx_max =
        static_cast<int>(std::sqrt(static_cast<double>(half_patch_px * half_patch_px - dy * dy)));
    const uchar* row = image.ptr<uchar>(y);
    for (int dx = -dx_max; dx <= dx_max; ++dx) {
      const int x = cx + dx;
      if (x < 0 || x >= image.cols) continue;
      m10 += dx * row[x];
      m01 += dy * row[x];
    }
  }
  return cv::fastAtan2(static_cast<float>(m01), static_cast<float>(m10));
}

/// Size of the pyramid level `scale` times smaller than `full` (as cv::ORB rounds it).
cv::Size levelSize(const cv::Size& full, double scale) {
  return cv::Size(cvRound(full.width / scale), cvRound(full.height / scale));
}

}  // namespace

GridDetector::GridDetector(const DetectorConfig& config) : config_(config) {
  CV_Assert(config_.grid_cols > 0 && config_.grid_rows > 0 && config_.num_levels > 0 &&
            config_.scale_factor > 1.0);
  level_scale_.resize(config_.num_levels);
  for (int l = 0; l < config_.num_levels; ++l) level_scale_[l] = std::pow(config_.scale_factor, l);
  candidates_.resize(numCells());
  level_candidates_.resize(config_.num_levels);
  level_taken_.resize(config_.num_levels);
  next_candidate_.resize(numCells());
  if (config_.compute_descriptors) {
    // Same pyramid geometry as our detection, so the keypoints' octave selects the right ORB level.
    orb_ = cv::ORB::create(config_.num_features, static_cast<float>(config_.scale_factor), config_.num_levels,
                           config_.edge_threshold_px, 0, 2, cv::ORB::FAST_SCORE, config_.patch_size_px,
                           config_.fast_threshold);
  }
}

int GridDetector::cellIndex(const cv::Point2f& px, const cv::Size& image_size) const {
  if (!(px.x >= 0.f && px.y >= 0.f && px.x < image_size.width && px.y < image_size.height)) return -1;
  // Cell c spans [ceil(c * W / cols), ceil((c + 1) * W / cols)) as in cellRect(); for an integer pixel x that
  // is exactly the cell floor(x * cols / W).
  const int x = static_cast<int>(px.x), y = static_cast<int>(px.y);
  const int col = static_cast<int>((static_cast<int64_t>(x) * config_.grid_cols) / image_size.width);
  const int row = static_cast<int>((static_cast<int64_t>(y) * config_.grid_rows) / image_size.height);
  return row * config_.grid_cols + col;
}

cv::Rect GridDetector::cellRect(int cell, const cv::Size& image_size) const {
  const int col = cell % config_.grid_cols, row = cell / config_.grid_cols;
  auto start = [](int i, int n, int size) {
    return static_cast<int>((static_cast<int64_t>(i) * size + n - 1) / n);  // ceil(i * size / n)
  };
  const int x0 = start(col, config_.grid_cols, image_size.width);
  const int x1 = start(col + 1, config_.grid_cols, image_size.width);
  const int y0 = start(row, config_.grid_rows, image_size.height);
  const int y1 = start(row + 1, config_.grid_rows, image_size.height);
  return cv::Rect(x0, y0, x1 - x0, y1 - y0);
}

void GridDetector::buildPyramid(const cv::Mat& gray) {
  levels_.resize(config_.num_levels);
  levels_[0] = gray;
  for (int l = 1; l < config_.num_levels; ++l) {
    // Same construction as cv::ORB (each level from the previous one), so descriptors computed by cv::ORB on
    // these keypoints sample the image the corner was found in. resize() reuses the buffer of the last call.
    cv::resize(levels_[l - 1], levels_[l], levelSize(gray.size(), level_scale_[l]), 0, 0,
               cv::INTER_LINEAR_EXACT);
    stats_.pyramid_pixels += levels_[l].total();
  }
}

GridDetector::SearchBounds GridDetector::searchBounds(int cell) const {
  const cv::Rect cell_px = cellRect(cell, image_size_);
  const float edge = static_cast<float>(config_.edge_threshold_px);
  return {std::max(static_cast<float>(cell_px.x), edge), std::max(static_cast<float>(cell_px.y), edge),
          std::min(static_cast<float>(cell_px.br().x), image_size_.width - edge),
          std::min(static_cast<float>(cell_px.br().y), image_size_.height - edge)};
}

cv::Rect GridDetector::fastRegion(int cell, int l) const {
  const SearchBounds b = searchBounds(cell);
  if (b.empty()) return cv::Rect();
  const double s = level_scale_[l];
  return cv::Rect(cvFloor(b.x_min / s) - kFastMarginPx, cvFloor(b.y_min / s) - kFastMarginPx,
                  cvCeil((b.x_end - b.x_min) / s) + 2 * kFastMarginPx,
                  cvCeil((b.y_end - b.y_min) / s) + 2 * kFastMarginPx) &
         cv::Rect(cv::Point(0, 0), levelSize(image_size_, s));
}

void GridDetector::buildPyramidRegions(const cv::Mat& gray, int cell_min_features) {
  levels_.resize(config_.num_levels);
  levels_[0] = gray;
  for (int l = 1; l < config_.num_levels; ++l)
    levels_[l].create(levelSize(gray.size(), level_scale_[l]), CV_8UC1);  // kept from call to call
  level_regions_.resize(config_.num_levels);
  for (int c = 0; c < numCells(); ++c) {
    if (stats_.existing_per_cell[c] >= cell_min_features) continue;
    // From the top level down: the region FAST reads, and the part of the level below that the bilinear
    // samples of the region above read (its pixels scaled, one pixel more on each side).
    for (int l = config_.num_levels - 1; l >= 1; --l) {
      cv::Rect region = fastRegion(c, l);
      if (l + 1 < config_.num_levels && level_regions_[l + 1].area() > 0) {
        const cv::Rect& above = level_regions_[l + 1];
        const double sx = static_cast<double>(levels_[l].cols) / levels_[l + 1].cols;
        const double sy = static_cast<double>(levels_[l].rows) / levels_[l + 1].rows;
        const cv::Rect need(cvFloor(above.x * sx) - 1, cvFloor(above.y * sy) - 1,
                            cvCeil(above.width * sx) + 3, cvCeil(above.height * sy) + 3);
        region = region.area() > 0 ? (region | need) : need;
      }
      level_regions_[l] = region & cv::Rect(0, 0, levels_[l].cols, levels_[l].rows);
    }
    // Then up: each region from the level below, sampled as resize() samples the whole level: level pixel x
    // reads the level below at (x + 0.5) * (cols below / cols) - 0.5.
    for (int l = 1; l < config_.num_levels; ++l) {
      const cv::Rect& r = level_regions_[l];
      if (r.area() <= 0) continue;
      const cv::Mat& below = levels_[l - 1];
      const double sx = static_cast<double>(below.cols) / levels_[l].cols;
      const double sy = static_cast<double>(below.rows) / levels_[l].rows;
      const cv::Matx23d dst_to_src(sx, 0.0, (r.x + 0.5) * sx - 0.5, 0.0, sy, (r.y + 0.5) * sy - 0.5);
      cv::Mat out = levels_[l](r);
      cv::warpAffine(below, out, dst_to_src, r.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                     cv::BORDER_REPLICATE);
      stats_.pyramid_pixels += r.area();
    }
  }
}

void GridDetector::collectCandidates(int cell, int threshold, std::vector<cv::KeyPoint>* out) {
  out->clear();
  const SearchBounds b = searchBounds(cell);
  if (b.empty()) return;

  for (int l = 0; l < config_.num_levels; ++l) {
    std::vector<cv::KeyPoint>& level_out = level_candidates_[l];
    level_out.clear();
    const cv::Mat& image = levels_[l];
    const double s = level_scale_[l];
    const cv::Rect roi = fastRegion(cell, l);
    if (roi.width < 2 * kFastMarginPx || roi.height < 2 * kFastMarginPx) continue;
    cv::FAST(image(roi), fast_buffer_, threshold, true);
    for (cv::KeyPoint kp : fast_buffer_) {
      const cv::Point2f full_px((kp.pt.x + roi.x) * static_cast<float>(s),
                                (kp.pt.y + roi.y) * static_cast<float>(s));
      // The widened region overlaps the neighbours: keep only this cell's corners.
      if (full_px.x < b.x_min || full_px.x >= b.x_end || full_px.y < b.y_min || full_px.y >= b.y_end)
        continue;
      kp.pt = full_px;
      kp.octave = l;
      kp.size = static_cast<float>(config_.patch_size_px * s);
      kp.class_id = cell;
      level_out.push_back(kp);
    }
    std::sort(level_out.begin(), level_out.end(), strongerFirst);
  }

  // FAST scores are not comparable across levels (on smooth terrain the coarse levels score higher, on sharp
  // texture the fine one), so a single ranking would fill a cell from one level. Interleave the levels
  // instead, strongest first within each, in ORB's proportions: level l gets a share proportional to
  // scale_factor^-l.
  std::fill(level_taken_.begin(), level_taken_.end(), 0);
  for (;;) {
    int best = -1;
    double best_load = 0.0;
    for (int l = 0; l < config_.num_levels; ++l) {
      if (level_taken_[l] >= level_candidates_[l].size()) continue;
      const double load =
          (level_taken_[l] + 1) * level_scale_[l];  // (taken + 1) / weight, weight = 1 / scale
      if (best < 0 || load < best_load) best = l, best_load = load;
    }
    if (best < 0) break;
    out->push_back(level_candidates_[best][level_taken_[best]++]);
  }
}

bool GridDetector::farFromAccepted(const cv::Point2f& px) const {
  if (config_.min_distance_px <= 0.0) return true;
  const double min_d2 = config_.min_distance_px * config_.min_distance_px;
  const int bx = static_cast<int>(px.x / bucket_size_px_), by = static_cast<int>(px.y / bucket_size_px_);
  // Buckets are at least min_distance_px wide, so any point within min_distance_px is in the 3x3
  // neighbourhood.
  for (int y = std::max(by - 1, 0); y <= std::min(by + 1, bucket_rows_ - 1); ++y) {
    for (int x = std::max(bx - 1, 0); x <= std::min(bx + 1, bucket_cols_ - 1); ++x) {
      for (int i = bucket_head_[y * bucket_cols_ + x]; i >= 0; i = bucket_next_[i]) {
        const double dx = accepted_px_[i].x - px.x, dy = accepted_px_[i].y - px.y;
        if (dx * dx + dy * dy < min_d2) return false;
      }
    }
  }
  return true;
}

void GridDetector::accept(const cv::Point2f& px) {
  if (config_.min_distance_px <= 0.0) return;
  const int bx = std::clamp(static_cast<int>(px.x / bucket_size_px_), 0, bucket_cols_ - 1);
  const int by = std::clamp(static_cast<int>(px.y / bucket_size_px_), 0, bucket_rows_ - 1);
  const int bucket = by * bucket_cols_ + bx;
  accepted_px_.push_back(px);
  bucket_next_.push_back(bucket_head_[bucket]);
  bucket_head_[bucket] = static_cast<int>(accepted_px_.size()) - 1;
}

std::vector<cv::KeyPoint> GridDetector::detect(const cv::Mat& gray,
                                               const std::vector<cv::Point2f>& existing_px,
                                               int cell_min_features, int min_active_cells) {
  CV_Assert(!gray.empty() && gray.type() == CV_8UC1);
  const int64 t_start = cv::getTickCount();
  const int n_cells = numCells();
  image_size_ = gray.size();
  stats_ = DetectionStats();
  stats_.new_per_cell.assign(n_cells, 0);
  stats_.existing_per_cell.assign(n_cells, 0);
  descriptors_.release();

  // Min-distance hash grid, seeded with the existing features so that new ones keep clear of them.
  accepted_px_.clear();
  bucket_next_.clear();
  if (config_.min_distance_px > 0.0) {
    bucket_size_px_ =
        std::max(config_.min_distance_px, 8.0);  // >= 8 px bounds the bucket count for tiny distances
    bucket_cols_ = static_cast<int>(std::ceil(gray.cols / bucket_size_px_)) + 1;
    bucket_rows_ = static_cast<int>(std::ceil(gray.rows / bucket_size_px_)) + 1;
    bucket_head_.assign(static_cast<size_t>(bucket_cols_) * bucket_rows_, -1);
  }
  for (const cv::Point2f& p : existing_px) {
    const int cell = cellIndex(p, image_size_);
    if (cell < 0) continue;
    ++stats_.existing_per_cell[cell];
    accept(p);
  }

  // Budget of the active cells: their share of num_features, less the features they already hold.
  const int share = config_.num_features / n_cells;
  int existing_in_active = 0;
  for (int c = 0; c < n_cells; ++c) {
    next_candidate_[c] = 0;
    candidates_[c].clear();
    if (stats_.existing_per_cell[c] >= cell_min_features) continue;
    ++stats_.active_cells;
    existing_in_active += stats_.existing_per_cell[c];
  }
  stats_.budget = std::max(0, static_cast<int>(std::lround(static_cast<double>(config_.num_features) *
                                                           stats_.active_cells / n_cells)) -
                                  existing_in_active);
  if (stats_.active_cells < std::min(min_active_cells, n_cells)) stats_.budget = 0;  // wait for more cells
  if (stats_.active_cells > 0 && stats_.budget > 0) {
    // A replenishment in a few cells computes only their part of the pyramid (main_brake_down 1024 flight,
    // one core: detection 1.35-1.55 -> 0.76-0.90 ms median over five starts, docs/visual_core.md step 7).
    if (config_.compute_descriptors || 4 * stats_.active_cells > n_cells)
      buildPyramid(gray);
    else
      buildPyramidRegions(gray, cell_min_features);
  }

  std::vector<cv::KeyPoint> result;
  result.reserve(stats_.budget);
  auto takeNext = [&](int c) {  // accepts the next candidate of cell c that keeps its distance; false if none
    std::vector<cv::KeyPoint>& cands = candidates_[c];
    while (next_candidate_[c] < cands.size()) {
      const cv::KeyPoint& kp = cands[next_candidate_[c]++];
      if (!farFromAccepted(kp.pt)) continue;
      accept(kp.pt);
      result.push_back(kp);
      ++stats_.new_per_cell[c];
      return true;
    }
    return false;
  };

  // Pass 1: each active cell takes up to its own share. A cell short of corners first retries with the low
  // threshold (ORB-SLAM's iniThFAST/minThFAST), so weakly textured ground still gets features of its own.
  for (int c = 0; c < n_cells && stats_.budget > 0; ++c) {
    if (stats_.existing_per_cell[c] >= cell_min_features) continue;
    const int quota = std::max(0, share - stats_.existing_per_cell[c]);
    collectCandidates(c, config_.fast_threshold, &candidates_[c]);
    if (config_.fast_threshold_fallback > 0 && static_cast<int>(candidates_[c].size()) < std::max(quota, 1)) {
      collectCandidates(c, config_.fast_threshold_fallback, &candidates_[c]);
      ++stats_.fallback_cells;
    }
    if (candidates_[c].empty()) ++stats_.empty_cells;
    for (int k = 0; k < quota && static_cast<int>(result.size()) < stats_.budget; ++k)
      if (!takeNext(c)) break;
  }

  // Pass 2: hand out what is left of the budget (the rounding remainder and the shares of corner-poor cells)
  // one feature per cell per round, the cell with the strongest next corner first. Without redistribution
  // only one round runs, so no cell exceeds ceil(num_features / cells).
  // Replenishment redistributes only towards the total budget: once the tracks already in the image and the
  // new features reach num_features, a corner-poor active cell's share is not handed to textured cells again.
  // Otherwise a textureless patch that stays in view donates its share at every detection, and the textured
  // cells that received it stay dense as they move across the image (main_brake_down 1024: 900 tracks for a
  // budget of 300, three times the tracking time). A full detection (no existing features) is not affected.
  int existing_total = 0;
  for (const int n : stats_.existing_per_cell) existing_total += n;
  const int pass2_target = std::min(
      stats_.budget, std::max(static_cast<int>(result.size()), config_.num_features - existing_total));
  std::vector<int> open_cells;
  for (int round = 0; static_cast<int>(result.size()) < pass2_target; ++round) {
    if (round > 0 && !config_.redistribute_budget) break;
    open_cells.clear();
    for (int c = 0; c < n_cells; ++c)
      if (stats_.existing_per_cell[c] < cell_min_features && next_candidate_[c] < candidates_[c].size())
        open_cells.push_back(c);
    if (open_cells.empty()) break;
    std::sort(open_cells.begin(), open_cells.end(), [&](int a, int b) {
      return strongerFirst(candidates_[a][next_candidate_[a]], candidates_[b][next_candidate_[b]]);
    });
    for (int c : open_cells) {
      if (static_cast<int>(result.size()) >= pass2_target) break;
      if (takeNext(c)) ++stats_.redistributed;
    }
  }
  stats_.detect_ms = msSince(t_start);

  if (config_.compute_descriptors && !result.empty()) {
    const int64 t_describe = cv::getTickCount();
    computeDescriptors(&result);
    stats_.describe_ms = msSince(t_describe);
  }
  return result;
}

void GridDetector::computeDescriptors(std::vector<cv::KeyPoint>* keypoints) {
  // cv::ORB::compute() takes the orientation from the keypoints, which FAST leaves unset: compute it as ORB
  // does, on the level the corner was found in.
  const int half_patch = config_.patch_size_px / 2;
  for (cv::KeyPoint& kp : *keypoints) {
    const double s = level_scale_[kp.octave];
    const cv::Point2f level_px(static_cast<float>(kp.pt.x / s), static_cast<float>(kp.pt.y / s));
    kp.angle = intensityCentroidAngleDeg(levels_[kp.octave], level_px, half_patch);
  }
  const size_t before = keypoints->size();
  orb_->compute(levels_[0], *keypoints, descriptors_);
  // ORB drops keypoints only closer to the border than edge_threshold_px, which detection already excluded.
  CV_Assert(keypoints->size() == before && descriptors_.rows == static_cast<int>(before));
}

}  // namespace planetary_vo

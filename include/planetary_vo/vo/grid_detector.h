#pragma once
/// @file grid_detector.h
/// Stage 1 of the chain: ORB-style corners (FAST on a scale pyramid, optional rBRIEF descriptors) spread over
/// a grid of image cells (thesis 4.4.2, 64 sub-windows), with the Phase-1 improvements of thesis 5.1: the
/// budget of cells without enough corners goes to textured cells, and detection can be restricted to the
/// cells that have become empty so that surviving tracks are kept (replenishment).
///
/// Unlike running cv::ORB on each sub-window (thesis Table 4.6: 26 ms for 64 windows), FAST runs once per
/// cell on the shared pyramid and no cell loses a border to the ORB patch, so cells are covered up to their
/// edges.

#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "planetary_vo/vo/config.h"

namespace planetary_vo {

/// What the last GridDetector::detect() call did, for diagnostics and tests.
struct DetectionStats {
  std::vector<int> new_per_cell;       ///< features added per cell, row-major (index = row * grid_cols + col)
  std::vector<int> existing_per_cell;  ///< existing features per cell given to detect()
  int active_cells = 0;                ///< cells that were searched (fewer existing features than requested)
  int fallback_cells = 0;              ///< active cells searched again with the low FAST threshold
  int empty_cells = 0;                 ///< active cells without a single corner (textureless)
  int redistributed = 0;               ///< features placed beyond their cell's own share (budget moved)
  int budget = 0;                      ///< features requested from the active cells
  double detect_ms = 0.0;              ///< pyramid + FAST + selection
  /// Pixels of the pyramid levels above full resolution that were computed: all of them for a detection in
  /// most cells, only the active cells' regions for a replenishment in a few (GridDetector::detect).
  long pyramid_pixels = 0;
  double describe_ms = 0.0;  ///< orientation + rBRIEF, 0 when descriptors are off
};

/// @brief Grid-distributed ORB/FAST feature detector.
///
/// Budget: each active cell first takes up to floor(num_features / cells) of its strongest corners (FAST
/// score), keeping min_distance_px from every feature already accepted or given as existing. The rest of the
/// budget is then handed out one feature per cell per round, cells with the strongest next corner first, to
/// cells that still have corners; so textureless cells donate their share and no textured cell gets more than
/// one feature above the others that could still take one. In replenishment (existing features given) the
/// handing out stops once the existing and new features reach num_features: a corner-poor cell that stays
/// empty does not give its share to the textured cells again at every detection.
///
/// Corners come from all num_levels pyramid levels (scale_factor apart, as ORB) and are reported at full
/// resolution with `octave` = level and `size` = patch_size_px * scale, so ORB descriptors can be computed
/// later. When at most a quarter of the cells is searched (replenishment) and no descriptors are wanted, only
/// the regions of the levels that their FAST reads are computed (bilinear from the level below, the same
/// sampling as the whole level's resize to within a grey level), not the whole pyramid.
///
/// Threading: not thread-safe (reuses internal buffers); use one instance per thread.
class GridDetector {
 public:
  explicit GridDetector(const DetectorConfig& config);

  /// @brief Detects new features.
  /// @param gray 8-bit single-channel image.
  /// @param existing_px features already tracked; they count towards their cell and keep new ones at
  ///        min_distance_px. Empty = full detection.
  /// @param cell_min_features a cell holding at least this many existing features is not searched (1 = detect
  ///        only in empty cells).
  /// @param min_active_cells nothing is detected (nor the pyramid built) unless at least this many cells hold
  ///        fewer than cell_min_features existing features (or every cell does, on a grid with fewer cells).
  /// @return the new features only, in full-resolution pixels; with compute_descriptors, lastDescriptors()
  /// holds
  ///         one row per returned keypoint.
  std::vector<cv::KeyPoint> detect(const cv::Mat& gray, const std::vector<cv::Point2f>& existing_px = {},
                                   int cell_min_features = 1, int min_active_cells = 1);

  /// rBRIEF descriptors of the last detect() (32 bytes per row, rows matching the keypoints); empty when
  /// compute_descriptors is off.
  const cv::Mat& lastDescriptors() const { return descriptors_; }
  const DetectionStats& lastStats() const { return stats_; }
  const DetectorConfig& config() const { return config_; }

  /// Grid cell (row-major index) containing `px` in an image of `image_size`; -1 outside the image.
  int cellIndex(const cv::Point2f& px, const cv::Size& image_size) const;
  /// Pixel rectangle of a cell; the grid splits the image evenly, the last row/column taking the rounding.
  cv::Rect cellRect(int cell, const cv::Size& image_size) const;
  int numCells() const { return config_.grid_cols * config_.grid_rows; }

 private:
  void buildPyramid(const cv::Mat& gray);
  /// Only the regions of levels 1.. that FAST reads for the active cells (existing_per_cell below
  /// cell_min_features), each computed from the level below.
  void buildPyramidRegions(const cv::Mat& gray, int cell_min_features);
  /// A cell's search area in full-resolution pixels: the cell less the edge_threshold_px border of the image.
  struct SearchBounds {
    float x_min, y_min, x_end, y_end;
    bool empty() const { return x_min >= x_end || y_min >= y_end; }
  };
  SearchBounds searchBounds(int cell) const;
  /// The region of level `l` that FAST reads for `cell`: its search area widened by FAST's margin (clipped to
  /// the level).
  cv::Rect fastRegion(int cell, int l) const;
  void collectCandidates(int cell, int threshold, std::vector<cv::KeyPoint>* out);
  bool farFromAccepted(const cv::Point2f& px) const;
  void accept(const cv::Point2f& px);
  void computeDescriptors(std::vector<cv::KeyPoint>* keypoints);

  DetectorConfig config_;
  std::vector<double> level_scale_;  // level -> full-resolution pixels per level pixel
  cv::Ptr<cv::ORB> orb_;             // descriptor extractor, only with compute_descriptors

  // Buffers reused from call to call so that a steady-state detect() allocates little.
  cv::Size image_size_;
  std::vector<cv::Mat> levels_;                              // level 0 is a header on the caller's image
  std::vector<cv::Rect> level_regions_;                      // per level, buildPyramidRegions() scratch
  std::vector<std::vector<cv::KeyPoint>> candidates_;        // per cell, strongest first
  std::vector<std::vector<cv::KeyPoint>> level_candidates_;  // per level, for the cell being collected
  std::vector<size_t> level_taken_;
  std::vector<cv::KeyPoint> fast_buffer_;
  std::vector<size_t> next_candidate_;  // per cell, first candidate not yet considered
  std::vector<int> bucket_head_;        // min-distance hash grid: first point index per bucket
  std::vector<int> bucket_next_;        // next point index in the same bucket
  std::vector<cv::Point2f> accepted_px_;
  int bucket_cols_ = 0, bucket_rows_ = 0;
  double bucket_size_px_ = 1.0;
  cv::Mat descriptors_;
  DetectionStats stats_;
};

}  // namespace planetary_vo

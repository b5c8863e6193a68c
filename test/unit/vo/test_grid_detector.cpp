/// Tests of GridDetector on synthetic textures: per-cell budget, redistribution away from textureless cells,
/// low-threshold fallback, minimum distance, replenishment masks and descriptors.

#include <algorithm>
#include <iostream>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "planetary_vo/vo/grid_detector.h"
#include "vo_test_images.h"

namespace planetary_vo {
namespace {

using test::texture;

const cv::Size kSize(640, 480);

std::vector<int> countPerCell(const GridDetector& d, const std::vector<cv::KeyPoint>& kps,
                              const cv::Size& size) {
  std::vector<int> counts(d.numCells(), 0);
  for (const cv::KeyPoint& kp : kps) {
    const int c = d.cellIndex(kp.pt, size);
    EXPECT_GE(c, 0) << "keypoint outside the image: " << kp.pt;
    if (c >= 0) ++counts[c];
  }
  return counts;
}

double minPairwiseDistance(const std::vector<cv::Point2f>& pts) {
  double best = 1e9;
  for (size_t i = 0; i < pts.size(); ++i)
    for (size_t j = i + 1; j < pts.size(); ++j) best = std::min(best, cv::norm(pts[i] - pts[j]));
  return best;
}

std::vector<cv::Point2f> positions(const std::vector<cv::KeyPoint>& kps) {
  std::vector<cv::Point2f> pts;
  for (const cv::KeyPoint& kp : kps) pts.push_back(kp.pt);
  return pts;
}

TEST(GridDetector, CellIndexAndCellRectAgreeOnEveryPixel) {
  DetectorConfig cfg;
  cfg.grid_cols = 7;
  cfg.grid_rows = 5;
  const GridDetector d(cfg);
  const cv::Size size(101, 77);  // not divisible by the grid
  std::vector<int> area(d.numCells(), 0);
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      const int c = d.cellIndex(cv::Point2f(x + 0.5f, y + 0.5f), size);
      ASSERT_GE(c, 0);
      ASSERT_TRUE(d.cellRect(c, size).contains(cv::Point(x, y))) << x << "," << y << " -> cell " << c;
      ++area[c];
    }
  }
  for (int c = 0; c < d.numCells(); ++c) EXPECT_EQ(area[c], d.cellRect(c, size).area()) << "cell " << c;
  EXPECT_EQ(d.cellIndex(cv::Point2f(-0.1f, 3.f), size), -1);
  EXPECT_EQ(d.cellIndex(cv::Point2f(101.f, 3.f), size), -1);
}

TEST(GridDetector, TexturedImageFillsTheBudgetEvenly) {
  const DetectorConfig cfg;  // 300 features, 8x8 grid, 10 px apart
  GridDetector d(cfg);
  const cv::Mat img = texture(kSize, 1);
  const std::vector<cv::KeyPoint> kps = d.detect(img);

  EXPECT_EQ(static_cast<int>(kps.size()), cfg.num_features);
  const std::vector<int> counts = countPerCell(d, kps, kSize);
  const int share = cfg.num_features / d.numCells();                            // 4
  const int ceil_share = (cfg.num_features + d.numCells() - 1) / d.numCells();  // 5
  for (int c = 0; c < d.numCells(); ++c) {
    EXPECT_GE(counts[c], share) << "cell " << c;
    EXPECT_LE(counts[c], ceil_share) << "cell " << c;
  }
  EXPECT_EQ(counts, d.lastStats().new_per_cell);
  EXPECT_GE(minPairwiseDistance(positions(kps)), cfg.min_distance_px);
  EXPECT_EQ(d.lastStats().empty_cells, 0);
  EXPECT_EQ(d.lastStats().active_cells, 64);
  // Corners come from several pyramid levels, reported at full resolution with ORB's size convention.
  int coarse = 0;
  for (const cv::KeyPoint& kp : kps) {
    ASSERT_GE(kp.octave, 0);
    ASSERT_LT(kp.octave, cfg.num_levels);
    EXPECT_NEAR(kp.size, cfg.patch_size_px * std::pow(cfg.scale_factor, kp.octave), 1e-3);
    coarse += kp.octave > 0;
  }
  EXPECT_GT(coarse, 0);
  EXPECT_TRUE(d.lastDescriptors().empty());
}

TEST(GridDetector, MinimumDistanceHoldsAcrossCellBorders) {
  DetectorConfig cfg;
  cfg.num_features = 2000;  // more than fit at 25 px spacing: the distance rule must be what limits the count
  cfg.min_distance_px = 25.0;
  GridDetector d(cfg);
  const std::vector<cv::KeyPoint> kps = d.detect(texture(kSize, 2));
  EXPECT_GE(minPairwiseDistance(positions(kps)), 25.0);
  EXPECT_GT(kps.size(), 200u);  // 640x480 / 25^2 ~ 490 discs; greedy packing reaches well over 200
  EXPECT_LT(kps.size(), 2000u);
}

TEST(GridDetector, TexturelessCellsGiveTheirBudgetToTexturedCells) {
  cv::Mat img = texture(kSize, 3);
  img(cv::Rect(0, 0, kSize.width / 2, kSize.height))
      .setTo(128);  // left half: flat, no corner at any threshold
  DetectorConfig cfg;
  GridDetector d(cfg);
  const std::vector<cv::KeyPoint> kps = d.detect(img);
  const std::vector<int> counts = countPerCell(d, kps, kSize);
  // Columns 0-2 are flat throughout. Column 3 ends at the flat/textured border, whose step edge has corners
  // of its own, so it is left out of the check.
  int flat = 0, max_textured = 0;
  for (int c = 0; c < d.numCells(); ++c) {
    if (c % cfg.grid_cols < 3) flat += counts[c];
    if (c % cfg.grid_cols >= 4) max_textured = std::max(max_textured, counts[c]);
  }
  EXPECT_EQ(flat, 0);
  EXPECT_GE(d.lastStats().empty_cells, 24);
  EXPECT_EQ(static_cast<int>(kps.size()), cfg.num_features);  // the whole budget went to the textured cells
  EXPECT_GE(max_textured, 7);  // ~300 over ~40 cells, against the 4-5 of an even split over 64
  EXPECT_GT(d.lastStats().redistributed, 300 - 64 * 4);  // more than the rounding remainder was moved
  EXPECT_GE(minPairwiseDistance(positions(kps)), cfg.min_distance_px);

  // Without redistribution the flat cells' budget is lost and no cell exceeds ceil(300 / 64) = 5.
  cfg.redistribute_budget = false;
  GridDetector fixed(cfg);
  const std::vector<cv::KeyPoint> kps_fixed = fixed.detect(img);
  const std::vector<int> counts_fixed = countPerCell(fixed, kps_fixed, kSize);
  EXPECT_LE(*std::max_element(counts_fixed.begin(), counts_fixed.end()), 5);
  EXPECT_LE(kps_fixed.size(), 40u * 5u);
  EXPECT_GE(kps_fixed.size(), 32u * 4u);
}

TEST(GridDetector, LowThresholdFallbackFindsCornersInFaintCells) {
  // Top-left 3x3 cells: texture of 6 grey levels standard deviation, too faint for FAST 20 but not for FAST 7
  // (shadowed or washed-out regolith). Only the 2x2 cells away from the step to the strong texture are
  // checked.
  cv::Mat img = texture(kSize, 4);
  const cv::Rect faint(0, 0, 240, 180);
  texture(faint.size(), 5, 2.0, 6.0).copyTo(img(faint));

  DetectorConfig cfg;
  cfg.fast_threshold_fallback = 0;
  GridDetector no_fallback(cfg);
  std::vector<int> counts = countPerCell(no_fallback, no_fallback.detect(img), kSize);
  const int faint_cells[] = {0, 1, 8, 9};
  for (int c : faint_cells)
    ASSERT_EQ(counts[c], 0) << "precondition: FAST 20 finds nothing in faint cell " << c;
  EXPECT_EQ(no_fallback.lastStats().fallback_cells, 0);

  cfg.fast_threshold_fallback = 7;
  GridDetector with_fallback(cfg);
  counts = countPerCell(with_fallback, with_fallback.detect(img), kSize);
  for (int c : faint_cells) EXPECT_GE(counts[c], 4) << "faint cell " << c << " should get its share";
  EXPECT_GE(with_fallback.lastStats().fallback_cells, 4);
  EXPECT_EQ(with_fallback.lastStats().empty_cells, 0);
}

TEST(GridDetector, ReplenishmentDetectsOnlyInEmptyCellsAndKeepsClearOfExistingFeatures) {
  const DetectorConfig cfg;
  GridDetector d(cfg);
  const cv::Mat img = texture(kSize, 6);
  const std::vector<cv::KeyPoint> full = d.detect(img);

  // Keep the features of all cells but a handful: those become the only empty cells.
  const std::vector<int> emptied = {0, 9, 27, 36, 63};
  std::vector<cv::Point2f> existing;
  for (const cv::KeyPoint& kp : full)
    if (std::find(emptied.begin(), emptied.end(), d.cellIndex(kp.pt, kSize)) == emptied.end())
      existing.push_back(kp.pt);

  const std::vector<cv::KeyPoint> added = d.detect(img, existing);
  const std::vector<int> counts = countPerCell(d, added, kSize);
  for (int c = 0; c < d.numCells(); ++c) {
    const bool is_emptied = std::find(emptied.begin(), emptied.end(), c) != emptied.end();
    if (is_emptied)
      EXPECT_GE(counts[c], 4) << "emptied cell " << c << " not refilled";
    else
      EXPECT_EQ(counts[c], 0) << "occupied cell " << c << " got new features";
  }
  EXPECT_EQ(d.lastStats().active_cells, static_cast<int>(emptied.size()));
  // The active cells' share of the budget: round(300 * 5 / 64) = 23.
  EXPECT_EQ(static_cast<int>(added.size()), 23);

  std::vector<cv::Point2f> all = existing;
  for (const cv::KeyPoint& kp : added) all.push_back(kp.pt);
  EXPECT_GE(minPairwiseDistance(all), cfg.min_distance_px);

  // Nothing to do when no cell is empty.
  EXPECT_TRUE(d.detect(img, positions(full)).empty());
  EXPECT_EQ(d.lastStats().active_cells, 0);
}

TEST(GridDetector, ReplenishmentRedistributesOnlyUpToTheTotalBudget) {
  // Left half flat: columns 0-2 (24 cells; column 3 has the step edge's corners) are empty at every
  // replenishment and have no corner to give. Repeated
  // detections must not hand their share to the textured cells again and again (the tracks would pile up in
  // the cells that received it): the redistribution stops where existing + new features reach num_features.
  cv::Mat img = texture(kSize, 9);
  img(cv::Rect(0, 0, kSize.width / 2, kSize.height)).setTo(128);
  const DetectorConfig cfg;
  GridDetector d(cfg);
  const std::vector<cv::KeyPoint> full = d.detect(img);
  ASSERT_EQ(static_cast<int>(full.size()), cfg.num_features)
      << "precondition: the textured half takes it all";

  // Empty four textured cells of the right half.
  const std::vector<int> emptied = {5, 22, 39, 63};
  std::vector<cv::Point2f> existing;
  for (const cv::KeyPoint& kp : full)
    if (std::find(emptied.begin(), emptied.end(), d.cellIndex(kp.pt, kSize)) == emptied.end())
      existing.push_back(kp.pt);
  const int deficit = cfg.num_features - static_cast<int>(existing.size());
  ASSERT_GT(deficit, 4 * 4) << "precondition: the emptied cells held more than their share";

  // Below the total budget: the emptied cells are refilled up to it, not beyond.
  std::vector<cv::KeyPoint> added = d.detect(img, existing);
  ASSERT_GE(d.lastStats().active_cells, 24 + 4);
  // The budget of the active cells (28 of 64 cells' share) is far larger than the deficit.
  ASSERT_GT(d.lastStats().budget, 2 * deficit);
  EXPECT_EQ(static_cast<int>(added.size()), deficit);
  std::vector<int> counts = countPerCell(d, added, kSize);
  for (int c : emptied) EXPECT_GE(counts[c], 4) << "emptied cell " << c << " not refilled";

  // At or above the total budget: each emptied cell gets its own share (300 / 64 = 4), nothing more.
  std::vector<cv::Point2f> crowded = existing;
  for (int i = 0; i < deficit + 10; ++i) crowded.push_back(existing[i % existing.size()]);
  added = d.detect(img, crowded);
  counts = countPerCell(d, added, kSize);
  for (int c : emptied) EXPECT_EQ(counts[c], 4) << "emptied cell " << c;
  EXPECT_EQ(static_cast<int>(added.size()), 4 * 4);
}

TEST(GridDetector, ReplenishmentInAFewCellsBuildsOnlyTheirPartOfThePyramid) {
  // Four emptied cells (two at the image's border, two inside) of 64: the replenishment computes only the
  // regions of the pyramid levels that their FAST reads, and finds the corners the whole pyramid gives (a
  // detector with descriptors on builds the whole pyramid: the reference). The partial levels sample the level
  // below bilinearly like the whole level's resize, to within a grey level, so a few corners may differ.
  const cv::Size size(1024, 768);
  const cv::Mat img = texture(size, 5);
  DetectorConfig cfg;
  GridDetector d(cfg);
  const std::vector<cv::KeyPoint> full = d.detect(img);
  const long full_pyramid_pixels = d.lastStats().pyramid_pixels;
  ASSERT_GT(full_pyramid_pixels, static_cast<long>(size.area()) / 2);  // levels 1-3 at 1.5: 0.73x the image
  const std::vector<int> emptied = {0, 20, 45, 63};
  std::vector<cv::Point2f> existing;
  for (const cv::KeyPoint& kp : full)
    if (std::find(emptied.begin(), emptied.end(), d.cellIndex(kp.pt, size)) == emptied.end())
      existing.push_back(kp.pt);

  d.detect(texture(size, 6));  // the levels now hold another image: nothing stale may pass for this one
  const std::vector<cv::KeyPoint> partial = d.detect(img, existing);
  ASSERT_EQ(d.lastStats().active_cells, 4);
  std::cout << "pyramid pixels: whole " << full_pyramid_pixels << ", four cells " << d.lastStats().pyramid_pixels
            << "\n";
  EXPECT_GT(d.lastStats().pyramid_pixels, 0);
  EXPECT_LT(d.lastStats().pyramid_pixels, full_pyramid_pixels / 8);

  DetectorConfig whole_cfg = cfg;
  whole_cfg.compute_descriptors = true;
  GridDetector whole(whole_cfg);
  const std::vector<cv::KeyPoint> reference = whole.detect(img, existing);
  EXPECT_EQ(whole.lastStats().pyramid_pixels, full_pyramid_pixels);
  ASSERT_EQ(partial.size(), reference.size());
  ASSERT_GE(partial.size(), 4u * 4u);
  int same = 0, coarse = 0;
  for (const cv::KeyPoint& kp : partial) {
    if (kp.octave > 0) ++coarse;
    for (const cv::KeyPoint& ref : reference)
      if (ref.octave == kp.octave && cv::norm(ref.pt - kp.pt) < 1e-3) {
        ++same;
        break;
      }
  }
  EXPECT_GT(coarse, 0) << "the test needs corners from the partial levels";
  std::cout << same << " of " << partial.size() << " corners as with the whole pyramid, " << coarse
            << " from levels above full resolution\n";
  EXPECT_GE(same, static_cast<int>(0.8 * partial.size())) << same << " of " << partial.size();
}

TEST(GridDetector, CellMinFeaturesTopsUpSparseCells) {
  DetectorConfig cfg;
  cfg.grid_cols = 4;
  cfg.grid_rows = 4;
  cfg.num_features = 160;  // 10 per cell
  GridDetector d(cfg);
  const cv::Mat img = texture(kSize, 7);
  // One existing feature in every cell: with cell_min_features = 1 nothing is searched; with 3 every cell is
  // topped up to its share of 10.
  std::vector<cv::Point2f> existing;
  for (int c = 0; c < d.numCells(); ++c) {
    const cv::Rect r = d.cellRect(c, kSize);
    existing.emplace_back(r.x + r.width / 2.f, r.y + r.height / 2.f);
  }
  EXPECT_TRUE(d.detect(img, existing, 1).empty());
  const std::vector<cv::KeyPoint> added = d.detect(img, existing, 3);
  const std::vector<int> counts = countPerCell(d, added, kSize);
  for (int c = 0; c < d.numCells(); ++c) EXPECT_EQ(counts[c], 9) << "cell " << c;
}

TEST(GridDetector, DescriptorsAreOptionalAndDoNotChangeTheKeypoints) {
  DetectorConfig cfg;
  const cv::Mat img = texture(kSize, 8);
  GridDetector plain(cfg);
  const std::vector<cv::KeyPoint> kps_plain = plain.detect(img);

  cfg.compute_descriptors = true;
  GridDetector described(cfg);
  const std::vector<cv::KeyPoint> kps = described.detect(img);
  // cv::ORB may reorder the keypoints (it groups them by level); the set must be the same.
  ASSERT_EQ(kps.size(), kps_plain.size());
  auto byPosition = [](const cv::KeyPoint& a, const cv::KeyPoint& b) {
    return a.pt.y != b.pt.y ? a.pt.y < b.pt.y : a.pt.x < b.pt.x;
  };
  std::vector<cv::KeyPoint> sorted = kps, sorted_plain = kps_plain;
  std::sort(sorted.begin(), sorted.end(), byPosition);
  std::sort(sorted_plain.begin(), sorted_plain.end(), byPosition);
  for (size_t i = 0; i < kps.size(); ++i) EXPECT_EQ(sorted[i].pt, sorted_plain[i].pt);

  const cv::Mat& desc = described.lastDescriptors();
  ASSERT_EQ(desc.rows, static_cast<int>(kps.size()));
  EXPECT_EQ(desc.cols, 32);
  EXPECT_EQ(desc.type(), CV_8U);
  // Distinct corners of random texture give distinct descriptors (about half the 256 bits differ).
  double mean_distance = 0.0;
  for (int i = 1; i < desc.rows; ++i)
    mean_distance += cv::norm(desc.row(i), desc.row(i - 1), cv::NORM_HAMMING);
  mean_distance /= desc.rows - 1;
  EXPECT_GT(mean_distance, 80.0);
  EXPECT_GT(described.lastStats().describe_ms, 0.0);

  // Descriptors describe the image content: the same full-resolution corner in an integer-shifted copy gets
  // the same descriptor (coarser levels resample differently, and the border is reflected, so only interior
  // octave-0 keypoints are compared).
  const cv::Point2f shift(5, 3);
  cv::Mat shifted;
  cv::warpAffine(img, shifted, test::translation(shift.x, shift.y), img.size(), cv::INTER_NEAREST,
                 cv::BORDER_REFLECT_101);
  std::vector<cv::KeyPoint> moved;
  std::vector<int> rows;
  for (size_t i = 0; i < kps.size(); ++i) {
    if (kps[i].octave != 0 || !cv::Rect(40, 40, kSize.width - 80, kSize.height - 80).contains(kps[i].pt))
      continue;
    moved.push_back(kps[i]);
    moved.back().pt += shift;
    rows.push_back(static_cast<int>(i));
  }
  ASSERT_GT(moved.size(), 30u);
  cv::Mat desc_moved;
  cv::ORB::create(300, 1.5f, 4, 0, 0, 2, cv::ORB::FAST_SCORE, 20)->compute(shifted, moved, desc_moved);
  ASSERT_EQ(desc_moved.rows, static_cast<int>(rows.size()));
  double same = 0.0;
  for (size_t i = 0; i < rows.size(); ++i)
    same += cv::norm(desc.row(rows[i]), desc_moved.row(i), cv::NORM_HAMMING);
  EXPECT_LT(same / rows.size(), 2.0);
}

TEST(GridDetector, RejectsNonGrayImages) {
  GridDetector d{DetectorConfig()};
  EXPECT_THROW(d.detect(cv::Mat()), cv::Exception);
  EXPECT_THROW(d.detect(cv::Mat(100, 100, CV_8UC3, cv::Scalar::all(0))), cv::Exception);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}

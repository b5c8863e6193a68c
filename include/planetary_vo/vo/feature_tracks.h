#pragma once
/// @file feature_tracks.h
/// Feature tracks with persistent ids, and the frame-to-frame correspondences handed to the geometry stage.

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace planetary_vo {

/// One feature followed from image to image. Positions are distorted (measured) pixels of the image they were
/// tracked in; undistortion is the geometry stage's business.
struct FeatureTrack {
  uint64_t id = 0;          ///< unique for the tracker's lifetime, never reused
  cv::Point2f px;           ///< position in the current frame
  cv::Point2f prev_px;      ///< position in the previous frame (equal to px in the frame it was detected)
  int64_t first_frame = 0;  ///< index (0-based, counted by the tracker) of the frame it was detected in
  int age_frames = 0;       ///< successful frame-to-frame tracking steps since detection
};

/// Point pairs between the previous and the current frame, as parallel arrays so that they can be handed to
/// cv::findFundamentalMat & co. directly. Entry i of every array belongs to the same track.
struct FrameCorrespondences {
  std::vector<uint64_t> track_ids;
  std::vector<cv::Point2f> prev_px;
  std::vector<cv::Point2f> curr_px;

  size_t size() const { return track_ids.size(); }
  bool empty() const { return track_ids.empty(); }
  void clear() {
    track_ids.clear();
    prev_px.clear();
    curr_px.clear();
  }
  void push_back(uint64_t id, const cv::Point2f& prev, const cv::Point2f& curr) {
    track_ids.push_back(id);
    prev_px.push_back(prev);
    curr_px.push_back(curr);
  }
};

}  // namespace planetary_vo

#pragma once
/// @file sample_buffer.h
/// The nodelet's waiting room for IMU and altimeter samples: messages arrive on their own connections, in any
/// order relative to the images, and the pipeline wants them in stamp order, before the image they precede
/// (Pipeline::addImu / addAltimeter). A SampleBuffer keeps the samples not yet given to the pipeline sorted
/// by stamp, gives them out up to a time, and refuses what the pipeline would refuse: a sample not after the
/// last one given out (out of order, too late) or with the stamp of a buffered one (duplicate). No ROS, no
/// estimation: unit-tested in test/ros/test_vo_conversions.cpp.

#include <algorithm>
#include <cstddef>
#include <deque>
#include <iterator>
#include <limits>
#include <optional>

namespace planetary_vo::ros_io {

template <class Sample>
class SampleBuffer {
 public:
  enum class Insert {
    kBuffered,   ///< kept, in stamp order
    kDuplicate,  ///< a buffered sample (or the last one given out) has the same stamp: refused
    kTooOld,     ///< older than the last sample given out: refused (the pipeline has moved past it)
    kSuspect,    ///< more than max_jump_s after the newest sample: refused once, the next sample decides
  };

  /// @param max_span_s samples more than this older than the newest are dropped on insert (flat memory while
  ///        no image consumes them); dropped() counts them.
  /// @param max_jump_s a sample more than this after the newest one (buffered or given out) is a stamp jump:
  ///        refused as suspect, so that one sample stamped a year ahead cannot push every later one out of
  ///        the buffer (as the newest, it made all others "older than max_span_s"). If the next sample
  ///        follows the suspect (within max_jump_s after it), the stream really jumped and goes on from
  ///        there; if it follows the old timeline, the suspect was an outlier.
  explicit SampleBuffer(double max_span_s = 10.0, double max_jump_s = 1.0)
      : max_span_s_(max_span_s), max_jump_s_(max_jump_s) {}

  Insert insert(const Sample& sample) {
    const double t = sample.timestamp_s;
    if (last_given_ && t == *last_given_) return Insert::kDuplicate;
    if (last_given_ && t < *last_given_) return Insert::kTooOld;
    std::optional<double> newest = last_given_;
    if (!samples_.empty() && (!newest || samples_.back().timestamp_s > *newest))
      newest = samples_.back().timestamp_s;
    if (newest && t > *newest + max_jump_s_) {
      const bool confirms = suspect_ && t > *suspect_ && t <= *suspect_ + max_jump_s_;
      if (!confirms) {
        suspect_ = t;
        return Insert::kSuspect;
      }
      ++jumps_;
    }
    suspect_.reset();  // either confirmed, or the stream went on on its timeline (the suspect was an outlier)
    const auto at = std::upper_bound(samples_.begin(), samples_.end(), t,
                                     [](double s, const Sample& b) { return s < b.timestamp_s; });
    if (at != samples_.begin() && std::prev(at)->timestamp_s == t) return Insert::kDuplicate;
    samples_.insert(at, sample);
    while (!samples_.empty() && samples_.front().timestamp_s < samples_.back().timestamp_s - max_span_s_) {
      samples_.pop_front();
      ++dropped_;
    }
    return Insert::kBuffered;
  }

  /// Removes the samples with stamp <= t_s and calls consume(sample) on each, in stamp order. Returns how
  /// many.
  template <class Consume>
  size_t giveUpTo(double t_s, Consume&& consume) {
    size_t n = 0;
    while (!samples_.empty() && samples_.front().timestamp_s <= t_s) {
      const Sample s = samples_.front();
      samples_.pop_front();
      last_given_ = s.timestamp_s;
      consume(s);
      ++n;
    }
    return n;
  }
  /// All of them.
  template <class Consume>
  size_t giveAll(Consume&& consume) {
    return giveUpTo(std::numeric_limits<double>::infinity(), consume);
  }

  /// Forgets the samples with stamp <= t_s without giving them out (they precede the first processed image).
  void discardUpTo(double t_s) {
    while (!samples_.empty() && samples_.front().timestamp_s <= t_s) samples_.pop_front();
  }

  /// A new consumer (a new pipeline): any stamp is accepted again; the buffered samples stay.
  void restart() { last_given_.reset(); }
  void clear() {
    samples_.clear();
    last_given_.reset();
    suspect_.reset();
  }

  size_t size() const { return samples_.size(); }
  bool empty() const { return samples_.empty(); }
  std::optional<double> lastGiven() const { return last_given_; }
  size_t dropped() const { return dropped_; }
  /// The largest forward step that is not a stamp jump (kSuspect beyond it).
  double maxJumpS() const { return max_jump_s_; }
  /// Forward stamp jumps confirmed by the sample after the suspect.
  size_t jumps() const { return jumps_; }

 private:
  double max_span_s_;
  double max_jump_s_;
  std::optional<double> suspect_;
  size_t jumps_ = 0;
  std::deque<Sample> samples_;  // ascending stamps, none equal
  std::optional<double> last_given_;
  size_t dropped_ = 0;
};

}  // namespace planetary_vo::ros_io

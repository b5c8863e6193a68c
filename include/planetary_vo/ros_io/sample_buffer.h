#pragma once
/// @file sample_buffer.h
/// The nodelet's waiting room for IMU and altimeter samples: messages arrive on their own connections, in any
/// order relative to the images, and the pipeline wants them in stamp order, before the image they precede
/// (Pipeline::addImu / addAltimeter). A SampleBuffer keeps the samples not yet given to the pipeline sorted
/// by stamp, gives them out up to a time, and refuses what the pipeline would refuse: a sample not after the
/// last one given out (out of order, too late) or with the stamp of a buffered one (duplicate). A single
/// sample stamped far ahead neither flushes the buffer nor is given out unless the stream confirms the jump.
/// No ROS, no estimation: unit-tested in test/ros/test_vo_conversions.cpp.

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
  };

  /// @param max_span_s samples more than this older than an inserted one are dropped on insert (flat memory
  ///        while no image consumes them); dropped() counts them. It is also the largest step between two
  ///        consecutive samples that is not a jump (see giveUpTo()).
  explicit SampleBuffer(double max_span_s = 10.0) : max_span_s_(max_span_s) {}

  Insert insert(const Sample& sample) {
    const double t = sample.timestamp_s;
    if (last_given_ && t == *last_given_) return Insert::kDuplicate;
    if (last_given_ && t < *last_given_) return Insert::kTooOld;
    const auto at = std::upper_bound(samples_.begin(), samples_.end(), t,
                                     [](double s, const Sample& b) { return s < b.timestamp_s; });
    if (at != samples_.begin() && std::prev(at)->timestamp_s == t) return Insert::kDuplicate;
    // Flat memory: samples more than max_span_s older than this one are dropped, unless this one jumps more
    // than max_span_s ahead of the sample before it (a corrupt stamp, or the first sample of a stream that
    // really jumped: then the next sample drops the old ones). Issue 12, fuzz test: relative to the newest
    // sample, one reading stamped years ahead made every later good reading "too old", dropped on insert,
    // silently, for good.
    const bool jump = at != samples_.begin() && t - std::prev(at)->timestamp_s > max_span_s_;
    samples_.insert(at, sample);
    while (!jump && !samples_.empty() && samples_.front().timestamp_s < t - max_span_s_) {
      samples_.pop_front();
      ++dropped_;
    }
    return Insert::kBuffered;
  }

  /// Removes the samples with stamp <= t_s and calls consume(sample) on each, in stamp order. Returns how
  /// many. A sample more than max_span_s after the last one given out is a jump: it is given only once the
  /// sample after it confirms the new timeline (within max_span_s of it), else it waits (issue 12, fuzz test:
  /// one IMU sample stamped years ahead, given at once by the IMU-rate output, made the pipeline refuse every
  /// later sample as out of order, for good).
  template <class Consume>
  size_t giveUpTo(double t_s, Consume&& consume) {
    size_t n = 0;
    while (!samples_.empty() && samples_.front().timestamp_s <= t_s) {
      const double t = samples_.front().timestamp_s;
      const bool jump = last_given_ && t - *last_given_ > max_span_s_;
      if (jump && !(samples_.size() > 1 && samples_[1].timestamp_s - t <= max_span_s_)) break;
      const Sample s = samples_.front();
      samples_.pop_front();
      last_given_ = s.timestamp_s;
      consume(s);
      ++n;
    }
    return n;
  }
  /// All of them (up to an unconfirmed jump: see giveUpTo()).
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
  }

  size_t size() const { return samples_.size(); }
  bool empty() const { return samples_.empty(); }
  std::optional<double> lastGiven() const { return last_given_; }
  size_t dropped() const { return dropped_; }

 private:
  double max_span_s_;
  std::deque<Sample> samples_;  // ascending stamps, none equal
  std::optional<double> last_given_;
  size_t dropped_ = 0;
};

}  // namespace planetary_vo::ros_io

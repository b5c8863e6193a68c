#pragma once
/// @file containment.h
/// Exception containment for ROS callbacks. An exception that leaves a callback reaches the nodelet manager's
/// spinner and aborts every nodelet the manager holds, so every callback body of the VO and hazard nodelets
/// and of aligned_path_node runs through runContained(): whatever the body throws (an std::exception from
/// OpenCV, Ceres, the allocator or the code itself, or anything else: an int, a string, a library's own type)
/// is caught and described, and the caller reports it (log + status) and carries on.

#include <exception>
#include <optional>
#include <string>

namespace planetary_vo {
namespace ros_io {

/// The description of an exception that reached no handler of its own: what() for an std::exception, else
/// "unknown exception (not derived from std::exception)". Never throws (a failure to build the text gives a
/// fixed one).
inline std::string describeException(const std::exception_ptr& error) noexcept {
  if (!error) return "no exception";
  try {
    try {
      std::rethrow_exception(error);
    } catch (const std::exception& e) {
      return e.what();
    } catch (...) {
      return "unknown exception (not derived from std::exception)";
    }
  } catch (...) {
  }
  return {};
}

/// Runs body(). Returns nothing when it returns normally, else the description of what it threw
/// (describeException). No exception leaves this function.
template <class Body>
std::optional<std::string> runContained(Body&& body) noexcept {
  std::exception_ptr error;
  try {
    body();
    return std::nullopt;
  } catch (...) {
    error = std::current_exception();
  }
  std::string why = describeException(error);
  if (why.empty()) why = "exception (its description could not be built)";
  return why;
}

}  // namespace ros_io
}  // namespace planetary_vo

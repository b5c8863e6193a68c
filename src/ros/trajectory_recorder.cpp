/// @file trajectory_recorder.cpp
/// The `trajectory_recorder` node: subscribes to a geometry_msgs/PoseStamped topic (`pose`, remap it) and
/// writes every pose as a TUM line (stamp x y z qx qy qz qw) to ~output, flushed per line so that the file is
/// complete whenever the node is stopped. The demo records vo/pose and ground_truth/pose with it.
///
/// Parameters: ~output (string, required) file to write; ~stamp_offset (double, 0) subtracted from every
/// stamp (e.g. the player's epoch, so that the file has dataset times).

#include <fstream>
#include <iomanip>
#include <string>

#include <geometry_msgs/PoseStamped.h>
#include <ros/ros.h>

namespace {

class TrajectoryRecorder {
 public:
  TrajectoryRecorder(ros::NodeHandle& nh, const std::string& path, double stamp_offset_s) : out_(path) {
    stamp_offset_.fromSec(stamp_offset_s);
    if (!out_) throw std::runtime_error("cannot write " + path);
    out_ << "# timestamp tx ty tz qx qy qz qw\n" << std::setprecision(9) << std::fixed;
    sub_ = nh.subscribe("pose", 1000, &TrajectoryRecorder::onPose, this);
  }

 private:
  void onPose(const geometry_msgs::PoseStampedConstPtr& msg) {
    const auto& p = msg->pose.position;
    const auto& q = msg->pose.orientation;
    out_ << (msg->header.stamp - stamp_offset_).toSec() << ' ' << p.x << ' ' << p.y << ' ' << p.z << ' '
         << q.x << ' ' << q.y << ' ' << q.z << ' ' << q.w << std::endl;
  }

  std::ofstream out_;
  ros::Time stamp_offset_;  ///< subtracted in integer nanoseconds, so 1e9 s + 0.3 s gives exactly 0.3
  ros::Subscriber sub_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "trajectory_recorder");
  ros::NodeHandle nh, pnh("~");
  std::string output;
  if (!pnh.getParam("output", output) || output.empty()) {
    ROS_FATAL("trajectory_recorder: set ~output to the TUM file to write");
    return 1;
  }
  try {
    TrajectoryRecorder recorder(nh, output, pnh.param("stamp_offset", 0.0));
    ROS_INFO_STREAM("trajectory_recorder: " << ros::names::resolve("pose") << " -> " << output);
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("trajectory_recorder: " << e.what());
    return 1;
  }
  return 0;
}

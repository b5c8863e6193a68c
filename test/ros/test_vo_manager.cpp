/// gtest node of vo_reload.test: the VO nodelet is unloaded from and loaded again into a running manager
/// through the manager's services (as `nodelet unload` / `nodelet load` do), twice. After each reload the
/// nodelet subscribes again and answers frames with status and pose; the manager stays up throughout.

#include <algorithm>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/PoseStamped.h>
#include <image_transport/image_transport.h>
#include <nodelet/NodeletList.h>
#include <nodelet/NodeletLoad.h>
#include <nodelet/NodeletUnload.h>
#include <ros/ros.h>

#include "planetary_vo/VoStatus.h"
#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/ros_io/conversions.h"
#include "test_ros_helpers.h"

namespace planetary_vo::ros_io {
namespace {

class VoReloadTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ros::NodeHandle pnh("~");
    std::string dir;
    ASSERT_TRUE(pnh.getParam("dataset", dir));
    manager_ = pnh.param<std::string>("manager", "/vo_manager");
    nodelet_ = pnh.param<std::string>("nodelet", "/vo");
    dataset_ = std::make_unique<Dataset>(Dataset::open(dir));
    image_pub_ = transport_.advertise("camera/image_raw", 10);
    info_pub_ = nh_.advertise<sensor_msgs::CameraInfo>("camera/camera_info", 10);
    status_sub_ = nh_.subscribe("vo/status", 100, &VoReloadTest::onStatus, this);
  }
  void onStatus(const VoStatusConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!m->header.stamp.isZero()) stamps_.push_back(m->header.stamp);
  }
  bool loaded() {
    nodelet::NodeletList list;
    if (!ros::service::call(manager_ + "/list", list)) return false;
    return std::count(list.response.nodelets.begin(), list.response.nodelets.end(), nodelet_) > 0;
  }
  /// Streams frames [begin, end) in lock step with vo/status; true if every frame got its status.
  bool stream(size_t begin, size_t end) {
    // Nothing may be lost on the way, or a frame never gets its status. The nodelet subscribes to the image
    // and to camera_info separately (they connect in either order; an image without its camera_info is never
    // processed), and the status connection is only usable once the manager has accepted it: the subscriber
    // side counts the publisher earlier (see allConnected()).
    if (!waitFor(
            [&] {
              return image_pub_.getNumSubscribers() > 0 && info_pub_.getNumSubscribers() > 0 &&
                     publisherSendsTo(manager_, status_sub_.getTopic());
            },
            30.0))
      return false;
    for (size_t i = begin; i < end; ++i) {
      const ros::Time t = toStamp(ros::Time(1000000000, 0), dataset_->timestamp(i));
      const std_msgs::Header header = makeHeader(t, "camera_optical");
      info_pub_.publish(toCameraInfo(dataset_->camera(), header));
      image_pub_.publish(cv_bridge::CvImage(header, "mono8", dataset_->loadImage(i)).toImageMsg());
      if (!waitFor(
              [&] {
                std::lock_guard<std::mutex> lock(mutex_);
                return std::find(stamps_.begin(), stamps_.end(), t) != stamps_.end();
              },
              30.0))
        return false;
    }
    return true;
  }

  ros::NodeHandle nh_;
  image_transport::ImageTransport transport_{nh_};
  image_transport::Publisher image_pub_;
  ros::Publisher info_pub_;
  ros::Subscriber status_sub_;
  std::string manager_, nodelet_;
  std::unique_ptr<Dataset> dataset_;
  std::mutex mutex_;
  std::vector<ros::Time> stamps_;
};

TEST_F(VoReloadTest, UnloadAndReloadInARunningManager) {
  ASSERT_TRUE(ros::service::waitForService(manager_ + "/load_nodelet", ros::Duration(30.0)));
  ASSERT_TRUE(waitFor([&] { return loaded(); }, 30.0)) << nodelet_ << " never appeared in " << manager_;
  ASSERT_TRUE(stream(0, 5)) << "the nodelet does not answer before the first unload";
  size_t next = 5;
  for (int round = 0; round < 2; ++round) {
    SCOPED_TRACE("round " + std::to_string(round));
    nodelet::NodeletUnload unload;
    unload.request.name = nodelet_;
    ASSERT_TRUE(ros::service::call(manager_ + "/unload_nodelet", unload));
    ASSERT_TRUE(unload.response.success);
    EXPECT_FALSE(loaded());
    // Unloaded means unsubscribed: the camera topics lose their subscriber. Also, stream() after the reload
    // must not take a connection to the unloaded nodelet that is still being closed for the new one.
    ASSERT_TRUE(waitFor(
        [&] { return image_pub_.getNumSubscribers() == 0 && info_pub_.getNumSubscribers() == 0; }, 30.0));

    nodelet::NodeletLoad load;
    load.request.name = nodelet_;
    load.request.type = "planetary_vo/VisualOdometryNodelet";
    ASSERT_TRUE(ros::service::call(manager_ + "/load_nodelet", load));
    ASSERT_TRUE(load.response.success);
    EXPECT_TRUE(loaded());
    ASSERT_TRUE(stream(next, next + 8)) << "the reloaded nodelet does not answer";
    next += 8;
  }
}

}  // namespace
}  // namespace planetary_vo::ros_io

int main(int argc, char** argv) { return planetary_vo::ros_io::runRosTests(argc, argv, "test_vo_manager"); }

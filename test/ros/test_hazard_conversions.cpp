/// Hazard products <-> messages (hazard_conversions.h), no master: the rasters round trip bit for bit (NaN
/// included) with the grid geometry; the occupancy grid maps safe / hazard / unknown to 0 / 100 / -1 in the
/// grid's row order; sites keep their order in the pose array and markers; malformed messages are refused.
#include <cmath>
#include <cstring>
#include <limits>

#include <gtest/gtest.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include "planetary_vo/ros_io/hazard_conversions.h"

using namespace planetary_vo;
using namespace planetary_vo::ros_io;

namespace {

terrain::HazardProducts someProducts() {
  terrain::HazardProducts p;
  terrain::GridGeometry g;
  g.x0_m = -3.0;
  g.y0_m = 10.0;
  g.cell_size_m = 0.5;
  g.cols = 7;
  g.rows = 5;
  p.terrain.grids.geometry = g;
  p.terrain.metric = true;
  p.terrain.num_points = 1234;
  const char* names[] = {"elevation_m",     "elevation_sigma_m", "relief_sigma_m",
                         "slope_sigma_deg", "residual_rms_m",    "slope_deg",
                         "roughness_m",     "shadow_fraction",   "shading_slope_deg"};
  for (int i = 0; i < 9; ++i) {
    cv::Mat layer = g.newLayer();
    for (int r = 0; r < g.rows; ++r)
      for (int c = 0; c < g.cols; ++c)
        if ((r + c) % 4 != 0) layer.at<float>(r, c) = float(i * 100 + r * 10 + c) + 0.25f;
    p.terrain.grids.layers[names[i]] = layer;
  }
  p.terrain.cells_known =
      cv::countNonZero(p.terrain.grids.layers["elevation_m"] == p.terrain.grids.layers["elevation_m"]);
  p.hazard = cv::Mat(g.rows, g.cols, CV_8U, cv::Scalar(terrain::kSafe));
  p.hazard.at<uint8_t>(1, 2) = terrain::kHazard;
  p.hazard.at<uint8_t>(4, 6) = terrain::kUnknown;
  return p;
}

bool sameBits(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() &&
         std::memcmp(a.data, b.data, a.total() * a.elemSize()) == 0;
}

}  // namespace

TEST(HazardConversions, RastersRoundTripWithTheGeometry) {
  const terrain::HazardProducts products = someProducts();
  terrain::HazardMapperConfig config;
  config.shading.sun_elevation_deg = 12.0;
  config.shading.sun_azimuth_deg = 250.0;
  std_msgs::Header header;
  header.frame_id = "world";
  header.stamp = ros::Time(1000, 5);
  const HazardMap msg = toHazardMapMsg(products, config, header);
  EXPECT_EQ(msg.header.frame_id, "world");
  EXPECT_TRUE(msg.metric);
  EXPECT_EQ(msg.num_points, 1234u);
  EXPECT_EQ(msg.elevation_m.encoding, "32FC1");
  EXPECT_EQ(msg.elevation_m.width, 7u);
  EXPECT_EQ(msg.elevation_m.height, 5u);
  // OccupancyGrid's convention: origin at the outer corner of cell (0, 0).
  EXPECT_DOUBLE_EQ(msg.info.origin.position.x, -3.25);
  EXPECT_DOUBLE_EQ(msg.info.origin.position.y, 9.75);
  const terrain::GridSet back = fromHazardMapMsg(msg);
  EXPECT_TRUE(back.geometry == products.terrain.grids.geometry);
  for (const char* name :
       {"elevation_m", "elevation_sigma_m", "relief_sigma_m", "slope_sigma_deg", "residual_rms_m",
        "slope_deg", "roughness_m", "shadow_fraction", "shading_slope_deg"})
    EXPECT_TRUE(sameBits(back.layers.at(name), products.terrain.grids.layers.at(name))) << name;
  EXPECT_EQ(back.parameters.at("max_shadow_fraction"), config.thresholds.max_shadow_fraction);
  EXPECT_EQ(back.parameters.at("max_shading_slope_deg"), config.thresholds.max_shading_slope_deg);
  EXPECT_EQ(back.parameters.at("shading_margin_m"), config.thresholds.shading_margin_m);
  EXPECT_EQ(back.parameters.at("shading_slope_weight"), config.thresholds.shading_slope_weight);
  EXPECT_EQ(back.parameters.at("sun_elevation_deg"), config.shading.sun_elevation_deg);
  EXPECT_EQ(back.parameters.at("sun_azimuth_deg"), config.shading.sun_azimuth_deg);
  EXPECT_EQ(back.parameters.at("footprint_diameter_m"), config.area.footprint_diameter_m);
  EXPECT_EQ(back.parameters.at("max_slope_deg"), config.thresholds.max_slope_deg);

  HazardMap bad = msg;
  bad.slope_deg.width = 6;
  EXPECT_THROW(fromHazardMapMsg(bad), std::invalid_argument);
  bad = msg;
  bad.roughness_m.encoding = "mono8";
  EXPECT_THROW(fromHazardMapMsg(bad), std::invalid_argument);
  bad = msg;
  bad.elevation_m.data.resize(10);
  EXPECT_THROW(fromHazardMapMsg(bad), std::invalid_argument);
  bad = msg;
  bad.info.resolution = 0.0f;
  EXPECT_THROW(fromHazardMapMsg(bad), std::invalid_argument);
  bad = msg;
  bad.info.origin.orientation.w = std::sqrt(0.5);
  bad.info.origin.orientation.z = std::sqrt(0.5);
  EXPECT_THROW(fromHazardMapMsg(bad), std::invalid_argument);
}

TEST(HazardConversions, OccupancyGridValuesAndOrder) {
  const terrain::HazardProducts products = someProducts();
  std_msgs::Header header;
  header.frame_id = "world";
  const nav_msgs::OccupancyGrid grid =
      toOccupancyGrid(products.hazard, products.terrain.grids.geometry, header);
  ASSERT_EQ(grid.data.size(), 35u);
  EXPECT_EQ(grid.data[1 * 7 + 2], kOccupancyHazard);  // row-major from cell (0, 0)
  EXPECT_EQ(grid.data[4 * 7 + 6], kOccupancyUnknown);
  EXPECT_EQ(grid.data[0], kOccupancySafe);
  EXPECT_EQ(std::count(grid.data.begin(), grid.data.end(), kOccupancySafe), 33);
  EXPECT_THROW(toOccupancyGrid(cv::Mat(5, 6, CV_8U), products.terrain.grids.geometry, header),
               std::invalid_argument);
}

TEST(HazardConversions, SitesPosesMarkersAndCloud) {
  terrain::LandingSiteResult result;
  for (int i = 0; i < 3; ++i) {
    terrain::LandingSite s;
    s.x_m = 10.0 * i;
    s.y_m = -5.0;
    s.elevation_m = i == 1 ? std::numeric_limits<double>::quiet_NaN() : 2.0;
    s.slope_deg = 3.0 + i;
    s.score = 1.0 - 0.1 * i;
    result.sites.push_back(s);
  }
  terrain::LandingSiteParams params;
  params.target_x_m = 1.0;
  std_msgs::Header header;
  header.frame_id = "world";
  const LandingSites msg = toLandingSitesMsg(result, params, true, header);
  ASSERT_EQ(msg.sites.size(), 3u);
  EXPECT_EQ(msg.target.x, 1.0);
  EXPECT_EQ(msg.sites[2].slope_deg, 5.0);
  terrain::LandingSiteParams back_params;
  const terrain::LandingSiteResult back = fromLandingSitesMsg(msg, &back_params);
  ASSERT_EQ(back.sites.size(), 3u);
  EXPECT_EQ(back.sites[2].slope_deg, 5.0);
  EXPECT_EQ(back.sites[1].x_m, 10.0);
  EXPECT_TRUE(std::isnan(back.sites[1].elevation_m));
  EXPECT_EQ(back.sites[0].score, 1.0);
  EXPECT_EQ(back_params.target_x_m, 1.0);
  EXPECT_EQ(back_params.min_clearance_m, params.min_clearance_m);
  const geometry_msgs::PoseArray poses = toPoseArray(msg);
  ASSERT_EQ(poses.poses.size(), 3u);
  EXPECT_EQ(poses.poses[1].position.x, 10.0);
  EXPECT_EQ(poses.poses[1].position.z, 0.0);  // unknown elevation -> 0, never NaN
  EXPECT_EQ(poses.poses[0].orientation.w, 1.0);
  const visualization_msgs::MarkerArray markers = toMarkers(msg);
  // DELETEALL, the target, a disc and a label per site.
  ASSERT_EQ(markers.markers.size(), 1u + 1u + 2u * 3u);
  EXPECT_EQ(markers.markers[0].action, visualization_msgs::Marker::DELETEALL);
  for (const auto& m : markers.markers) EXPECT_TRUE(std::isfinite(m.pose.position.z));

  const terrain::HazardProducts products = someProducts();
  const sensor_msgs::PointCloud2 cloud = toElevationCloud(products.terrain.grids, 1, header);
  EXPECT_EQ(int(cloud.width), products.terrain.cells_known);
  sensor_msgs::PointCloud2ConstIterator<float> z(cloud, "z"), intensity(cloud, "intensity");
  for (; z != z.end(); ++z, ++intensity) {
    EXPECT_TRUE(std::isfinite(*z));
    EXPECT_TRUE(std::isfinite(*intensity));
  }
  EXPECT_LT(int(toElevationCloud(products.terrain.grids, 2, header).width), products.terrain.cells_known);
  EXPECT_THROW(toElevationCloud(products.terrain.grids, 0, header), std::invalid_argument);
}

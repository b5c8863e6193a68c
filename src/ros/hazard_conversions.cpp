/// @file hazard_conversions.cpp
/// Hazard products <-> messages (see hazard_conversions.h).

#include "planetary_vo/ros_io/hazard_conversions.h"

#include <cmath>
#include <cstring>
#include <iomanip>
#include <sstream>
#include <string>

#include <sensor_msgs/image_encodings.h>
#include <sensor_msgs/point_cloud2_iterator.h>

namespace planetary_vo::ros_io {
namespace {

constexpr int kNumRasterLayers = 9;
const char* const kRasterLayers[kNumRasterLayers] = {
    "elevation_m", "elevation_sigma_m", "relief_sigma_m",  "slope_sigma_deg",  "residual_rms_m",
    "slope_deg",   "roughness_m",       "shadow_fraction", "shading_slope_deg"};

sensor_msgs::Image floatImage(const cv::Mat& layer, const std_msgs::Header& header) {
  sensor_msgs::Image img;
  img.header = header;
  img.encoding = sensor_msgs::image_encodings::TYPE_32FC1;
  img.is_bigendian = 0;
  img.height = static_cast<uint32_t>(layer.rows);
  img.width = static_cast<uint32_t>(layer.cols);
  img.step = img.width * sizeof(float);
  img.data.resize(static_cast<size_t>(img.step) * img.height);
  for (int r = 0; r < layer.rows; ++r)
    std::memcpy(&img.data[static_cast<size_t>(r) * img.step], layer.ptr<float>(r), img.step);
  return img;
}

cv::Mat fromFloatImage(const sensor_msgs::Image& img, const terrain::GridGeometry& g, const char* name) {
  if (img.encoding != sensor_msgs::image_encodings::TYPE_32FC1 || img.is_bigendian ||
      int(img.width) != g.cols || int(img.height) != g.rows || img.step < img.width * sizeof(float) ||
      img.data.size() < size_t(img.step) * img.height)
    throw std::invalid_argument(std::string("HazardMap rejected: layer ") + name +
                                " is not a little-endian 32FC1 image of the grid's size");
  cv::Mat layer(g.rows, g.cols, CV_32F);
  for (int r = 0; r < g.rows; ++r)
    std::memcpy(layer.ptr<float>(r), &img.data[size_t(r) * img.step], g.cols * sizeof(float));
  return layer;
}

}  // namespace

nav_msgs::MapMetaData toMapMetaData(const terrain::GridGeometry& g, const ros::Time& stamp) {
  nav_msgs::MapMetaData info;
  info.map_load_time = stamp;
  info.resolution = static_cast<float>(g.cell_size_m);
  info.width = static_cast<uint32_t>(g.cols);
  info.height = static_cast<uint32_t>(g.rows);
  info.origin.position.x = g.x0_m - 0.5 * g.cell_size_m;
  info.origin.position.y = g.y0_m - 0.5 * g.cell_size_m;
  info.origin.position.z = 0.0;
  info.origin.orientation.w = 1.0;
  return info;
}

terrain::GridGeometry fromMapMetaData(const nav_msgs::MapMetaData& info) {
  const auto& q = info.origin.orientation;
  if (!(std::isfinite(info.resolution) && info.resolution > 0.0f) || info.width == 0 || info.height == 0 ||
      !std::isfinite(info.origin.position.x) || !std::isfinite(info.origin.position.y))
    throw std::invalid_argument("grid geometry rejected: empty grid or non-positive resolution");
  if (std::abs(std::abs(q.w) - 1.0) > 1e-9 || std::abs(q.x) > 1e-9 || std::abs(q.y) > 1e-9 ||
      std::abs(q.z) > 1e-9)
    throw std::invalid_argument("grid geometry rejected: a rotated origin is not supported");
  terrain::GridGeometry g;
  g.cell_size_m = info.resolution;
  g.cols = static_cast<int>(info.width);
  g.rows = static_cast<int>(info.height);
  g.x0_m = info.origin.position.x + 0.5 * g.cell_size_m;
  g.y0_m = info.origin.position.y + 0.5 * g.cell_size_m;
  return g;
}

HazardMap toHazardMapMsg(const terrain::HazardProducts& products, const terrain::HazardMapperConfig& config,
                         const std_msgs::Header& header) {
  const terrain::GridSet& grids = products.terrain.grids;
  HazardMap msg;
  msg.header = header;
  msg.info = toMapMetaData(grids.geometry, header.stamp);
  msg.metric = products.terrain.metric;
  msg.footprint_diameter_m = config.area.footprint_diameter_m;
  msg.support_radius_m = config.map.support_radius_m;
  msg.max_slope_deg = config.thresholds.max_slope_deg;
  msg.max_roughness_m = config.thresholds.max_roughness_m;
  msg.max_shadow_fraction = config.thresholds.max_shadow_fraction;
  msg.max_shading_slope_deg = config.thresholds.max_shading_slope_deg;
  msg.shading_margin_m = config.thresholds.shading_margin_m;
  msg.shading_slope_weight = config.thresholds.shading_slope_weight;
  msg.sun_elevation_deg = config.shading.sun_elevation_deg;
  msg.sun_azimuth_deg = config.shading.sun_azimuth_deg;
  msg.num_points = static_cast<uint32_t>(products.terrain.num_points);
  msg.cells_known = products.terrain.cells_known;
  sensor_msgs::Image* out[kNumRasterLayers] = {
      &msg.elevation_m,     &msg.elevation_sigma_m, &msg.relief_sigma_m,
      &msg.slope_sigma_deg, &msg.residual_rms_m,    &msg.slope_deg,
      &msg.roughness_m,     &msg.shadow_fraction,   &msg.shading_slope_deg};
  for (int i = 0; i < kNumRasterLayers; ++i) {
    auto it = grids.layers.find(kRasterLayers[i]);
    if (it != grids.layers.end()) *out[i] = floatImage(it->second, header);
  }
  return msg;
}

terrain::GridSet fromHazardMapMsg(const HazardMap& msg) {
  terrain::GridSet grids;
  grids.geometry = fromMapMetaData(msg.info);
  const sensor_msgs::Image* in[kNumRasterLayers] = {
      &msg.elevation_m,     &msg.elevation_sigma_m, &msg.relief_sigma_m,
      &msg.slope_sigma_deg, &msg.residual_rms_m,    &msg.slope_deg,
      &msg.roughness_m,     &msg.shadow_fraction,   &msg.shading_slope_deg};
  for (int i = 0; i < kNumRasterLayers; ++i)
    if (!in[i]->data.empty())
      grids.layers[kRasterLayers[i]] = fromFloatImage(*in[i], grids.geometry, kRasterLayers[i]);
  grids.parameters = {{"footprint_diameter_m", msg.footprint_diameter_m},
                      {"support_radius_m", msg.support_radius_m},
                      {"max_slope_deg", msg.max_slope_deg},
                      {"max_roughness_m", msg.max_roughness_m},
                      {"max_shadow_fraction", msg.max_shadow_fraction},
                      {"max_shading_slope_deg", msg.max_shading_slope_deg},
                      {"shading_margin_m", msg.shading_margin_m},
                      {"shading_slope_weight", msg.shading_slope_weight},
                      {"sun_elevation_deg", msg.sun_elevation_deg},
                      {"sun_azimuth_deg", msg.sun_azimuth_deg}};
  grids.description = msg.metric ? "hazard map (metric)" : "hazard map (NOT metric: the map's unit)";
  return grids;
}

nav_msgs::OccupancyGrid toOccupancyGrid(const cv::Mat& hazard, const terrain::GridGeometry& geometry,
                                        const std_msgs::Header& header) {
  if (hazard.type() != CV_8UC1 || hazard.rows != geometry.rows || hazard.cols != geometry.cols)
    throw std::invalid_argument("toOccupancyGrid: the hazard mask is not CV_8UC1 of the grid's size");
  nav_msgs::OccupancyGrid grid;
  grid.header = header;
  grid.info = toMapMetaData(geometry, header.stamp);
  grid.data.resize(static_cast<size_t>(geometry.rows) * geometry.cols);
  for (int r = 0; r < geometry.rows; ++r)
    for (int c = 0; c < geometry.cols; ++c) {
      const uint8_t v = hazard.at<uint8_t>(r, c);
      grid.data[size_t(r) * geometry.cols + c] = v == terrain::kSafe     ? kOccupancySafe
                                                 : v == terrain::kHazard ? kOccupancyHazard
                                                                         : kOccupancyUnknown;
    }
  return grid;
}

LandingSites toLandingSitesMsg(const terrain::LandingSiteResult& result,
                               const terrain::LandingSiteParams& params, bool metric,
                               const std_msgs::Header& header) {
  LandingSites msg;
  msg.header = header;
  msg.target.x = params.target_x_m;
  msg.target.y = params.target_y_m;
  msg.confidence_k = params.confidence_k;
  msg.min_clearance_m = params.min_clearance_m;
  msg.metric = metric;
  msg.reason = result.reason;
  msg.cells_in_reach = result.cells_in_reach;
  msg.cells_known = result.cells_known;
  msg.cells_safe = result.cells_safe;
  for (const terrain::LandingSite& s : result.sites) {
    LandingSite m;
    m.position.x = s.x_m;
    m.position.y = s.y_m;
    m.position.z = s.elevation_m;
    m.slope_deg = s.slope_deg;
    m.roughness_m = s.roughness_m;
    m.slope_sigma_deg = s.slope_sigma_deg;
    m.roughness_sigma_m = s.roughness_sigma_m;
    m.slope_margin_deg = s.slope_margin_deg;
    m.roughness_margin_m = s.roughness_margin_m;
    m.clearance_m = s.clearance_m;
    m.distance_to_target_m = s.distance_to_target_m;
    m.score = s.score;
    msg.sites.push_back(m);
  }
  return msg;
}

terrain::LandingSiteResult fromLandingSitesMsg(const LandingSites& msg, terrain::LandingSiteParams* params) {
  terrain::LandingSiteResult result;
  result.reason = msg.reason;
  result.cells_in_reach = msg.cells_in_reach;
  result.cells_known = msg.cells_known;
  result.cells_safe = msg.cells_safe;
  for (const LandingSite& m : msg.sites) {
    terrain::LandingSite s;
    s.x_m = m.position.x;
    s.y_m = m.position.y;
    s.elevation_m = m.position.z;
    s.slope_deg = m.slope_deg;
    s.roughness_m = m.roughness_m;
    s.slope_sigma_deg = m.slope_sigma_deg;
    s.roughness_sigma_m = m.roughness_sigma_m;
    s.slope_margin_deg = m.slope_margin_deg;
    s.roughness_margin_m = m.roughness_margin_m;
    s.clearance_m = m.clearance_m;
    s.distance_to_target_m = m.distance_to_target_m;
    s.score = m.score;
    result.sites.push_back(s);
  }
  result.cells_qualifying = static_cast<int>(result.sites.size());
  if (params != nullptr) {
    params->target_x_m = msg.target.x;
    params->target_y_m = msg.target.y;
    params->confidence_k = msg.confidence_k;
    params->min_clearance_m = msg.min_clearance_m;
  }
  return result;
}

geometry_msgs::PoseArray toPoseArray(const LandingSites& sites) {
  geometry_msgs::PoseArray poses;
  poses.header = sites.header;
  for (const LandingSite& s : sites.sites) {
    geometry_msgs::Pose p;
    p.position = s.position;
    if (!std::isfinite(p.position.z)) p.position.z = 0.0;
    p.orientation.w = 1.0;
    poses.poses.push_back(p);
  }
  return poses;
}

visualization_msgs::MarkerArray toMarkers(const LandingSites& sites) {
  visualization_msgs::MarkerArray markers;
  visualization_msgs::Marker clear;
  clear.header = sites.header;
  clear.action = visualization_msgs::Marker::DELETEALL;
  markers.markers.push_back(clear);
  auto base = [&](const std::string& ns, int id, int type) {
    visualization_msgs::Marker m;
    m.header = sites.header;
    m.ns = ns;
    m.id = id;
    m.type = type;
    m.action = visualization_msgs::Marker::ADD;
    m.pose.orientation.w = 1.0;
    m.color.a = 0.8f;
    return m;
  };
  double z_ref = 0.0;
  for (const LandingSite& s : sites.sites)
    if (std::isfinite(s.position.z)) {
      z_ref = s.position.z;
      break;
    }
  visualization_msgs::Marker target = base("target", 0, visualization_msgs::Marker::CYLINDER);
  target.pose.position = sites.target;
  target.pose.position.z = z_ref;
  target.scale.x = target.scale.y = 2.0;
  target.scale.z = 0.2;
  target.color.r = 1.0f;
  markers.markers.push_back(target);
  for (size_t i = 0; i < sites.sites.size(); ++i) {
    const LandingSite& s = sites.sites[i];
    const double z = std::isfinite(s.position.z) ? s.position.z : z_ref;
    visualization_msgs::Marker disc = base("sites", int(i), visualization_msgs::Marker::CYLINDER);
    disc.pose.position = s.position;
    disc.pose.position.z = z;
    disc.scale.x = disc.scale.y = 2.0 * sites.min_clearance_m;
    disc.scale.z = 1.0;  // a flat disc would hide in the terrain's points
    disc.pose.position.z = z + 0.5;
    disc.color.g = 1.0f;
    disc.color.r = i == 0 ? 0.0f : 1.0f;
    markers.markers.push_back(disc);
    visualization_msgs::Marker text =
        base("site_labels", int(i), visualization_msgs::Marker::TEXT_VIEW_FACING);
    text.pose.position = disc.pose.position;
    text.pose.position.z = z + 6.0;
    text.scale.z = 4.0;
    text.color.r = text.color.g = text.color.b = 1.0f;
    text.color.a = 1.0f;
    std::ostringstream label;
    label << std::fixed << std::setprecision(1) << "#" << i + 1 << " slope " << s.slope_deg << " deg, rough "
          << std::setprecision(2) << s.roughness_m << " m";
    text.text = label.str();
    markers.markers.push_back(text);
  }
  return markers;
}

sensor_msgs::PointCloud2 toElevationCloud(const terrain::GridSet& grids, int stride,
                                          const std_msgs::Header& header) {
  if (stride < 1) throw std::invalid_argument("toElevationCloud: stride must be >= 1");
  const terrain::GridGeometry& g = grids.geometry;
  const cv::Mat& elevation = grids.layers.at("elevation_m");
  auto slope_it = grids.layers.find("slope_deg");
  std::vector<std::array<float, 4>> points;
  for (int r = 0; r < g.rows; r += stride)
    for (int c = 0; c < g.cols; c += stride) {
      const float z = elevation.at<float>(r, c);
      if (!std::isfinite(z)) continue;
      float slope = slope_it != grids.layers.end() ? slope_it->second.at<float>(r, c) : 0.0f;
      if (!std::isfinite(slope)) slope = 0.0f;
      points.push_back({float(g.x_m(c)), float(g.y_m(r)), z, slope});
    }
  sensor_msgs::PointCloud2 cloud;
  cloud.header = header;
  sensor_msgs::PointCloud2Modifier modifier(cloud);
  modifier.setPointCloud2Fields(4, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1,
                                sensor_msgs::PointField::FLOAT32, "z", 1, sensor_msgs::PointField::FLOAT32,
                                "intensity", 1, sensor_msgs::PointField::FLOAT32);
  modifier.resize(points.size());
  cloud.height = 1;
  cloud.width = static_cast<uint32_t>(points.size());
  cloud.is_dense = true;
  if (points.empty())
    return cloud;  // no iterator over empty data: it takes data.front() (UB; see toPointCloud)
  sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z"), i(cloud, "intensity");
  for (const auto& p : points) {
    *x = p[0], *y = p[1], *z = p[2], *i = p[3];
    ++x, ++y, ++z, ++i;
  }
  return cloud;
}

}  // namespace planetary_vo::ros_io

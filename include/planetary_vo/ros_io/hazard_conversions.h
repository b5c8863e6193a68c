#pragma once
/// @file hazard_conversions.h
/// The hazard mapper's products (terrain/hazard_mapper.h) <-> the messages of the hazard nodelet:
/// planetary_vo/HazardMap (the rasters), nav_msgs/OccupancyGrid (the hazard mask), planetary_vo/LandingSites,
/// geometry_msgs/PoseArray and PoseStamped (the sites), visualization_msgs/MarkerArray (sites, target, for
/// rviz) and sensor_msgs/PointCloud2 (the elevation with its slope, for rviz). No node handle: unit-tested in
/// test/ros/test_hazard_conversions.cpp without a master.
///
/// Grid layout in every message: nav_msgs/OccupancyGrid's (row-major from cell (0, 0) at the smallest x and
/// y; origin = the outer corner of cell (0, 0)); the same as terrain::GridGeometry's cells, so a layer's
/// image row r is grid row r.

#include <stdexcept>

#include <geometry_msgs/PoseArray.h>
#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/OccupancyGrid.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/Header.h>
#include <visualization_msgs/MarkerArray.h>

#include "planetary_vo/HazardMap.h"
#include "planetary_vo/LandingSites.h"
#include "planetary_vo/terrain/hazard_mapper.h"

namespace planetary_vo::ros_io {

/// Occupancy values of the hazard grid: safe, hazard, unknown (OccupancyGrid's -1).
constexpr int8_t kOccupancySafe = 0, kOccupancyHazard = 100, kOccupancyUnknown = -1;

/// Geometry -> MapMetaData (map_load_time = header stamp; origin at the outer corner of cell (0, 0)).
nav_msgs::MapMetaData toMapMetaData(const terrain::GridGeometry& geometry, const ros::Time& stamp);
/// MapMetaData -> geometry. Throws std::invalid_argument on a non-positive or non-finite resolution, an empty
/// grid or a rotated origin.
terrain::GridGeometry fromMapMetaData(const nav_msgs::MapMetaData& info);

/// The rasters (layers elevation_m, elevation_sigma_m, relief_sigma_m, slope_sigma_deg, residual_rms_m,
/// slope_deg, roughness_m as 32FC1 images, empty when the products lack one; the header goes to each) with
/// the thresholds and map settings of `config`.
HazardMap toHazardMapMsg(const terrain::HazardProducts& products, const terrain::HazardMapperConfig& config,
                         const std_msgs::Header& header);
/// The layers of a HazardMap as a grid set (parameters footprint_diameter_m, support_radius_m,
/// max_slope_deg, max_roughness_m). Throws std::invalid_argument when a layer is not 32FC1 of the grid's
/// size (an empty layer is left out).
terrain::GridSet fromHazardMapMsg(const HazardMap& msg);

/// hazardMask() (kSafe / kHazard / kUnknown) -> OccupancyGrid (0 / 100 / -1).
nav_msgs::OccupancyGrid toOccupancyGrid(const cv::Mat& hazard, const terrain::GridGeometry& geometry,
                                        const std_msgs::Header& header);

LandingSites toLandingSitesMsg(const terrain::LandingSiteResult& result,
                               const terrain::LandingSiteParams& params, bool metric,
                               const std_msgs::Header& header);
/// The message back to the core result (sites, reason, cell counts; cells_qualifying = the sites listed) and,
/// when params is not null, the parameters it carries (target, k, clearance; the others keep their defaults).
terrain::LandingSiteResult fromLandingSitesMsg(const LandingSites& msg, terrain::LandingSiteParams* params);
/// The sites as poses (best first; orientation: the map frame's, z up); a site's z is its elevation or 0.
geometry_msgs::PoseArray toPoseArray(const LandingSites& sites);
/// A cylinder of the clearance radius per site (the best green, the others yellow) with its rank and
/// margins as text, and the target as a red disc; markers of an earlier call that are gone are deleted
/// (DELETEALL first).
visualization_msgs::MarkerArray toMarkers(const LandingSites& sites);

/// Cells with an elevation as points (x, y, z = elevation; intensity = slope in deg, NaN-free), every
/// `stride`-th cell along rows and columns (stride >= 1).
sensor_msgs::PointCloud2 toElevationCloud(const terrain::GridSet& grids, int stride,
                                          const std_msgs::Header& header);

}  // namespace planetary_vo::ros_io

// HazardMapper: config/hazard.yaml is the default and bad keys are named; the map events of a known terrain
// (a flat plain next to a 20 deg bank) give the hazard mask and a landing site on the plain, clear of the
// bank; no site on a map without metres; densification only once metric.
#include <cmath>
#include <cstdint>
#include <random>

#include <gtest/gtest.h>

#include "level_ground_views.h"
#include "planetary_vo/terrain/hazard_mapper.h"
#include "test_support.h"

using namespace planetary_vo;
using namespace planetary_vo::terrain;

namespace {

const double kBankGradient = std::tan(20.0 * M_PI / 180.0);

/// Flat (z = 0) for x < 5 m, a 20 deg bank rising along +x beyond.
double surface(double x, double /*y*/) { return x < 5.0 ? 0.0 : kBankGradient * (x - 5.0); }

HazardMapperConfig smallArea() {
  HazardMapperConfig config;
  config.area.half_extent_m = 30.0;
  config.area.cell_size_m = 0.5;
  config.area.footprint_diameter_m = 4.0;
  config.map.support_radius_m = 2.0;
  config.sites.target_x_m = 10.0;  // on the bank: the site must move onto the plain
  config.sites.target_y_m = 0.0;
  config.sites.max_distance_from_target_m = 25.0;
  return config;
}

/// Points every 0.5 m (jittered) on the surface, 2 cm vertical noise, a matching covariance.
MapEvents pointsOnSurface() {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> jitter(-0.2, 0.2);
  std::normal_distribution<double> noise(0.0, 0.02);
  MapEvents events;
  uint64_t id = 1;
  for (double x = -34.0; x <= 34.0; x += 0.5)
    for (double y = -34.0; y <= 34.0; y += 0.5) {
      MapPointState p;
      p.id = id++;
      const double px = x + jitter(rng), py = y + jitter(rng);
      p.p_world = Eigen::Vector3d(px, py, surface(px, py) + noise(rng));
      p.covariance_world = Eigen::Matrix3d::Identity() * 0.02 * 0.02;
      p.num_observations = 2;
      events.points_added.push_back(p);
    }
  return events;
}

}  // namespace

TEST(HazardMapperConfig, TheFileIsTheDefault) {
  const HazardMapperConfig from_file = loadHazardMapperConfig(test::sourceRoot() + "config/hazard.yaml");
  EXPECT_EQ(dumpHazardMapperConfig(from_file), dumpHazardMapperConfig(HazardMapperConfig()))
      << "config/hazard.yaml and the stages' member initialisers disagree";
  // dump -> parse is the identity on a changed config too.
  HazardMapperConfig changed;
  changed.area.cell_size_m = 0.25;
  changed.densify = false;
  changed.sites.max_sites = 3;
  EXPECT_EQ(dumpHazardMapperConfig(parseHazardMapperConfig(dumpHazardMapperConfig(changed))),
            dumpHazardMapperConfig(changed));
  // The area is given once and reaches both stages.
  const HazardMapperConfig parsed = parseHazardMapperConfig("area: {cell_size_m: 0.25}\n");
  EXPECT_EQ(parsed.map.area.cell_size_m, 0.25);
  EXPECT_EQ(parsed.densifier.area.cell_size_m, 0.25);
}

TEST(HazardMapperConfig, EveryBadKeyIsNamed) {
  try {
    parseHazardMapperConfig(
        "area: {cell_size_m: fine}\nthresholds: {max_slope_dg: 8}\nhazards: {}\nsites: {max_sites: 2.5}\n");
    FAIL() << "accepted";
  } catch (const HazardConfigError& e) {
    const std::string all = e.what();
    EXPECT_EQ(e.problems().size(), 4u) << all;
    EXPECT_NE(all.find("area.cell_size_m: expected a number"), std::string::npos) << all;
    EXPECT_NE(all.find("thresholds.max_slope_dg: unknown key"), std::string::npos) << all;
    EXPECT_NE(all.find("hazards: unknown section"), std::string::npos) << all;
    EXPECT_NE(all.find("sites.max_sites: expected an integer"), std::string::npos) << all;
  }
  // Repeated keys and sections (rosparam would keep the last, yaml-cpp the first) and folders are errors.
  EXPECT_THROW(parseHazardMapperConfig("area: {cell_size_m: 0.5, cell_size_m: 1.0}\n"), HazardConfigError);
  EXPECT_THROW(parseHazardMapperConfig("sites: {}\nsites: {}\n"), HazardConfigError);
  EXPECT_THROW(loadHazardMapperConfig(test::sourceRoot() + "config"), HazardConfigError);
  // Ranges are the stages' own checks.
  EXPECT_THROW(parseHazardMapperConfig("area: {cell_size_m: -1}\n"), HazardConfigError);
  EXPECT_THROW(parseHazardMapperConfig("thresholds: {max_slope_deg: 0}\n"), HazardConfigError);
  EXPECT_THROW(parseHazardMapperConfig("thresholds: {shading_margin_m: -0.5}\n"), HazardConfigError);
  EXPECT_NO_THROW(parseHazardMapperConfig("thresholds: {shading_margin_m: 0}\n"));
  EXPECT_THROW(parseHazardMapperConfig("shading: {sun_azimuth_deg: 400}\n"), HazardConfigError);
  EXPECT_EQ(parseHazardMapperConfig("shading: {sun_azimuth_deg: 250}\n").shading.sun_azimuth_deg, 250.0);
  EXPECT_FALSE(
      parseHazardMapperConfig("shading: {normalise_turned_away: false}\n").shading.normalise_turned_away);
  EXPECT_THROW(parseHazardMapperConfig("shading: {normalise_turned_away: 2.5}\n"), HazardConfigError);
  EXPECT_DOUBLE_EQ(parseHazardMapperConfig("shading_tilt: {weight: 0.5}\n").shading_tilt.weight, 0.5);
  EXPECT_THROW(parseHazardMapperConfig("shading_tilt: {weight: 1.5}\n"), HazardConfigError);
  EXPECT_THROW(parseHazardMapperConfig("shading_tilt: {surround_sigma_m: 0.5}\n"), HazardConfigError);
  EXPECT_THROW(parseHazardMapperConfig("densifier: {grid_step_px: 0}\n"), HazardConfigError);
  EXPECT_THROW(parseHazardMapperConfig("sites: {max_sites: 0}\n"), HazardConfigError);
  EXPECT_THROW(parseHazardMapperConfig("map: {support_radius_m: .nan}\n"), HazardConfigError);
  EXPECT_THROW(parseHazardMapperConfig("[1, 2]"), HazardConfigError);
  EXPECT_THROW(parseHazardMapperConfig("area: {cell_size_m: [0.5]}\n"), HazardConfigError);
}

TEST(HazardMapper, TheBankIsAHazardAndTheSiteIsOnThePlain) {
  HazardMapper mapper(smallArea());
  mapper.apply(pointsOnSurface(), /*metric_scale=*/true);
  const HazardProducts products = mapper.products();
  ASSERT_TRUE(products.terrain.metric);
  const GridGeometry& g = products.terrain.grids.geometry;
  const cv::Mat& slope = products.terrain.grids.layers.at("slope_deg");
  int plain_safe = 0, plain = 0, bank_hazard = 0, bank = 0;
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      if (products.hazard.at<uint8_t>(r, c) == kUnknown) continue;
      const double x = g.x_m(c);
      if (x < 0.0) {
        ++plain;
        plain_safe += products.hazard.at<uint8_t>(r, c) == kSafe;
        EXPECT_LT(slope.at<float>(r, c), 2.0f) << "x " << x;
      } else if (x > 10.0) {
        ++bank;
        bank_hazard += products.hazard.at<uint8_t>(r, c) == kHazard;
        EXPECT_NEAR(slope.at<float>(r, c), 20.0f, 2.0f) << "x " << x;
      }
    }
  ASSERT_GT(plain, 1000);
  ASSERT_GT(bank, 1000);
  EXPECT_EQ(plain_safe, plain);
  EXPECT_EQ(bank_hazard, bank);
  // The hazard layer is the mask as float (NaN unknown), written with the rest.
  const cv::Mat& hazard_f = products.terrain.grids.layers.at("hazard");
  EXPECT_EQ(cv::countNonZero(hazard_f == 1.0f), cv::countNonZero(products.hazard == kHazard));
  // The best site: on the plain (the target, on the bank, is not safe), clear of the bank's foot by the
  // dispersion, within reach of the target.
  ASSERT_FALSE(products.sites.sites.empty()) << products.sites.reason;
  const LandingSite& best = products.sites.sites.front();
  EXPECT_LE(best.x_m, 5.0 - 2.0 - smallArea().sites.min_clearance_m + 0.5);
  EXPECT_LE(best.distance_to_target_m, smallArea().sites.max_distance_from_target_m);
  EXPECT_LT(best.slope_deg, 2.0);

  // The sites' file gives back the sites and the parameters they were chosen with.
  const std::string file = test::outputDir("hazard_mapper") + "/landing_sites.yaml";
  writeLandingSites(file, products.sites, mapper.config().sites);
  LandingSiteParams params;
  const LandingSiteResult read = readLandingSites(file, &params);
  ASSERT_EQ(read.sites.size(), products.sites.sites.size());
  for (size_t i = 0; i < read.sites.size(); ++i) {
    EXPECT_EQ(read.sites[i].col, products.sites.sites[i].col);
    EXPECT_EQ(read.sites[i].row, products.sites.sites[i].row);
    EXPECT_EQ(read.sites[i].x_m, products.sites.sites[i].x_m);
    EXPECT_EQ(read.sites[i].slope_margin_deg, products.sites.sites[i].slope_margin_deg);
    EXPECT_EQ(read.sites[i].score, products.sites.sites[i].score);
  }
  EXPECT_EQ(read.cells_safe, products.sites.cells_safe);
  EXPECT_EQ(params.target_x_m, 10.0);
  EXPECT_EQ(params.min_clearance_m, mapper.config().sites.min_clearance_m);
  EXPECT_THROW(readLandingSites(file + ".missing", &params), std::runtime_error);
}

// A boulder field west of x = -5 m: blocks 0.8 m high and 1.2 m wide every 2 m (a third of the ground). The
// 2 m plane-fit support averages them into a raised, smooth surface (estimated roughness under 0.3 m), but
// the points' RMS distance from the fitted planes (~0.38 m) exceeds the roughness limit, so no site is
// certified there; without the residual layer the smooth-looking field would be chosen.
TEST(HazardMapper, NoSiteWhereThePointsShowReliefTheMapDoesNotResolve) {
  HazardMapperConfig config = smallArea();
  config.sites.target_x_m = -20.0;  // in the boulder field
  config.sites.max_distance_from_target_m = 12.0;
  config.sites.min_clearance_m = 1.0;  // the smoothed field still has rough spots 2 m apart
  config.sites.confidence_k = 2.0;     // the smoothed field's slope + 2.5 sigma is just over the limit
  HazardMapper mapper(config);
  MapEvents events = pointsOnSurface();
  for (MapPointState& p : events.points_added) {
    const double x = p.p_world.x(), y = p.p_world.y();
    const double dx = std::remainder(x, 2.0), dy = std::remainder(y, 2.0);
    if (x < -5.0 && std::abs(dx) < 0.6 && std::abs(dy) < 0.6) p.p_world.z() += 0.8;
  }
  mapper.apply(events, true);
  HazardProducts products = mapper.products();
  ASSERT_TRUE(products.terrain.grids.layers.count("residual_rms_m"));
  EXPECT_TRUE(products.sites.sites.empty())
      << "a site in the boulder field at (" << products.sites.sites[0].x_m << ", "
      << products.sites.sites[0].y_m << ")";
  // The same map without the residuals: the boulders are smoothed away and the field looks safe.
  products.terrain.grids.layers.erase("residual_rms_m");
  const LandingSiteResult blind = findLandingSites(products.terrain.grids, config.thresholds, config.sites);
  ASSERT_FALSE(blind.sites.empty()) << blind.reason << " (safe " << blind.cells_safe << " of "
                                    << blind.cells_known << ")";
  EXPECT_LT(blind.sites.front().roughness_m, 0.3);
}

TEST(HazardMapper, NoSiteOnAMapWithoutMetres) {
  HazardMapper mapper(smallArea());
  mapper.apply(pointsOnSurface(), /*metric_scale=*/false);
  const HazardProducts products = mapper.products();
  EXPECT_FALSE(products.terrain.metric);
  EXPECT_TRUE(products.sites.sites.empty());
  EXPECT_NE(products.sites.reason.find("not metric"), std::string::npos) << products.sites.reason;
  // Slopes are still mapped (the map's scale is isotropic).
  EXPECT_GT(cv::countNonZero(products.hazard == kHazard), 1000);
}

TEST(HazardMapper, NoSiteNextToAShadowTheKeyframesSaw) {
  // The plain of the test above, flat where the target is now (-15, 0); a nadir keyframe from 40 m sees a
  // black square 2 m across at the target (the shadow of a rock the 2 m plane fit does not resolve). Its
  // cells become unknown and the best site keeps the dispersion clear of them; with the shadows off, the
  // site is the target itself.
  HazardMapperConfig config = smallArea();
  config.sites.target_x_m = -15.0;
  config.densify = false;
  const PinholeCamera camera = PinholeCamera::fromFieldOfView(320, 320, 60.0);
  const Pose T_world_cam = test::nadirAt(-15.0, 0.0, 40.0);
  const cv::Mat gray = test::renderLevelGround(camera, T_world_cam, 0.0, [](const Eigen::Vector3d& p) {
    const bool shadow = std::abs(p.x() + 15.0) <= 1.0 && std::abs(p.y()) <= 1.0;
    const bool odd = (int(std::floor(p.x())) + int(std::floor(p.y()))) % 2 != 0;
    return uint8_t(shadow ? 3 : (odd ? 150 : 90));
  });
  MapEvents events = pointsOnSurface();
  MapKeyframeState kf;
  kf.id = 1;
  kf.T_world_cam = T_world_cam;
  events.keyframes_added.push_back(kf);

  for (const bool enabled : {true, false}) {
    config.shadows.enabled = enabled;
    HazardMapper mapper(config);
    mapper.setCamera(camera);
    EXPECT_EQ(mapper.apply(events, true, gray).shadow_view_added, enabled);
    const HazardProducts products = mapper.products();
    ASSERT_FALSE(products.sites.sites.empty()) << products.sites.reason;
    const LandingSite& best = products.sites.sites.front();
    const GridGeometry& g = products.terrain.grids.geometry;
    int col = 0, row = 0;
    ASSERT_TRUE(g.cellAt(-15.0, 0.0, &col, &row));
    if (enabled) {
      ASSERT_TRUE(products.terrain.grids.layers.count("shadow_fraction"));
      EXPECT_EQ(products.terrain.grids.layers.at("shadow_fraction").at<float>(row, col), 1.0f);
      EXPECT_EQ(products.hazard.at<uint8_t>(row, col), kUnknown);   // relief unseen
      EXPECT_NEAR(products.shadows.cells_shadowed, 16 + 4 * 4, 8);  // ~ (2 m / 0.5 m + 1)^2 cells
      // Clear of the square by the dispersion: Chebyshev distance from its centre >= 1 m + 3 m.
      EXPECT_GE(std::max(std::abs(best.x_m + 15.0), std::abs(best.y_m)),
                1.0 + config.sites.min_clearance_m - 0.5);
    } else {
      EXPECT_FALSE(products.terrain.grids.layers.count("shadow_fraction"));
      EXPECT_EQ(products.hazard.at<uint8_t>(row, col), kSafe);
      EXPECT_DOUBLE_EQ(best.x_m, -15.0);
      EXPECT_DOUBLE_EQ(best.y_m, 0.0);
    }
  }
}

TEST(HazardMapper, NoSiteOnReliefTheShadingShowsUnderAHighSun) {
  // The plain again, target (-15, 0); a nadir keyframe from 40 m under a Sun 30 deg high sees, on a 6 m
  // square at the target, a washboard (4 m wavelength, slopes up to 8.5 deg, 9 cm high: no shadow, and
  // under the 2 m plane fit) shaded by the Lambert law. With the Sun's elevation given its cells are
  // hazards (shading relief about 4.4 deg RMS against 2.7) and the site keeps clear; without it (0: not
  // given) the site is the target itself.
  HazardMapperConfig config = smallArea();
  config.sites.target_x_m = -15.0;
  config.densify = false;
  const PinholeCamera camera = PinholeCamera::fromFieldOfView(320, 320, 60.0);
  const Pose T_world_cam = test::nadirAt(-15.0, 0.0, 40.0);
  const double e = 30.0 * M_PI / 180.0, amplitude = std::tan(8.5 * M_PI / 180.0);
  const Eigen::Vector3d sun(std::cos(e), 0.0, std::sin(e));
  const cv::Mat gray = test::renderLevelGround(camera, T_world_cam, 0.0, [&](const Eigen::Vector3d& p) {
    const bool washboard = std::abs(p.x() + 15.0) <= 3.0 && std::abs(p.y()) <= 3.0;
    const double gradient = washboard ? amplitude * std::cos(2.0 * M_PI * p.x() / 4.0) : 0.0;
    const double lit = Eigen::Vector3d(-gradient, 0.0, 1.0).normalized().dot(sun) / std::sin(e);
    return static_cast<uint8_t>(std::lround(120.0 * lit));
  });
  MapEvents events = pointsOnSurface();
  MapKeyframeState kf;
  kf.id = 1;
  kf.T_world_cam = T_world_cam;
  events.keyframes_added.push_back(kf);

  for (const double sun_elevation_deg : {30.0, 0.0}) {
    config.shading.sun_elevation_deg = sun_elevation_deg;
    HazardMapper mapper(config);
    mapper.setCamera(camera);
    const bool given = sun_elevation_deg > 0.0;
    EXPECT_EQ(mapper.apply(events, true, gray).shading_view_added, given);
    const HazardProducts products = mapper.products();
    ASSERT_FALSE(products.sites.sites.empty()) << products.sites.reason;
    const LandingSite& best = products.sites.sites.front();
    int col = 0, row = 0;
    ASSERT_TRUE(products.terrain.grids.geometry.cellAt(-15.0, 0.0, &col, &row));
    EXPECT_EQ(products.shadows.cells_shadowed, 0);  // no shadow: only the shading shows the relief
    if (given) {
      ASSERT_TRUE(products.terrain.grids.layers.count("shading_slope_deg"));
      EXPECT_NEAR(products.terrain.grids.layers.at("shading_slope_deg").at<float>(row, col), 4.4, 0.9);
      EXPECT_EQ(products.hazard.at<uint8_t>(row, col), kHazard);
      // The cells within shading_margin_m (2 m) of those above the limit are hazards in the published map
      // too, and the site keeps the dispersion clear of them.
      const GridSet& grids = products.terrain.grids;
      EXPECT_DOUBLE_EQ(grids.parameters.at("shading_margin_m"), 2.0);
      const cv::Mat own = hazardMask(grids.layers.at("slope_deg"), grids.layers.at("roughness_m"), cv::Mat(),
                                     grids.layers.at("shading_slope_deg"), config.thresholds);
      const int own_hazards = cv::countNonZero(own == kHazard);
      EXPECT_GT(own_hazards, 0);
      EXPECT_GT(cv::countNonZero(products.hazard == kHazard), own_hazards);
      EXPECT_GE(std::max(std::abs(best.x_m + 15.0), std::abs(best.y_m)), 3.0 + 2.0);
    } else {
      EXPECT_FALSE(products.terrain.grids.layers.count("shading_slope_deg"));
      EXPECT_EQ(products.hazard.at<uint8_t>(row, col), kSafe);
      EXPECT_DOUBLE_EQ(best.x_m, -15.0);
      EXPECT_DOUBLE_EQ(best.y_m, 0.0);
    }
  }
}

TEST(HazardMapper, DensifiesKeyframesOnlyOnceMetric) {
  HazardMapper mapper(smallArea());
  MapEvents events;
  MapKeyframeState kf;
  kf.id = 1;
  kf.timestamp_s = 1.0;
  kf.T_world_cam = Pose::Identity();
  events.keyframes_added.push_back(kf);
  cv::Mat gray(48, 64, CV_8UC1, cv::Scalar(100));
  // Without a camera nothing can be densified.
  EXPECT_FALSE(mapper.apply(events, true, gray).densified);
  mapper.setCamera(PinholeCamera(64, 48, 60.0, 60.0, 32.0, 24.0));
  EXPECT_FALSE(mapper.apply(events, /*metric_scale=*/false, gray).densified);
  const HazardMapperUpdate update = mapper.apply(events, /*metric_scale=*/true, gray);
  EXPECT_TRUE(update.keyframe);
  EXPECT_TRUE(update.densified);
  // A keyframe image of another size is refused, not tracked.
  EXPECT_THROW(mapper.apply(events, true, cv::Mat(10, 10, CV_8UC1)), std::invalid_argument);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}

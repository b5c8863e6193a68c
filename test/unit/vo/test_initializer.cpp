/// Tests of the Initializer on the synthetic two-view scenes of geometry/synthetic_scene.h (known motion and
/// points): each motion model recovers the motion, `auto` picks H on a plane and E on relief, the
/// homography's two-fold ambiguity is settled by the nadir prior or, on obliquely seen ground, by
/// triangulation (and rejected when neither can settle it), a twin that triangulates as many points is
/// settled by its reprojection cost over relief, the map is the true scene up to the unit
/// baseline, and a motion without parallax is rejected rather than invented.

#include <cmath>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "planetary_vo/geometry/synthetic_scene.h"
#include "planetary_vo/vo/initializer.h"

namespace planetary_vo {
namespace {

SyntheticTwoViewScene scene(double depth_spread, double baseline, double noise_px = 0.5,
                            Eigen::Vector3d direction = Eigen::Vector3d(1.0, 0.3, 0.2)) {
  SyntheticSceneConfig cfg;
  cfg.num_points = 400;
  cfg.depth_spread = depth_spread;
  cfg.baseline = baseline;
  cfg.centre_direction_c1 = direction;
  cfg.rotation_deg = 2.0;
  cfg.noise_px = noise_px;
  cfg.seed = 7;
  return makeSyntheticScene(cfg);
}

std::vector<uint64_t> ids(size_t n) {
  std::vector<uint64_t> out(n);
  for (size_t i = 0; i < n; ++i) out[i] = 1000 + i;
  return out;
}

MotionConfig motionConfig(MotionModel model) {
  MotionConfig m;
  m.model = model;
  return m;
}

/// Angle between the estimated and the true translation direction, and the rotation error, in degrees.
void expectMotionClose(const RelativeMotion& motion, const Pose& T_c2_c1_true, double max_dir_deg,
                       double max_rot_deg) {
  ASSERT_TRUE(motion.valid) << motion.reason;
  EXPECT_NEAR(motion.T_c2_c1_unit.translation().norm(), 1.0, 1e-9);
  EXPECT_LT(angleBetweenDeg(motion.T_c2_c1_unit.translation(), T_c2_c1_true.translation()), max_dir_deg);
  EXPECT_LT(rotationAngleDeg(motion.T_c2_c1_unit.linear().transpose() * T_c2_c1_true.linear()), max_rot_deg);
}

TEST(Initializer, EachModelRecoversTheMotionOfAScene) {
  const SyntheticTwoViewScene relief = scene(800.0, 150.0);
  const SyntheticTwoViewScene plane = scene(0.0, 150.0);
  const MapConfig map;
  expectMotionClose(Initializer(motionConfig(MotionModel::kEssential), map)
                        .estimateMotion(relief.px1, relief.px2, relief.camera.K()),
                    relief.T_c2_c1, 3.0, 0.2);
  expectMotionClose(Initializer(motionConfig(MotionModel::kFundamental), map)
                        .estimateMotion(relief.px1, relief.px2, relief.camera.K()),
                    relief.T_c2_c1, 5.0, 0.3);
  const RelativeMotion h = Initializer(motionConfig(MotionModel::kHomography), map)
                               .estimateMotion(plane.px1, plane.px2, plane.camera.K());
  expectMotionClose(h, plane.T_c2_c1, 3.0, 0.2);
  EXPECT_EQ(h.model, MotionEstimate::kHomography);
}

TEST(Initializer, FundamentalIsRejectedOnAPlane) {
  // The 8-point system is degenerate on coplanar points (peer-results: ORB-SLAM3 initialised from F on a
  // plane and turned forward motion into pitch). It must be refused, not concatenated.
  const SyntheticTwoViewScene plane = scene(0.0, 150.0);
  const RelativeMotion f = Initializer(motionConfig(MotionModel::kFundamental), MapConfig())
                               .estimateMotion(plane.px1, plane.px2, plane.camera.K());
  EXPECT_FALSE(f.valid);
  EXPECT_FALSE(f.reason.empty());
}

TEST(Initializer, AutoChoosesHomographyOnAPlaneAndEssentialOnRelief) {
  const Initializer init(motionConfig(MotionModel::kAuto), MapConfig());
  const SyntheticTwoViewScene plane = scene(0.0, 150.0);
  const RelativeMotion on_plane = init.estimateMotion(plane.px1, plane.px2, plane.camera.K());
  expectMotionClose(on_plane, plane.T_c2_c1, 3.0, 0.2);
  EXPECT_EQ(on_plane.model, MotionEstimate::kHomography);

  const SyntheticTwoViewScene relief = scene(1500.0, 150.0);
  const RelativeMotion on_relief = init.estimateMotion(relief.px1, relief.px2, relief.camera.K());
  expectMotionClose(on_relief, relief.T_c2_c1, 3.0, 0.2);
  EXPECT_EQ(on_relief.model, MotionEstimate::kEssential);
}

TEST(Initializer, NadirPriorSettlesTheHomographyAmbiguityOfADescent) {
  // Straight down towards a fronto-parallel plane: the two homography decompositions explain the points
  // equally well (the case ORB-SLAM2 never got past). The +z prior picks the ground's normal.
  const SyntheticTwoViewScene descent = scene(0.0, 100.0, 0.5, Eigen::Vector3d(0.2, 0.1, 1.0));
  const RelativeMotion with_prior = Initializer(motionConfig(MotionModel::kHomography), MapConfig())
                                        .estimateMotion(descent.px1, descent.px2, descent.camera.K());
  expectMotionClose(with_prior, descent.T_c2_c1, 5.0, 0.3);

  const RelativeMotion without =
      Initializer(motionConfig(MotionModel::kHomography), MapConfig(), Eigen::Vector3d::Zero())
          .estimateMotion(descent.px1, descent.px2, descent.camera.K());
  // Without the prior the result is either rejected as ambiguous or (if the counts happened to separate)
  // right; it must never be the wrong decomposition presented as valid.
  if (without.valid) {
    EXPECT_LT(angleBetweenDeg(without.T_c2_c1_unit.translation(), descent.T_c2_c1.translation()), 5.0);
  }
}

/// Ground seen obliquely: camera 1 at the origin looking along +z, the ground's normal (towards it) tilted
/// `tilt_deg` from the optical axis about x, `distance` away along the normal, with relief uniform in
/// +-relief/2 along it; camera 2 moved `baseline` along `direction_c1` (normalised) and pitched `pitch_deg`.
/// `num_points` points where random pixels of image 1 meet the ground (and stay in image 2), with `noise_px`.
struct GroundSpec {
  double tilt_deg = 30.0;
  double distance = 1500.0;
  double relief = 0.0;
  double baseline = 150.0;
  Eigen::Vector3d direction_c1 = Eigen::Vector3d::UnitY();
  double pitch_deg = 0.5;
  size_t num_points = 400;
  double noise_px = 0.3;
  uint32_t seed = 5;
};

SyntheticTwoViewScene groundScene(const GroundSpec& g) {
  SyntheticTwoViewScene s;
  s.camera = thesisCamera();
  const double tilt = g.tilt_deg * M_PI / 180.0;
  const Eigen::Vector3d normal(0.0, std::sin(tilt), std::cos(tilt));
  const Eigen::Vector3d c2_in_c1 = g.baseline * g.direction_c1.normalized();
  const Eigen::Matrix3d R_c2_c1 =
      Eigen::AngleAxisd(g.pitch_deg * M_PI / 180.0, Eigen::Vector3d::UnitX()).toRotationMatrix();
  s.T_c2_c1 = Pose::Identity();
  s.T_c2_c1.linear() = R_c2_c1;
  s.T_c2_c1.translation() = -R_c2_c1 * c2_in_c1;
  cv::RNG rng(g.seed);
  const Eigen::Matrix3d K = s.camera.K();
  while (s.points_c1.size() < g.num_points) {
    const Eigen::Vector3d ray =
        K.inverse() * Eigen::Vector3d(rng.uniform(0.0, 1024.0), rng.uniform(0.0, 1024.0), 1.0);
    const double d = g.relief > 0.0 ? g.distance + rng.uniform(-0.5, 0.5) * g.relief : g.distance;
    const Eigen::Vector3d p = ray * (d / normal.dot(ray));
    const Eigen::Vector3d p2 = s.T_c2_c1 * p;
    const Eigen::Vector3d q1 = K * p, q2 = K * p2;
    const cv::Point2d px1(q1.x() / q1.z(), q1.y() / q1.z()), px2(q2.x() / q2.z(), q2.y() / q2.z());
    if (px2.x < 0 || px2.y < 0 || px2.x > 1024 || px2.y > 1024) continue;
    s.points_c1.push_back(p);
    s.px1.emplace_back(px1.x + rng.gaussian(g.noise_px), px1.y + rng.gaussian(g.noise_px));
    s.px2.emplace_back(px2.x + rng.gaussian(g.noise_px), px2.y + rng.gaussian(g.noise_px));
  }
  return s;
}

/// Flat ground seen obliquely, as by the 30-degree-forward lander camera: 1500 units away, camera 2 moved
/// `baseline` along the ground (downrange: the in-plane direction seen at the top of the image) and pitched
/// 0.5 deg.
SyntheticTwoViewScene obliqueGround(double tilt_deg, double baseline, double noise_px, uint32_t seed) {
  const double tilt = tilt_deg * M_PI / 180.0;
  GroundSpec g;
  g.tilt_deg = tilt_deg;
  g.baseline = baseline;
  g.direction_c1 = Eigen::Vector3d(0.0, -std::cos(tilt), std::sin(tilt));
  g.noise_px = noise_px;
  g.seed = seed;
  return groundScene(g);
}

TEST(Initializer, TriangulationSettlesTheHomographyAmbiguityWithoutAPrior) {
  // Flying downrange over ground seen 30 deg forward (Main Brake, 30-degree camera): both homography
  // decompositions put every point in front of both cameras, so the in-front counts tie and estimateMotion()
  // without a prior must refuse. The wrong decomposition puts the plane where the rays meet at a smaller
  // angle (and some behind a camera), so it triangulates far fewer points; initialize() uses that.
  const SyntheticTwoViewScene ground = obliqueGround(30.0, 150.0, 0.3, 5);
  const Initializer no_prior(motionConfig(MotionModel::kHomography), MapConfig(), Eigen::Vector3d::Zero());
  const RelativeMotion ambiguous = no_prior.estimateMotion(ground.px1, ground.px2, ground.camera.K());
  std::cout << "estimateMotion: " << (ambiguous.valid ? "valid" : ambiguous.reason) << "\n";
  ASSERT_FALSE(ambiguous.valid) << "precondition: the decompositions are indistinguishable by the counts";
  EXPECT_NE(ambiguous.reason.find("ambiguous"), std::string::npos) << ambiguous.reason;

  for (MotionModel model : {MotionModel::kHomography, MotionModel::kAuto}) {
    SCOPED_TRACE(toString(model));
    const Initializer init(motionConfig(model), MapConfig(), Eigen::Vector3d::Zero());
    const Initialization map =
        init.initialize(ids(ground.px1.size()), ground.px1, ground.px2, ground.camera.K());
    std::cout << toString(model) << ": " << map.points_c1.size() << " points, rival " << map.rival_points
              << " " << map.reason << "\n";
    ASSERT_TRUE(map.valid) << map.reason;
    expectMotionClose(map.motion, ground.T_c2_c1, 5.0, 0.3);
    EXPECT_LT(map.rival_points, 0.75 * map.points_c1.size());
  }
}

TEST(Initializer, AmbiguousPlanarDescentIsRejectedNotGuessed) {
  // Descending towards a fronto-parallel plane: the two decompositions triangulate about as many points, so
  // without a prior nothing can tell them apart yet, and the pair is rejected.
  const SyntheticTwoViewScene descent = scene(0.0, 100.0, 0.5, Eigen::Vector3d(0.2, 0.1, 1.0));
  const Initializer init(motionConfig(MotionModel::kHomography), MapConfig(), Eigen::Vector3d::Zero());
  const Initialization map =
      init.initialize(ids(descent.px1.size()), descent.px1, descent.px2, descent.camera.K());
  EXPECT_FALSE(map.valid);
  EXPECT_NE(map.reason.find("two different motions"), std::string::npos) << map.reason;
}

TEST(Initializer, APlanarViewIsNotStartedFromEssentialAloneWhenItsTwinFitsAsWell) {
  // Descending towards a plane: the view is planar (auto picks the homography), but here the homography fails
  // a check of its own (a plane-normal prior it disagrees with stands in for the real case, a parallax just
  // short of the threshold) while E passes. On a plane E has a twin motion explaining the points as well, and
  // five-point E may return either: approach_30deg at 1024 px, 210 features without anchor refinement,
  // initialised from the twin and tracked a mirrored trajectory (Sim(3) ATE 19.7 %). The homography's
  // decompositions compete as rivals: with both motions triangulating about as many points, nothing starts.
  const SyntheticTwoViewScene descent = scene(0.0, 100.0, 0.5, Eigen::Vector3d(0.2, 0.1, 1.0));
  const Eigen::Vector3d wrong_prior(1.0, 0.0, 0.0);
  const RelativeMotion e = Initializer(motionConfig(MotionModel::kEssential), MapConfig(), wrong_prior)
                               .estimateMotion(descent.px1, descent.px2, descent.camera.K());
  const RelativeMotion h = Initializer(motionConfig(MotionModel::kHomography), MapConfig(), wrong_prior)
                               .estimateMotion(descent.px1, descent.px2, descent.camera.K());
  std::cout << "E: " << (e.valid ? "valid" : e.reason) << "; H: " << (h.valid ? "valid" : h.reason) << "\n";
  ASSERT_TRUE(e.valid) << "precondition: E passes its checks";
  ASSERT_FALSE(h.valid) << "precondition: the homography fails one of its own";
  const Initialization map =
      Initializer(motionConfig(MotionModel::kAuto), MapConfig(), wrong_prior)
          .initialize(ids(descent.px1.size()), descent.px1, descent.px2, descent.camera.K());
  std::cout << "auto: " << (map.valid ? "valid" : map.reason) << "\n";
  EXPECT_FALSE(map.valid) << "started from E alone";
  EXPECT_TRUE(map.reason.find("two different motions") != std::string::npos ||
              map.reason.find("failed its own checks") != std::string::npos)
      << map.reason;
  // Off the plane E has no twin: the same motion over relief starts a map.
  const SyntheticTwoViewScene relief = scene(800.0, 100.0, 0.5, Eigen::Vector3d(0.2, 0.1, 1.0));
  const Initialization relief_map =
      Initializer(motionConfig(MotionModel::kAuto), MapConfig(), wrong_prior)
          .initialize(ids(relief.px1.size()), relief.px1, relief.px2, relief.camera.K());
  ASSERT_TRUE(relief_map.valid) << relief_map.reason;
  expectMotionClose(relief_map.motion, relief.T_c2_c1, 5.0, 0.3);
}

TEST(Initializer, ReliefOffThePlaneSettlesTheTwinThatTheCountsCannot) {
  // Descending towards nearly planar ground (depth spread 80 at 1500 units, 0.1 px noise): both motions
  // triangulate about as many points, so the counts alone would wait, as on approach_nozzle (512 ideal,
  // dispersed render run_000) for 54 frames. Under the twin motion the relief leaves a systematic
  // reprojection residual; the cost on the common correspondences settles the pair for the right motion.
  const SyntheticTwoViewScene ground = scene(80.0, 100.0, 0.1, Eigen::Vector3d(0.2, 0.1, 1.0));
  for (MotionModel model : {MotionModel::kHomography, MotionModel::kAuto}) {
    SCOPED_TRACE(toString(model));
    const Initialization map =
        Initializer(motionConfig(model), MapConfig(), Eigen::Vector3d::Zero())
            .initialize(ids(ground.px1.size()), ground.px1, ground.px2, ground.camera.K());
    std::cout << toString(model) << ": " << map.points_c1.size() << " points, rival " << map.rival_points
              << " at " << map.rival_cost_ratio << "x the cost " << map.reason << "\n";
    ASSERT_TRUE(map.valid) << map.reason;
    expectMotionClose(map.motion, ground.T_c2_c1, 2.0, 0.3);
    EXPECT_GE(map.rival_points, 0.75 * map.points_c1.size())
        << "precondition: the counts alone are ambiguous";
    EXPECT_GE(map.rival_cost_ratio, 1.5);
  }
  // Over flat to rough ground and 0.1-0.5 px of noise: the cost starts a map only for the right motion, and
  // on a plane (where the motions are truly twins) it waits.
  for (double spread : {0.0, 20.0, 40.0, 80.0, 160.0}) {
    for (double noise : {0.1, 0.3, 0.5}) {
      const SyntheticTwoViewScene s = scene(spread, 100.0, noise, Eigen::Vector3d(0.2, 0.1, 1.0));
      for (MotionModel model : {MotionModel::kHomography, MotionModel::kAuto}) {
        SCOPED_TRACE(std::string(toString(model)) + " spread " + std::to_string(spread) + " noise " +
                     std::to_string(noise));
        const Initialization map = Initializer(motionConfig(model), MapConfig(), Eigen::Vector3d::Zero())
                                       .initialize(ids(s.px1.size()), s.px1, s.px2, s.camera.K());
        if (spread == 0.0) {
          EXPECT_FALSE(map.valid) << "a plane started a map";
        }
        if (map.valid && map.rival_points >= 0.75 * map.points_c1.size()) {
          expectMotionClose(map.motion, s.T_c2_c1, 2.0, 0.3);  // the cost decided
        } else if (map.valid) {
          // The count decided: the right motion, within what 0.5 px of noise leaves E over relief (5.5 deg in
          // direction at spread 160), not the twin (tens of degrees).
          expectMotionClose(map.motion, s.T_c2_c1, 8.0, 0.5);
        }
      }
    }
  }
}

/// Closing in on ground seen 45 deg obliquely, as the nozzle-pointing camera does in the last 15 s of
/// approach_nozzle: camera 2 moved `baseline` along (0, -0.45, 0.89) in camera 1 (forward and up in the
/// image: descending 18 deg to the ground, as on hazard campaign seed 15 run_002) and pitched 0.12 deg; 300
/// points.
SyntheticTwoViewScene closingOnObliqueGround(double distance, double relief, double baseline, double noise_px,
                                             uint32_t seed) {
  GroundSpec g;
  g.tilt_deg = 45.0;
  g.distance = distance;
  g.relief = relief;
  g.baseline = baseline;
  g.direction_c1 = Eigen::Vector3d(0.0, -0.45, 0.89);
  g.pitch_deg = 0.12;
  g.num_points = 300;
  g.noise_px = noise_px;
  g.seed = seed;
  return groundScene(g);
}

TEST(Initializer, TheCostOverrulesACountThatFavoursTheTwinOfAForwardMotion) {
  // Moving mostly along the optical axis, the right motion's rays meet at small angles near the focus of
  // expansion and fewer of its points pass the triangulation parallax threshold than the planar twin's, whose
  // translation is more sideways: counted alone, the twin wins (hazard campaign seed 15, approach_nozzle
  // run_002: 225 points against 149, a map that pitched 26 deg for the true 41). The relief leaves the twin a
  // reprojection cost several times the right motion's; the cost decides.
  int twin_outcounts = 0;
  for (uint32_t seed = 1; seed <= 5; ++seed) {
    const SyntheticTwoViewScene s = closingOnObliqueGround(184.0, 10.0, 7.0, 0.1, seed);
    for (MotionModel model : {MotionModel::kHomography, MotionModel::kAuto}) {
      SCOPED_TRACE(std::string(toString(model)) + " seed " + std::to_string(seed));
      const Initialization map = Initializer(motionConfig(model), MapConfig(), Eigen::Vector3d::Zero())
                                     .initialize(ids(s.px1.size()), s.px1, s.px2, s.camera.K());
      std::cout << toString(model) << " seed " << seed << ": " << map.points_c1.size() << " points, rival "
                << map.rival_points << " at " << map.rival_cost_ratio << "x the cost " << map.reason << "\n";
      ASSERT_TRUE(map.valid) << map.reason;
      expectMotionClose(map.motion, s.T_c2_c1, 3.0, 0.1);
      EXPECT_GE(map.rival_cost_ratio, 1.5);
      twin_outcounts += map.rival_points > static_cast<int>(map.points_c1.size());
    }
  }
  EXPECT_GE(twin_outcounts, 5) << "precondition: on most of these pairs the twin triangulates more points";
  // On flat ground (relief 0) the two motions cost the same and the count still decides: for this motion it
  // picks the twin (docs/visual_core.md, step 15, a limitation: no check here can tell the motions apart).
}

TEST(Initializer, MapIsTheSceneAtUnitBaseline) {
  const SyntheticTwoViewScene relief = scene(800.0, 150.0, 0.3);
  const Initializer init(motionConfig(MotionModel::kAuto), MapConfig());
  const std::vector<uint64_t> track_ids = ids(relief.px1.size());
  const Initialization map = init.initialize(track_ids, relief.px1, relief.px2, relief.camera.K());
  ASSERT_TRUE(map.valid) << map.reason;
  ASSERT_GT(map.points_c1.size(), 300u);
  // The true baseline is 150 units, the map's is 1: every point is the true one divided by 150.
  const double scale = relief.T_c2_c1.translation().norm();
  int close = 0;
  for (size_t i = 0; i < map.points_c1.size(); ++i) {
    const uint64_t k = map.track_ids[i] - 1000;
    const Eigen::Vector3d truth = relief.points_c1[k] / scale;
    if ((map.points_c1[i] - truth).norm() < 0.05 * truth.norm()) ++close;
  }
  EXPECT_GT(close, static_cast<int>(0.95 * map.points_c1.size()));
  EXPECT_NEAR(map.median_depth * scale, 1500.0 + 400.0, 200.0);
}

TEST(Initializer, NoParallaxIsRejectedNotInvented) {
  // Hover: the same view twice (plus noise). A VO must not invent motion here (peer-results, EuRoC static).
  const SyntheticTwoViewScene hover = scene(800.0, 0.0, 0.5);
  for (MotionModel model : {MotionModel::kAuto, MotionModel::kEssential, MotionModel::kHomography}) {
    const Initialization map = Initializer(motionConfig(model), MapConfig())
                                   .initialize(ids(hover.px1.size()), hover.px1, hover.px2, hover.camera.K());
    EXPECT_FALSE(map.valid) << toString(model);
    EXPECT_FALSE(map.reason.empty());
  }
}

/// A street seen by a car's camera (KITTI-like: 1241 x 376 px, f 718 px, 1.65 m above the road): a third of
/// the points on the road 4-14 m ahead, the rest on facades and far away (15-80 m); the car moves `forward_m`
/// with a 0.5 deg turn. Not planar: the homography of the road explains only its third.
SyntheticTwoViewScene street(double forward_m, uint32_t seed) {
  SyntheticTwoViewScene s;
  s.camera = PinholeCamera(1241, 376, 718.856, 718.856, 607.19, 185.22);
  s.T_c2_c1.linear() = Eigen::AngleAxisd(0.5 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  s.T_c2_c1.translation() = -s.T_c2_c1.linear() * Eigen::Vector3d(0.0, 0.0, forward_m);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.3);
  while (s.points_c1.size() < 150) {
    Eigen::Vector3d p;
    if (s.points_c1.size() % 3 == 0) {  // road: y = +1.65 m (camera y down)
      p = Eigen::Vector3d(-6.0 + 12.0 * u(rng), 1.65, 4.0 + 10.0 * u(rng));
    } else {  // facades and the far street
      p = Eigen::Vector3d(-25.0 + 50.0 * u(rng), -8.0 + 9.5 * u(rng), 15.0 + 65.0 * u(rng));
    }
    const Eigen::Vector2d a = s.camera.project(p), b = s.camera.project(s.T_c2_c1 * p);
    if (a.x() < 0 || a.x() > 1240 || a.y() < 0 || a.y() > 375 || b.x() < 0 || b.x() > 1240 || b.y() < 0 ||
        b.y() > 375)
      continue;
    s.points_c1.push_back(p);
    s.px1.emplace_back(a.x() + noise(rng), a.y() + noise(rng));
    s.px2.emplace_back(b.x() + noise(rng), b.y() + noise(rng));
  }
  return s;
}

TEST(Initializer, ARoadHomographyDoesNotStartAStreetWhoseParallaxIsTooSmall) {
  // The KITTI turn clip started at its image 1 was initialised 0.1 s later from a homography of 56 of 136
  // points (the road), with a median parallax of 10.8 deg under its own decomposition while the essential
  // matrix measured 0.32 deg on 104 points: a wrong motion (Sim(3) ATE 3.2 %, attitude off by 10 deg). When
  // the score does not call the views planar, the homography of part of them is a fallback only where E has
  // no verdict on the parallax; where E says it is too small, the initialisation waits.
  MotionConfig motion = motionConfig(MotionModel::kAuto);
  const Initializer init(motion, MapConfig());
  const SyntheticTwoViewScene near = street(0.6, 3);
  const Initialization wait = init.initialize(ids(near.px1.size()), near.px1, near.px2, near.camera.K());
  EXPECT_FALSE(wait.valid) << "started: " << wait.motion.reason;
  EXPECT_NE(wait.reason.find("parallax"), std::string::npos) << wait.reason;
  // The homography alone is valid on these views: it is what the old fallback started from.
  motion.model = MotionModel::kHomography;
  const RelativeMotion h =
      Initializer(motion, MapConfig()).estimateMotion(near.px1, near.px2, near.camera.K());
  EXPECT_TRUE(h.valid) << h.reason;
  // With enough parallax E starts the map, with the true motion.
  const SyntheticTwoViewScene far = street(3.0, 3);
  const Initialization go = init.initialize(ids(far.px1.size()), far.px1, far.px2, far.camera.K());
  ASSERT_TRUE(go.valid) << go.reason;
  expectMotionClose(go.motion, far.T_c2_c1, 3.0, 0.2);
}

TEST(Initializer, PointsInASmallPartOfTheViewDoNotStartAMap) {
  // 80 points in a patch of 1/100 of the view (a lit strip above the shadow at a Sun of 10 deg, held-out
  // approach_nozzle run_004): the motion fits their pixels but they cannot tell a rotation from a
  // translation. Unchecked, such starts were 58-62 deg off in their direction of travel there (40-131 deg
  // here); the check refuses every one and says the reference must move.
  int unchecked_valid = 0, unchecked_wrong = 0, checked_valid = 0, ill_conditioned = 0;
  for (uint32_t seed = 1; seed <= 10; ++seed) {
    SyntheticSceneConfig cfg;
    cfg.num_points = 80;
    cfg.xy_half_extent = 100.0;
    cfg.depth_spread = 300.0;
    cfg.baseline = 60.0;
    cfg.centre_direction_c1 = Eigen::Vector3d(0.6, -0.3, 0.75);
    cfg.rotation_deg = 1.5;
    cfg.noise_px = 0.3;
    cfg.seed = seed;
    const SyntheticTwoViewScene s = makeSyntheticScene(cfg);
    MotionConfig unchecked = motionConfig(MotionModel::kEssential);
    unchecked.max_rotation_sigma_deg = 0.0;
    const Initialization a =
        Initializer(unchecked, MapConfig()).initialize(ids(s.px1.size()), s.px1, s.px2, s.camera.K());
    const Initialization b = Initializer(motionConfig(MotionModel::kEssential), MapConfig())
                                 .initialize(ids(s.px1.size()), s.px1, s.px2, s.camera.K());
    if (a.valid) {
      ++unchecked_valid;
      const double dir_err = angleBetweenDeg(a.motion.T_c2_c1_unit.translation(), s.T_c2_c1.translation());
      std::cout << "seed " << seed << ": unchecked start " << dir_err
                << " deg off in direction, rotation sigma " << a.conditioning.rotation_sigma_deg << " deg\n";
      unchecked_wrong += dir_err > 10.0;
    }
    checked_valid += b.valid;
    ill_conditioned += a.valid && b.ill_conditioned;
    std::cout << "seed " << seed << ": checked: " << b.reason << "\n";
  }
  // The other pairs fail the parallax check: their essential matrix is itself wrong.
  EXPECT_GE(unchecked_valid, 5) << "precondition: pairs with the parallax and the points a start needs";
  EXPECT_GE(unchecked_wrong, unchecked_valid - 1);
  EXPECT_EQ(checked_valid, 0);
  EXPECT_EQ(ill_conditioned, unchecked_valid);
}

TEST(Initializer, TooFewCorrespondencesAreRejected) {
  const SyntheticTwoViewScene relief = scene(800.0, 150.0);
  std::vector<cv::Point2d> a(relief.px1.begin(), relief.px1.begin() + 10);
  std::vector<cv::Point2d> b(relief.px2.begin(), relief.px2.begin() + 10);
  const RelativeMotion m = Initializer(MotionConfig(), MapConfig()).estimateMotion(a, b, relief.camera.K());
  EXPECT_FALSE(m.valid);
  EXPECT_NE(m.reason.find("too few"), std::string::npos);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}

// Descent trajectories, IMU / altimeter consistency, DEM placement, crater statistics, photometry.
#include <cmath>

#include <gtest/gtest.h>

#include "planetary_vo/render/crater_field.h"
#include "planetary_vo/render/descent_trajectory.h"
#include "planetary_vo/render/photometry.h"
#include "planetary_vo/render/sequence_renderer.h"
#include "test_support.h"

using namespace planetary_vo;
using namespace planetary_vo::render;

TEST(DescentTrajectory, MainBrakeMatchesThesisTable) {
  const DescentTrajectory tr(TrajectoryPhase::kMainBrake, CameraMode::kDownward);
  EXPECT_DOUBLE_EQ(tr.duration(), 114.0);
  const Eigen::Vector3d d = tr.position(114.0) - tr.position(0.0);
  EXPECT_NEAR(d.y(), 35049.0, 1.0);
  EXPECT_NEAR(d.x(), 6507.0, 1.0);
  EXPECT_LT(tr.position(114.0).y(), 0.0);  // downrange is negative (thesis 4.2.2)
  EXPECT_NEAR(tr.position(0.0).z(), 1400.0, 1e-9);
  // Nearly constant altitude before the final descent, then a steep drop.
  EXPECT_NEAR(tr.position(60.0).z(), 1400.0, 1e-9);
  EXPECT_LT(tr.position(114.0).z(), 700.0);
}

TEST(DescentTrajectory, ApproachDescendsSteadilyToLowGate) {
  const DescentTrajectory tr(TrajectoryPhase::kApproach, CameraMode::kDownward);
  EXPECT_DOUBLE_EQ(tr.duration(), 55.0);
  EXPECT_NEAR(tr.position(55.0).z(), 100.0, 1e-6);
  for (double t = 0.1; t <= 55.0; t += 0.1) ASSERT_LT(tr.position(t).z(), tr.position(t - 0.1).z()) << t;
  EXPECT_GT(tr.position(0.0).z() / tr.position(55.0).z(), 5.0);  // image scale grows > 5x
}

TEST(DescentTrajectory, DerivativesAreConsistentAndAccelerationContinuous) {
  for (const SequenceSpec& spec : lunarSequences()) {
    const DescentTrajectory tr = DescentTrajectory::fromSequence(spec);
    for (double t = 0.5; t < tr.duration() - 0.5; t += 1.7) {
      const double h = 1e-3;
      EXPECT_LT((tr.velocity(t) - (tr.position(t + h) - tr.position(t - h)) / (2 * h)).norm(), 1e-3)
          << spec.name;
      EXPECT_LT((tr.acceleration(t) - (tr.velocity(t + h) - tr.velocity(t - h)) / (2 * h)).norm(), 1e-3);
      // Continuous acceleration: no jump over 1 ms anywhere (jerk is bounded).
      EXPECT_LT((tr.acceleration(t + 1e-3) - tr.acceleration(t)).norm(), 1e-3) << spec.name << " t=" << t;
    }
  }
}

TEST(DescentTrajectory, CameraModes) {
  auto offNadirDeg = [](const DescentTrajectory& tr, double t) {
    return angleBetweenDeg(tr.rotation(t).col(2), -Eigen::Vector3d::UnitZ());
  };
  const DescentTrajectory down(TrajectoryPhase::kMainBrake, CameraMode::kDownward);
  const DescentTrajectory fwd(TrajectoryPhase::kMainBrake, CameraMode::kForward30);
  const DescentTrajectory pitch(TrajectoryPhase::kMainBrake, CameraMode::kPitchDownTo30);
  const DescentTrajectory nozzle(TrajectoryPhase::kApproach, CameraMode::kNozzle);
  EXPECT_NEAR(offNadirDeg(down, 30), 0.0, 1e-9);
  EXPECT_NEAR(offNadirDeg(fwd, 30), 30.0, 1e-9);
  EXPECT_GT(fwd.rotation(30).col(2).dot(fwd.forward()), 0.4);  // tilted forward, not backward
  EXPECT_NEAR(offNadirDeg(pitch, 0), 0.0, 1e-9);
  EXPECT_NEAR(offNadirDeg(pitch, 114), 30.0, 1e-9);
  EXPECT_GT(pitch.state(45).angular_velocity_cam.norm(), 0.05);  // the manoeuvre is a real rotation
  for (double t = 0; t <= 55; t += 5) {
    const Eigen::Vector3d thrust = nozzle.acceleration(t) + Eigen::Vector3d(0, 0, kLunarGravity);
    EXPECT_NEAR(angleBetweenDeg(nozzle.rotation(t).col(2), -thrust), 0.0, 1e-6);
  }
  EXPECT_GT(offNadirDeg(nozzle, 0) - offNadirDeg(nozzle, 55),
            10.0);  // rotates continuously during the descent
  for (const DescentTrajectory* tr : {&down, &fwd, &pitch, &nozzle})
    EXPECT_NEAR((tr->rotation(7).transpose() * tr->rotation(7) - Eigen::Matrix3d::Identity()).norm(), 0.0,
                1e-12);
}

TEST(DescentTrajectory, ImuIntegratesToTheGroundTruthMotion) {
  for (const char* name : {"main_brake_pitch", "approach_nozzle", "approach_30deg"}) {
    const DescentTrajectory tr = DescentTrajectory::fromSequence(findSequence(name));
    const double t0 = 35.0, t1 = 52.0, dt = 1.0 / 200.0;
    Eigen::Vector3d dv = Eigen::Vector3d::Zero();
    Eigen::Matrix3d R = tr.rotation(t0);
    const Eigen::Vector3d g(0, 0, -kLunarGravity);
    for (double t = t0; t < t1 - 1e-9; t += dt) {
      const ImuSample a = tr.imu(t), b = tr.imu(t + dt);
      const Eigen::Vector3d w = 0.5 * dt * (a.angular_velocity_radps + b.angular_velocity_radps);
      const Eigen::Matrix3d Rb =
          w.norm() > 0 ? Eigen::Matrix3d(R * Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix())
                       : R;
      dv += 0.5 * dt * (R * a.specific_force_mps2 + Rb * b.specific_force_mps2) + dt * g;
      R = Rb;
    }
    EXPECT_LT((dv - (tr.velocity(t1) - tr.velocity(t0))).norm(), 2e-3) << name;
    EXPECT_LT(rotationAngleDeg(R.transpose() * tr.rotation(t1)), 1e-3) << name;
  }
}

TEST(DescentTrajectory, PlacementKeepsTerrainClearAndAltimeterIsConsistent) {
  const std::string dem_path = test::dataPath("lunar_dem/apollo17_gld100.yaml");
  ASSERT_TRUE(test::requireDataFile(dem_path));
  const auto dem = LunarDem::load(dem_path);
  for (const char* name : {"main_brake_30deg", "approach_down"}) {
    const DescentTrajectory tr = DescentTrajectory::fromSequence(findSequence(name));
    const LunarTerrain terrain(dem, placeTrajectoryOnDem(*dem, tr), TerrainParams());
    for (double t = 0; t <= tr.duration(); t += tr.duration() / 20) {
      const TrajectoryState s = tr.state(t);
      const AltimeterTruth alt = altimeterTruthAt(terrain, tr, t);
      // Altitude is camera z minus the terrain right below; the terrain stays well below the camera.
      EXPECT_NEAR(alt.altitude_m,
                  s.position.z() - terrain.height(s.position.x(), s.position.y(), kAltimeterLodM), 1e-9);
      EXPECT_GT(alt.altitude_m, 0.4 * s.position.z()) << name << " t=" << t;
      // The true slant range ends on the terrain surface, along the boresight.
      ASSERT_TRUE(std::isfinite(alt.true_range_m));
      ASSERT_GT(alt.true_range_m, 0.0);
      const Eigen::Vector3d hit = s.position + alt.true_range_m * s.R_world_cam.col(2);
      EXPECT_NEAR(hit.z(), terrain.height(hit.x(), hit.y(), kAltimeterLodM), 1e-3) << name << " t=" << t;
      EXPECT_GE(alt.incidence_deg, 0.0);
      EXPECT_LT(alt.incidence_deg, 90.0);
      EXPECT_GE(alt.true_range_m, 0.5 * alt.altitude_m);
    }
  }
}

TEST(CraterField, PowerLawSizeFrequencyAndMorphology) {
  CraterFieldParams params;
  const CraterField field(7, params);
  // Count craters per class over the same area: N(>D) ~ D^-2 means each octave holds 4x fewer craters.
  const double area_side = 400.0 * field.classDiameter(3);
  std::vector<double> counts;
  Crater buf[CraterField::kMaxPerCell];
  for (int k = 3; k <= 5; ++k) {
    const int64_t n = static_cast<int64_t>(area_side / field.cellSize(k));
    double c = 0;
    for (int64_t i = 0; i < n; ++i)
      for (int64_t j = 0; j < n; ++j) {
        const int m = field.cellCraters(k, i, j, buf);
        for (int q = 0; q < m; ++q) {
          EXPECT_GE(buf[q].diameter_m, field.classDiameter(k));
          EXPECT_LT(buf[q].diameter_m, 2 * field.classDiameter(k));
        }
        c += m;
      }
    counts.push_back(c);
  }
  EXPECT_NEAR(counts[0] / counts[1], 4.0, 0.4);
  EXPECT_NEAR(counts[1] / counts[2], 4.0, 0.8);
  Crater fresh;
  fresh.diameter_m = 100, fresh.freshness = 1.0, fresh.depth_m = 20, fresh.rim_height_m = 4;
  EXPECT_NEAR(CraterField::craterProfile(fresh, 0.0), -16.0, 0.5);  // floor 0.2 D below the rim crest
  EXPECT_NEAR(CraterField::craterProfile(fresh, 50.0), 4.0, 0.3);   // raised rim
  EXPECT_EQ(CraterField::craterProfile(fresh, 130.0), 0.0);         // ejecta ends at 2.5 R
}

// The renderer bakes its lattices with sampleGrid (per-feature splatting); it must be the same terrain as
// point sampling, bit for bit, at every level of detail (fine levels: boulders and small craters; coarse
// ones: only DEM, large craters and low octaves), including negative coordinates and cell boundaries.
TEST(LunarTerrain, GridBakingEqualsPointSampling) {
  const std::string dem_path = test::dataPath("lunar_dem/apollo15_gld100.yaml");
  ASSERT_TRUE(test::requireDataFile(dem_path));
  const auto dem = LunarDem::load(dem_path);
  const DescentTrajectory tr = DescentTrajectory::fromSequence(findSequence("approach_down"));
  TerrainParams tp;
  tp.seed = 3;
  const LunarTerrain terrain(dem, placeTrajectoryOnDem(*dem, tr), tp);
  const int n = 40;
  std::vector<float> h(n * n), a(n * n);
  int checked = 0, differing_from_flat = 0;
  for (int level = 0; level <= 12; level += 2) {
    const double s = std::ldexp(1.0, level) / 64.0;
    for (const auto& origin : {std::pair<int64_t, int64_t>{-20, -7}, {-517, 913}, {12345, -4321}}) {
      terrain.sampleGrid(origin.first, origin.second, n, n, s, s, h.data(), a.data());
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          const LunarTerrain::Sample p = terrain.sample((origin.first + i) * s, (origin.second + j) * s, s);
          ASSERT_EQ(h[j * n + i], static_cast<float>(p.height_m)) << level << " " << i << " " << j;
          ASSERT_EQ(a[j * n + i], static_cast<float>(p.albedo)) << level << " " << i << " " << j;
          differing_from_flat += std::abs(p.albedo - tp.albedo) > 0.03;  // fresh ejecta / boulders seen
          ++checked;
        }
    }
  }
  EXPECT_EQ(checked, 7 * 3 * n * n);
  EXPECT_GT(differing_from_flat, 0);
}

TEST(Photometry, LunarLambertIsNotLambert) {
  // At zero phase, lunar-Lambert is Lommel-Seeliger-like: no limb darkening (brightness independent of
  // slope).
  EXPECT_NEAR(lunarLambertL(0.0), 1.0, 1e-12);
  const double flat = lunarLambertReflectance(0.1, 1.0, 1.0, 0.0);
  const double tilted = lunarLambertReflectance(0.1, 0.5, 0.5, 0.0);
  EXPECT_NEAR(flat, tilted, 1e-12);  // Lambert would halve it
  EXPECT_LT(lunarLambertL(90.0), 0.5);
  EXPECT_EQ(lunarLambertReflectance(0.1, -0.1, 1.0, 30.0), 0.0);
  EXPECT_NEAR(sunDirection(12, 90).z(), std::sin(12 * M_PI / 180), 1e-12);
  EXPECT_GT(sunDirection(12, 90).x(), 0.9);
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}

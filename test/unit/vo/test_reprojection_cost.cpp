/// Tests of the bundle adjustment's analytic reprojection cost: its residual and Jacobians equal those of
/// Ceres' automatic differentiation of the same expression (Eigen's q * p, projected), at random poses and
/// points, also for a quaternion off unit norm (the Jacobian is taken in the ambient 4-space, before the
/// manifold); and a point behind the camera fails the evaluation.

#include <random>

#include <gtest/gtest.h>

#include <ceres/autodiff_cost_function.h>
#include <Eigen/Geometry>

#include "planetary_vo/vo/reprojection_cost.h"

namespace planetary_vo {
namespace {

/// The residual as the bundle adjustment wrote it before (automatic differentiation): the reference.
struct AutoDiffReprojection {
  AutoDiffReprojection(const Eigen::Vector2d& px, double fx, double fy, double cx, double cy)
      : px_(px), fx_(fx), fy_(fy), cx_(cx), cy_(cy) {}
  template <typename T>
  bool operator()(const T* q_cam_world, const T* t_cam_world, const T* p_world, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(q_cam_world);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(t_cam_world);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p(p_world);
    const Eigen::Matrix<T, 3, 1> p_cam = q * p + t;
    if (!(p_cam.z() > T(0))) return false;
    residual[0] = T(fx_) * p_cam.x() / p_cam.z() + T(cx_) - T(px_.x());
    residual[1] = T(fy_) * p_cam.y() / p_cam.z() + T(cy_) - T(px_.y());
    return true;
  }
  Eigen::Vector2d px_;
  double fx_, fy_, cx_, cy_;
};

struct Evaluation {
  bool ok = false;
  Eigen::Vector2d r;
  Eigen::Matrix<double, 2, 4, Eigen::RowMajor> j_q;
  Eigen::Matrix<double, 2, 3, Eigen::RowMajor> j_t, j_p;
};

Evaluation evaluate(const ceres::CostFunction& cost, const double* q, const double* t, const double* p) {
  Evaluation e;
  const double* parameters[3] = {q, t, p};
  double* jacobians[3] = {e.j_q.data(), e.j_t.data(), e.j_p.data()};
  e.ok = cost.Evaluate(parameters, e.r.data(), jacobians);
  return e;
}

TEST(ReprojectionCost, ResidualAndJacobiansEqualAutomaticDifferentiation) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  const double fx = 880.0, fy = 870.0, cx = 512.5, cy = 511.0;
  int evaluated = 0;
  double worst_jacobian = 0.0;
  for (int trial = 0; trial < 200; ++trial) {
    // A random rotation; on every fourth trial a quaternion 5 % off unit norm (an ambient-space point).
    Eigen::Quaterniond q = Eigen::Quaterniond::UnitRandom();
    const double scale = trial % 4 == 0 ? 1.05 : 1.0;
    const Eigen::Vector4d q_coeffs = scale * q.coeffs();
    // A point in front of the camera at 50-5000 m, seen anywhere in a wide field of view.
    const double depth = 50.0 * std::pow(100.0, 0.5 * (uni(rng) + 1.0));
    const Eigen::Vector3d p_cam(0.6 * depth * uni(rng), 0.6 * depth * uni(rng), depth);
    const Eigen::Vector3d t(100.0 * uni(rng), 100.0 * uni(rng), 100.0 * uni(rng));
    const Eigen::Vector3d p_world = q.inverse() * (p_cam - t);
    const Eigen::Vector2d px(fx * p_cam.x() / p_cam.z() + cx + 3.0 * uni(rng),
                             fy * p_cam.y() / p_cam.z() + cy + 3.0 * uni(rng));

    const ReprojectionCost analytic(px, fx, fy, cx, cy);
    const ceres::AutoDiffCostFunction<AutoDiffReprojection, 2, 4, 3, 3> reference(
        new AutoDiffReprojection(px, fx, fy, cx, cy));
    const Evaluation a = evaluate(analytic, q_coeffs.data(), t.data(), p_world.data());
    const Evaluation b = evaluate(reference, q_coeffs.data(), t.data(), p_world.data());
    ASSERT_EQ(a.ok, b.ok) << "trial " << trial;
    if (!b.ok) continue;  // the 5 %-scaled quaternion can put a point behind the camera
    ++evaluated;
    EXPECT_NEAR((a.r - b.r).norm(), 0.0, 1e-9 * (1.0 + b.r.norm())) << "trial " << trial;
    const double jq = (a.j_q - b.j_q).norm() / b.j_q.norm();
    const double jt = (a.j_t - b.j_t).norm() / b.j_t.norm();
    const double jp = (a.j_p - b.j_p).norm() / b.j_p.norm();
    EXPECT_LT(jq, 1e-12) << "trial " << trial;
    EXPECT_LT(jt, 1e-12) << "trial " << trial;
    EXPECT_LT(jp, 1e-12) << "trial " << trial;
    worst_jacobian = std::max({worst_jacobian, jq, jt, jp});
  }
  EXPECT_GT(evaluated, 180);
  RecordProperty("worst_relative_jacobian_difference", std::to_string(worst_jacobian));
}

TEST(ReprojectionCost, APointOnOrBehindTheImagePlaneFails) {
  const ReprojectionCost cost(Eigen::Vector2d(100.0, 100.0), 500.0, 500.0, 320.0, 240.0);
  const Eigen::Vector4d q = Eigen::Quaterniond::Identity().coeffs();
  const Eigen::Vector3d t = Eigen::Vector3d::Zero();
  for (const double z : {0.0, -1.0, -1000.0}) {
    const Eigen::Vector3d p(1.0, 2.0, z);
    EXPECT_FALSE(evaluate(cost, q.data(), t.data(), p.data()).ok) << "z " << z;
  }
  const Eigen::Vector3d in_front(1.0, 2.0, 1e-6);
  EXPECT_TRUE(evaluate(cost, q.data(), t.data(), in_front.data()).ok);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}

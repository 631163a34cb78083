// Window BA factors (include/mcvo/backend/factors.h): residual at ground truth,
// Jacobians against central differences in the tangent space, bearings beyond
// 90 deg, and a small two-frame, two-camera bundle adjustment.
#include "mcvo/backend/factors.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "backend/backend_test_util.h"

namespace mcvo {
namespace {

using test::kDeg;

constexpr double kSqrtInfo = 460.0 / 1.5;

Eigen::Matrix3d Ypr(double yaw, double pitch, double roll) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// Camera looking along rig +x (rig: x forward, y right, z down), yawed by
// `yaw` about rig z: camera z = viewing direction, camera x = rig right.
Rigid3d RigFromCam(double yaw, const Eigen::Vector3d& position) {
  Eigen::Matrix3d forward_cam;  // columns: camera axes in the rig frame
  forward_cam.col(0) = Eigen::Vector3d::UnitY();
  forward_cam.col(1) = Eigen::Vector3d::UnitZ();
  forward_cam.col(2) = Eigen::Vector3d::UnitX();
  return Rigid3d(Eigen::Matrix3d(Ypr(yaw, 0.0, 0.0) * forward_cam), position);
}

// A landmark seen from an anchor camera and an observing camera.
struct LandmarkCase {
  Rigid3d world_from_rig_anchor, world_from_rig_obs, rig_from_cam_anchor, rig_from_cam_obs;
  Eigen::Vector3d anchor_bearing, observed_bearing;
  double inverse_depth = 0.0;
};

// The landmark at distance `distance` along `anchor_bearing` (camera frame,
// any direction) of the anchor camera; the observed bearing is the truth.
LandmarkCase MakeCase(const Rigid3d& world_from_rig_anchor, const Rigid3d& world_from_rig_obs,
                      const Rigid3d& rig_from_cam_anchor, const Rigid3d& rig_from_cam_obs,
                      const Eigen::Vector3d& anchor_bearing, double distance) {
  LandmarkCase s{world_from_rig_anchor,       world_from_rig_obs,      rig_from_cam_anchor, rig_from_cam_obs,
                 anchor_bearing.normalized(), Eigen::Vector3d::Zero(), 1.0 / distance};
  const Eigen::Vector3d point_in_world =
      world_from_rig_anchor * (rig_from_cam_anchor * (s.anchor_bearing * distance));
  s.observed_bearing =
      (rig_from_cam_obs.Inverse() * (world_from_rig_obs.Inverse() * point_in_world)).normalized();
  return s;
}

enum class Kind { kOtherCamera, kSameCamera, kSameFrame };

// Which implementation of a factor kind: analytic Jacobians with the
// extrinsics as parameter blocks (the default), the AutoDiff reference, or
// analytic with constant extrinsics (no extrinsic blocks).
enum class Variant { kAnalytic, kAutoDiff, kConstExtrinsics };

constexpr Variant kVariants[] = {Variant::kAnalytic, Variant::kAutoDiff, Variant::kConstExtrinsics};

const char* VariantName(Variant variant) {
  switch (variant) {
    case Variant::kAnalytic:
      return "analytic";
    case Variant::kAutoDiff:
      return "autodiff";
    case Variant::kConstExtrinsics:
      return "const extrinsics";
  }
  return "?";
}

// The cost function of `kind` with its parameter blocks (owned storage).
struct Factor {
  std::unique_ptr<ceres::CostFunction> cost;
  std::vector<std::vector<double>> storage;
  std::vector<double*> params;
  std::vector<bool> is_pose;  // pose-manifold block (else the inverse depth)
};

Factor MakeFactor(Kind kind, const LandmarkCase& s, Variant variant = Variant::kAnalytic) {
  Factor f;
  auto add_pose = [&](const Rigid3d& pose) {
    f.storage.emplace_back(kPoseParamSize);
    PoseToParams(pose, f.storage.back().data());
    f.is_pose.push_back(true);
  };
  const Eigen::Vector3d& a = s.anchor_bearing;
  const Eigen::Vector3d& b = s.observed_bearing;
  const bool autodiff = variant == Variant::kAutoDiff;
  const bool with_extrinsics = variant != Variant::kConstExtrinsics;
  switch (kind) {
    case Kind::kOtherCamera:
      f.cost.reset(variant == Variant::kConstExtrinsics
                       ? NewReprojectionFactorOtherCameraConstExtrinsics(a, b, s.rig_from_cam_anchor,
                                                                         s.rig_from_cam_obs, kSqrtInfo)
                   : autodiff ? NewReprojectionFactorOtherCameraAutoDiff(a, b, kSqrtInfo)
                              : NewReprojectionFactorOtherCamera(a, b, kSqrtInfo));
      add_pose(s.world_from_rig_anchor);
      add_pose(s.world_from_rig_obs);
      if (with_extrinsics) {
        add_pose(s.rig_from_cam_anchor);
        add_pose(s.rig_from_cam_obs);
      }
      break;
    case Kind::kSameCamera:
      f.cost.reset(variant == Variant::kConstExtrinsics ? NewReprojectionFactorSameCameraConstExtrinsics(
                                                              a, b, s.rig_from_cam_anchor, kSqrtInfo)
                   : autodiff ? NewReprojectionFactorSameCameraAutoDiff(a, b, kSqrtInfo)
                              : NewReprojectionFactorSameCamera(a, b, kSqrtInfo));
      add_pose(s.world_from_rig_anchor);
      add_pose(s.world_from_rig_obs);
      if (with_extrinsics) add_pose(s.rig_from_cam_anchor);
      break;
    case Kind::kSameFrame:
      f.cost.reset(variant == Variant::kConstExtrinsics
                       ? NewReprojectionFactorSameFrameConstExtrinsics(a, b, s.rig_from_cam_anchor,
                                                                       s.rig_from_cam_obs, kSqrtInfo)
                   : autodiff ? NewReprojectionFactorSameFrameAutoDiff(a, b, kSqrtInfo)
                              : NewReprojectionFactorSameFrame(a, b, kSqrtInfo));
      if (with_extrinsics) {
        add_pose(s.rig_from_cam_anchor);
        add_pose(s.rig_from_cam_obs);
      }
      break;
  }
  f.storage.push_back({s.inverse_depth});
  f.is_pose.push_back(false);
  for (auto& block : f.storage) f.params.push_back(block.data());
  return f;
}

Eigen::Vector2d EvaluateFactor(const Factor& f) {
  Eigen::Vector2d r;
  EXPECT_TRUE(f.cost->Evaluate(f.params.data(), r.data(), nullptr));
  return r;
}

// A setup of `kind` for a landmark along `anchor_bearing`.
LandmarkCase CaseOfKind(Kind kind, const Eigen::Vector3d& anchor_bearing, double distance,
                        std::mt19937* rng) {
  const Rigid3d world_from_rig_anchor(test::RandomRotation(rng, M_PI), Eigen::Vector3d(3.0, -2.0, 0.5));
  const Rigid3d rig_from_next(Ypr(5 * kDeg, 1 * kDeg, -2 * kDeg), Eigen::Vector3d(1.2, 0.1, -0.05));
  const Rigid3d front = RigFromCam(0.0, Eigen::Vector3d(1.5, 0.0, -0.6));
  const Rigid3d side = RigFromCam(-80 * kDeg, Eigen::Vector3d(0.7, -0.5, -1.0));
  switch (kind) {
    case Kind::kOtherCamera:
      return MakeCase(world_from_rig_anchor, world_from_rig_anchor * rig_from_next, front, side,
                      anchor_bearing, distance);
    case Kind::kSameCamera:
      return MakeCase(world_from_rig_anchor, world_from_rig_anchor * rig_from_next, front, front,
                      anchor_bearing, distance);
    case Kind::kSameFrame:
      break;
  }
  return MakeCase(world_from_rig_anchor, world_from_rig_anchor, front, side, anchor_bearing, distance);
}

constexpr Kind kKinds[] = {Kind::kOtherCamera, Kind::kSameCamera, Kind::kSameFrame};

TEST(TangentBasis, OrthonormalRightHandedForEveryDirection) {
  std::mt19937 rng(7);
  std::vector<Eigen::Vector3d> bearings = {Eigen::Vector3d::UnitZ(),
                                           -Eigen::Vector3d::UnitZ(),
                                           Eigen::Vector3d::UnitX(),
                                           -Eigen::Vector3d::UnitY(),
                                           Eigen::Vector3d(0.0, std::sin(0.001), -std::cos(0.001)),
                                           Eigen::Vector3d(0.3, 0.2, -0.5).normalized()};
  for (int i = 0; i < 2000; ++i) bearings.push_back(test::RandomUnit(&rng));
  double worst = 0.0;
  for (const Eigen::Vector3d& b : bearings) {
    const Eigen::Matrix<double, 2, 3> basis = TangentBasis(b);
    const Eigen::Vector3d e1 = basis.row(0).transpose(), e2 = basis.row(1).transpose();
    worst = std::max(worst, (basis * basis.transpose() - Eigen::Matrix2d::Identity()).cwiseAbs().maxCoeff());
    worst = std::max(worst, (basis * b).cwiseAbs().maxCoeff());
    worst = std::max(worst, (e1.cross(e2) - b).cwiseAbs().maxCoeff());
    EXPECT_EQ(basis, TangentBasis(b));  // deterministic
  }
  EXPECT_LT(worst, 1e-14);
  // The optical axis gets the image axes, so residuals read as (u, v) errors.
  EXPECT_LT((TangentBasis(Eigen::Vector3d::UnitZ()) -
             (Eigen::Matrix<double, 2, 3>() << 1, 0, 0, 0, 1, 0).finished())
                .norm(),
            1e-15);
}

TEST(TangentBasis, SmoothWithin120DegreesOfTheAxis) {
  // Lipschitz: a step of d in the bearing moves the basis by O(d), across the
  // 90 deg circle included; the only switch is beyond 120 deg.
  std::mt19937 rng(8);
  double worst_ratio = 0.0;
  for (int i = 0; i < 2000; ++i) {
    Eigen::Vector3d b = test::RandomUnit(&rng);
    if (b.z() < -0.49) continue;
    const Eigen::Vector3d b2 = (b + 1e-6 * test::RandomUnit(&rng)).normalized();
    if (b2.z() < -0.49) continue;
    worst_ratio = std::max(worst_ratio, (TangentBasis(b2) - TangentBasis(b)).norm() / (b2 - b).norm());
  }
  std::printf("tangent basis: max |dB| / |db| = %.3f\n", worst_ratio);
  EXPECT_LT(worst_ratio, 5.0);
}

TEST(PoseParams, RoundTrip) {
  std::mt19937 rng(1);
  const Rigid3d pose(test::RandomRotation(&rng, M_PI), Eigen::Vector3d(1.0, -2.0, 3.0));
  double params[kPoseParamSize];
  PoseToParams(pose, params);
  EXPECT_EQ(params[6], pose.rotation.w());
  EXPECT_EQ(params[3], pose.rotation.x());
  const Rigid3d back = PoseFromParams(params);
  EXPECT_LT(test::RotationAngle(back.rotation, pose.rotation), 1e-15);
  EXPECT_LT((back.translation - pose.translation).norm(), 1e-15);
  std::unique_ptr<ceres::Manifold> manifold(NewPoseManifold());
  EXPECT_EQ(manifold->AmbientSize(), 7);
  EXPECT_EQ(manifold->TangentSize(), 6);
}

TEST(ReprojectionFactor, ZeroAtGroundTruthForAllKindsAndDirections) {
  std::mt19937 rng(11);
  double worst = 0.0;
  for (Kind kind : kKinds) {
    for (int i = 0; i < 200; ++i) {
      // Any anchor direction, behind the camera included (fisheye).
      const LandmarkCase s = CaseOfKind(kind, test::RandomUnit(&rng), 2.0 + 0.2 * i, &rng);
      for (Variant variant : kVariants)
        worst = std::max(worst, EvaluateFactor(MakeFactor(kind, s, variant)).norm());
      const Eigen::Vector2d plain = ReprojectionResidual(
          s.world_from_rig_anchor, s.world_from_rig_obs, s.rig_from_cam_anchor, s.rig_from_cam_obs,
          s.anchor_bearing, s.inverse_depth, s.observed_bearing, kSqrtInfo);
      worst = std::max(worst, plain.norm());
    }
  }
  std::printf("max |r| at ground truth: %.3g px\n", worst);
  EXPECT_LT(worst, 1e-9);
}

TEST(ReprojectionFactor, NormIsSqrtInformationTimesSineOfAngle) {
  std::mt19937 rng(12);
  for (Kind kind : kKinds) {
    for (double angle : {1e-4, 3e-3, 0.05}) {
      LandmarkCase s = CaseOfKind(kind, test::RandomUnit(&rng), 7.0, &rng);
      const Eigen::Vector3d truth = s.observed_bearing;
      const Eigen::Vector3d axis = truth.cross(test::RandomUnit(&rng)).normalized();
      s.observed_bearing = Eigen::AngleAxisd(angle, axis) * truth;
      const Factor f = MakeFactor(kind, s);
      EXPECT_NEAR(EvaluateFactor(f).norm(), kSqrtInfo * std::sin(angle), 1e-9 * kSqrtInfo);
    }
  }
}

TEST(ReprojectionFactor, CeresAgreesWithPlainResidualAwayFromTruth) {
  std::mt19937 rng(13);
  for (Kind kind : kKinds) {
    LandmarkCase s = CaseOfKind(kind, test::RandomUnit(&rng), 5.0, &rng);
    s.inverse_depth *= 1.3;
    s.rig_from_cam_obs.translation += Eigen::Vector3d(0.05, -0.02, 0.03);
    if (kind != Kind::kSameFrame) {
      s.world_from_rig_obs.rotation = test::RandomRotation(&rng, 0.05) * s.world_from_rig_obs.rotation;
    }
    const Eigen::Vector2d plain =
        ReprojectionResidual(s.world_from_rig_anchor, s.world_from_rig_obs, s.rig_from_cam_anchor,
                             kind == Kind::kSameCamera ? s.rig_from_cam_anchor : s.rig_from_cam_obs,
                             s.anchor_bearing, s.inverse_depth, s.observed_bearing, kSqrtInfo);
    EXPECT_GT(plain.norm(), 1.0);
    for (Variant variant : kVariants) {
      EXPECT_LT((EvaluateFactor(MakeFactor(kind, s, variant)) - plain).norm(), 1e-9 * plain.norm())
          << VariantName(variant);
    }
  }
}

// Autodiff Jacobians times the manifold's PlusJacobian against central
// differences of r(x [+] d), for every block, away from the truth.
double WorstJacobianError(Kind kind, const LandmarkCase& truth, std::mt19937* rng,
                          Variant variant = Variant::kAnalytic) {
  Factor f = MakeFactor(kind, truth, variant);
  std::unique_ptr<ceres::Manifold> pose_manifold(NewPoseManifold());
  // Move every block off the truth so the residual is not zero.
  for (size_t i = 0; i < f.params.size(); ++i) {
    if (f.is_pose[i]) {
      std::vector<double> delta(6);
      for (double& d : delta) d = std::uniform_real_distribution<double>(-0.05, 0.05)(*rng);
      std::vector<double> moved(kPoseParamSize);
      pose_manifold->Plus(f.params[i], delta.data(), moved.data());
      std::copy(moved.begin(), moved.end(), f.params[i]);
    } else {
      f.params[i][0] *= 1.2;
    }
  }
  double worst = 0.0, scale = 1.0;
  for (size_t i = 0; i < f.params.size(); ++i) {
    const ceres::Manifold* manifold = f.is_pose[i] ? pose_manifold.get() : nullptr;
    const Eigen::MatrixXd analytic =
        test::AnalyticTangentJacobian(*f.cost, f.params, static_cast<int>(i), manifold);
    const Eigen::MatrixXd numeric =
        test::NumericTangentJacobian(*f.cost, f.params, static_cast<int>(i), manifold, 1e-6);
    worst = std::max(worst, (analytic - numeric).cwiseAbs().maxCoeff());
    scale = std::max(scale, analytic.cwiseAbs().maxCoeff());
  }
  return worst / scale;
}

TEST(ReprojectionFactor, JacobiansMatchFiniteDifferencesInTangentSpace) {
  std::mt19937 rng(14);
  double worst = 0.0;
  for (Kind kind : kKinds) {
    for (Variant variant : kVariants) {
      for (int i = 0; i < 20; ++i) {
        worst = std::max(worst, WorstJacobianError(kind, CaseOfKind(kind, test::RandomUnit(&rng), 4.0, &rng),
                                                   &rng, variant));
      }
    }
  }
  std::printf("max relative Jacobian error: %.3g\n", worst);
  EXPECT_LT(worst, 1e-6);
}

TEST(ReprojectionFactor, FisheyeBearingsBeyond90Degrees) {
  std::mt19937 rng(15);
  // Anchor and observed bearings 95 .. 180 deg off the optical axis.
  const std::vector<Eigen::Vector3d> anchors = {Eigen::Vector3d(1.0, 0.0, -0.1).normalized(),
                                                Eigen::Vector3d(0.3, -0.4, -0.8).normalized(),
                                                -Eigen::Vector3d::UnitZ()};
  for (Kind kind : kKinds) {
    for (const Eigen::Vector3d& anchor : anchors) {
      const LandmarkCase s = CaseOfKind(kind, anchor, 6.0, &rng);
      const Factor f = MakeFactor(kind, s);
      EXPECT_LT(EvaluateFactor(f).norm(), 1e-9);
      for (Variant variant : kVariants) EXPECT_LT(WorstJacobianError(kind, s, &rng, variant), 1e-6);
      // An observation behind the observing camera, off by 0.01 rad.
      LandmarkCase off = s;
      off.observed_bearing =
          Eigen::AngleAxisd(0.01, s.observed_bearing.unitOrthogonal()) * s.observed_bearing;
      EXPECT_NEAR(EvaluateFactor(MakeFactor(kind, off)).norm(), kSqrtInfo * std::sin(0.01), 1e-9 * kSqrtInfo);
    }
  }
}

TEST(ReprojectionFactor, PointAtInfinityIsFinite) {
  std::mt19937 rng(16);
  LandmarkCase s = CaseOfKind(Kind::kOtherCamera, Eigen::Vector3d(0.1, 0.0, 1.0).normalized(), 1e9, &rng);
  s.inverse_depth = 0.0;
  const Factor f = MakeFactor(Kind::kOtherCamera, s);
  const Eigen::Vector2d r = EvaluateFactor(f);
  EXPECT_TRUE(r.allFinite());
  EXPECT_LT(r.norm(), 1e-6);  // a point 1e9 m away: only the rotations matter
  std::vector<double> jac_storage(2);
  double* jacobians[5] = {nullptr, nullptr, nullptr, nullptr, jac_storage.data()};
  Eigen::Vector2d r2;
  ASSERT_TRUE(f.cost->Evaluate(f.params.data(), r2.data(), jacobians));
  EXPECT_TRUE(Eigen::Vector2d(jac_storage[0], jac_storage[1]).allFinite());
}

// ---------------------------------------------------------------- analytic vs AutoDiff

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Residual and ambient Jacobians (every block) of a cost function.
struct Evaluation {
  Eigen::Vector2d residual;
  std::vector<RowMajor> jacobians;
};

Evaluation EvaluateWithJacobians(const ceres::CostFunction& cost, const std::vector<double*>& params) {
  Evaluation e;
  std::vector<double*> ptrs;
  for (size_t i = 0; i < params.size(); ++i) {
    e.jacobians.emplace_back(2, cost.parameter_block_sizes()[i]);
    e.jacobians.back().setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  for (RowMajor& j : e.jacobians) ptrs.push_back(j.data());
  EXPECT_TRUE(cost.Evaluate(params.data(), e.residual.data(), ptrs.data()));
  return e;
}

// A random configuration of `kind` off the truth: any rig and camera
// orientations, a landmark in any direction of the anchor camera (beyond 90
// deg included) at 0.3 .. 60 m or at infinity, an observed bearing off the
// truth by up to 0.5 rad or anywhere on the sphere.
LandmarkCase RandomCase(Kind kind, std::mt19937* rng) {
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  auto random_translation = [&](double scale) {
    return Eigen::Vector3d(scale * test::RandomUnit(rng) * uniform(*rng));
  };
  const Rigid3d world_from_rig_anchor(test::RandomRotation(rng, M_PI), random_translation(20.0));
  const Rigid3d anchor_from_obs(test::RandomRotation(rng, M_PI), random_translation(3.0));
  const Rigid3d rig_from_cam_anchor(test::RandomRotation(rng, M_PI), random_translation(1.5));
  const Rigid3d rig_from_cam_obs(test::RandomRotation(rng, M_PI), random_translation(1.5));
  const Rigid3d world_from_rig_obs =
      kind == Kind::kSameFrame ? world_from_rig_anchor : world_from_rig_anchor * anchor_from_obs;
  LandmarkCase s = MakeCase(world_from_rig_anchor, world_from_rig_obs, rig_from_cam_anchor,
                            kind == Kind::kSameCamera ? rig_from_cam_anchor : rig_from_cam_obs,
                            test::RandomUnit(rng), 0.3 + 60.0 * uniform(*rng));
  if (uniform(*rng) < 0.2) {
    s.observed_bearing = test::RandomUnit(rng);
  } else {
    const Eigen::Vector3d axis = s.observed_bearing.cross(test::RandomUnit(rng)).normalized();
    s.observed_bearing = Eigen::AngleAxisd(0.5 * uniform(*rng), axis) * s.observed_bearing;
  }
  if (uniform(*rng) < 0.1) s.inverse_depth = 0.0;
  return s;
}

// Largest difference between two Jacobians of a block relative to the
// largest entry of the reference.
double RelativeDifference(const RowMajor& a, const RowMajor& reference) {
  const double scale = std::max(reference.cwiseAbs().maxCoeff(), 1e-300);
  return (a - reference).cwiseAbs().maxCoeff() / scale;
}

TEST(ReprojectionFactor, AnalyticJacobiansMatchAutoDiff) {
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  double worst_residual = 0.0, worst_jacobian = 0.0;
  for (Kind kind : kKinds) {
    for (int i = 0; i < 2000; ++i) {
      const LandmarkCase s = RandomCase(kind, &rng);
      Factor analytic = MakeFactor(kind, s, Variant::kAnalytic);
      Factor autodiff = MakeFactor(kind, s, Variant::kAutoDiff);
      // Quaternions off the unit sphere by up to 1e-3 (the ambient Jacobian
      // of q * v is exact there too), on a quarter of the cases.
      if (i % 4 == 0) {
        for (size_t b = 0; b < analytic.params.size(); ++b) {
          if (!analytic.is_pose[b]) continue;
          const double factor = 1.0 + 1e-3 * (2.0 * uniform(rng) - 1.0);
          for (int k = 3; k < kPoseParamSize; ++k) {
            analytic.params[b][k] *= factor;
            autodiff.params[b][k] = analytic.params[b][k];
          }
        }
      }
      const Evaluation ea = EvaluateWithJacobians(*analytic.cost, analytic.params);
      const Evaluation ed = EvaluateWithJacobians(*autodiff.cost, autodiff.params);
      worst_residual =
          std::max(worst_residual, (ea.residual - ed.residual).norm() / std::max(ed.residual.norm(), 1e-3));
      for (size_t b = 0; b < ea.jacobians.size(); ++b) {
        ASSERT_TRUE(ea.jacobians[b].allFinite());
        worst_jacobian = std::max(worst_jacobian, RelativeDifference(ea.jacobians[b], ed.jacobians[b]));
      }
    }
  }
  std::printf("analytic vs autodiff: max relative residual difference %.3g, Jacobian %.3g\n", worst_residual,
              worst_jacobian);
  EXPECT_LT(worst_residual, 1e-9);
  EXPECT_LT(worst_jacobian, 1e-9);
}

TEST(WorldPointFactor, ZeroAtTruthAndAnalyticJacobiansMatchAutoDiff) {
  std::mt19937 rng(33);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  double worst_truth = 0.0, worst_residual = 0.0, worst_jacobian = 0.0;
  for (int i = 0; i < 2000; ++i) {
    const Rigid3d world_from_rig(test::RandomRotation(&rng, M_PI), 20.0 * uniform(rng) * test::RandomUnit(&rng));
    const Rigid3d cam_from_rig(test::RandomRotation(&rng, M_PI), 1.5 * uniform(rng) * test::RandomUnit(&rng));
    // A point in any direction of the camera (beyond 90 deg too), 0.3 .. 60 m.
    const Eigen::Vector3d in_cam = (0.3 + 60.0 * uniform(rng)) * test::RandomUnit(&rng);
    Eigen::Vector3d point = world_from_rig * (cam_from_rig.Inverse() * in_cam);
    double pose[kPoseParamSize];
    PoseToParams(world_from_rig, pose);
    std::vector<double*> params = {pose, point.data()};
    // At the truth the residual is zero.
    {
      std::unique_ptr<ceres::CostFunction> cost(NewWorldPointFactor(in_cam.normalized(), cam_from_rig, kSqrtInfo));
      Eigen::Vector2d r;
      ASSERT_TRUE(cost->Evaluate(params.data(), r.data(), nullptr));
      worst_truth = std::max(worst_truth, r.norm());
    }
    // Off the truth (observed bearing up to 0.5 rad away, the quaternion off
    // the unit sphere on a quarter of the cases): analytic = AutoDiff.
    const Eigen::Vector3d axis = in_cam.normalized().cross(test::RandomUnit(&rng)).normalized();
    const Eigen::Vector3d observed = Eigen::AngleAxisd(0.5 * uniform(rng), axis) * in_cam.normalized();
    if (i % 4 == 0) {
      const double factor = 1.0 + 1e-3 * (2.0 * uniform(rng) - 1.0);
      for (int k = 3; k < kPoseParamSize; ++k) pose[k] *= factor;
    }
    std::unique_ptr<ceres::CostFunction> analytic(NewWorldPointFactor(observed, cam_from_rig, kSqrtInfo));
    std::unique_ptr<ceres::CostFunction> autodiff(NewWorldPointFactorAutoDiff(observed, cam_from_rig, kSqrtInfo));
    const Evaluation ea = EvaluateWithJacobians(*analytic, params);
    const Evaluation ed = EvaluateWithJacobians(*autodiff, params);
    worst_residual = std::max(worst_residual, (ea.residual - ed.residual).norm() / std::max(ed.residual.norm(), 1e-3));
    for (size_t b = 0; b < ea.jacobians.size(); ++b) {
      ASSERT_TRUE(ea.jacobians[b].allFinite());
      worst_jacobian = std::max(worst_jacobian, RelativeDifference(ea.jacobians[b], ed.jacobians[b]));
    }
  }
  std::printf("world point factor: residual at truth %.3g; analytic vs autodiff: residual %.3g, Jacobian %.3g\n",
              worst_truth, worst_residual, worst_jacobian);
  EXPECT_LT(worst_truth, 1e-6);
  EXPECT_LT(worst_residual, 1e-9);
  EXPECT_LT(worst_jacobian, 1e-9);
}

// The extrinsic as a parameter block (refine.refine_extrinsics) gives the
// fixed-extrinsic factor's residual and, for the pose and the point, its
// Jacobians.
TEST(WorldPointFactor, ExtrinsicBlockMatchesTheFixedExtrinsic) {
  std::mt19937 rng(34);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  double worst_residual = 0.0, worst_jacobian = 0.0;
  for (int i = 0; i < 500; ++i) {
    const Rigid3d world_from_rig(test::RandomRotation(&rng, M_PI), 20.0 * uniform(rng) * test::RandomUnit(&rng));
    const Rigid3d cam_from_rig(test::RandomRotation(&rng, M_PI), 1.5 * uniform(rng) * test::RandomUnit(&rng));
    const Eigen::Vector3d in_cam = (0.3 + 60.0 * uniform(rng)) * test::RandomUnit(&rng);
    Eigen::Vector3d point = world_from_rig * (cam_from_rig.Inverse() * in_cam);
    const Eigen::Vector3d axis = in_cam.normalized().cross(test::RandomUnit(&rng)).normalized();
    const Eigen::Vector3d observed = Eigen::AngleAxisd(0.3 * uniform(rng), axis) * in_cam.normalized();
    double pose[kPoseParamSize], extrinsic[kPoseParamSize];
    PoseToParams(world_from_rig, pose);
    PoseToParams(cam_from_rig, extrinsic);
    std::unique_ptr<ceres::CostFunction> fixed(NewWorldPointFactor(observed, cam_from_rig, kSqrtInfo));
    std::unique_ptr<ceres::CostFunction> block(NewWorldPointExtrinsicFactor(observed, kSqrtInfo));
    const Evaluation ef = EvaluateWithJacobians(*fixed, {pose, point.data()});
    const Evaluation eb = EvaluateWithJacobians(*block, {pose, extrinsic, point.data()});
    ASSERT_EQ(eb.jacobians.size(), 3u);
    worst_residual = std::max(worst_residual, (ef.residual - eb.residual).norm() / std::max(ef.residual.norm(), 1e-3));
    worst_jacobian = std::max({worst_jacobian, RelativeDifference(ef.jacobians[0], eb.jacobians[0]),
                               RelativeDifference(ef.jacobians[1], eb.jacobians[2])});
    ASSERT_TRUE(eb.jacobians[1].allFinite());
    EXPECT_GT(eb.jacobians[1].norm(), 0.0);
  }
  EXPECT_LT(worst_residual, 1e-9);
  EXPECT_LT(worst_jacobian, 1e-9);
}

TEST(ReprojectionFactor, ConstExtrinsicsMatchExtrinsicBlocks) {
  // The constant-extrinsic variants against the AutoDiff factors with
  // extrinsic blocks: same residual, same Jacobians of the shared blocks.
  std::mt19937 rng(32);
  double worst_residual = 0.0, worst_jacobian = 0.0;
  for (Kind kind : kKinds) {
    for (int i = 0; i < 1000; ++i) {
      const LandmarkCase s = RandomCase(kind, &rng);
      const Factor fixed = MakeFactor(kind, s, Variant::kConstExtrinsics);
      const Factor reference = MakeFactor(kind, s, Variant::kAutoDiff);
      ASSERT_EQ(fixed.params.size(), kind == Kind::kSameFrame ? 1u : 3u);
      const Evaluation ef = EvaluateWithJacobians(*fixed.cost, fixed.params);
      const Evaluation er = EvaluateWithJacobians(*reference.cost, reference.params);
      worst_residual =
          std::max(worst_residual, (ef.residual - er.residual).norm() / std::max(er.residual.norm(), 1e-3));
      // Shared blocks: the poses (first two, unless same frame) and the inverse depth (last).
      if (kind != Kind::kSameFrame) {
        worst_jacobian = std::max(worst_jacobian, RelativeDifference(ef.jacobians[0], er.jacobians[0]));
        worst_jacobian = std::max(worst_jacobian, RelativeDifference(ef.jacobians[1], er.jacobians[1]));
      }
      worst_jacobian = std::max(worst_jacobian, RelativeDifference(ef.jacobians.back(), er.jacobians.back()));
    }
  }
  std::printf("const extrinsics vs extrinsic blocks: max relative residual difference %.3g, Jacobian %.3g\n",
              worst_residual, worst_jacobian);
  EXPECT_LT(worst_residual, 1e-9);
  EXPECT_LT(worst_jacobian, 1e-9);
}

TEST(ReprojectionFactor, NullJacobianBlocksAreSkipped) {
  // Ceres passes null for constant blocks: the others are unchanged.
  std::mt19937 rng(33);
  for (Kind kind : kKinds) {
    for (Variant variant : {Variant::kAnalytic, Variant::kConstExtrinsics}) {
      const Factor f = MakeFactor(kind, RandomCase(kind, &rng), variant);
      const Evaluation full = EvaluateWithJacobians(*f.cost, f.params);
      for (size_t skip = 0; skip < f.params.size(); ++skip) {
        Evaluation partial = full;
        std::vector<double*> ptrs;
        for (size_t b = 0; b < f.params.size(); ++b) {
          partial.jacobians[b].setZero();
          ptrs.push_back(b == skip ? nullptr : partial.jacobians[b].data());
        }
        Eigen::Vector2d r;
        ASSERT_TRUE(f.cost->Evaluate(f.params.data(), r.data(), ptrs.data()));
        EXPECT_EQ(r, full.residual);
        for (size_t b = 0; b < f.params.size(); ++b) {
          if (b != skip) {
            EXPECT_EQ(partial.jacobians[b], full.jacobians[b]) << VariantName(variant);
          }
        }
      }
    }
  }
}

// ---------------------------------------------------------------- small BA

struct BaObservation {
  int frame = 0, camera = 0;
  Eigen::Vector3d bearing;
};

struct BaResult {
  double translation_error_m = 0.0, rotation_error_rad = 0.0, rms_residual = 0.0, median_depth_error = 0.0;
  int num_residuals = 0, kinds[3] = {0, 0, 0};
  Rigid3d pose1;  // the estimate of frame 1
  std::vector<double> inverse_depths;
};

// Two rig poses, a front and a left-front camera (overlapping), landmarks
// anchored in their first observation; frame 0 and the extrinsics fixed.
BaResult RunSmallBa(double noise_px, uint32_t seed, Variant variant = Variant::kAnalytic) {
  std::mt19937 rng(seed);
  const std::vector<Rigid3d> rig_from_cam = {RigFromCam(0.0, Eigen::Vector3d(1.5, 0.0, -0.6)),
                                             RigFromCam(-50 * kDeg, Eigen::Vector3d(1.2, -0.6, -0.9))};
  const std::vector<Rigid3d> world_from_rig = {
      Rigid3d(Ypr(0.3, 0.02, -0.01), Eigen::Vector3d(10.0, 5.0, -1.0)),
      Rigid3d(Ypr(0.3 + 4 * kDeg, 0.01, 0.0),
              Eigen::Vector3d(10.0, 5.0, -1.0) + Ypr(0.3, 0, 0) * Eigen::Vector3d(1.5, 0.1, 0.0))};
  const double sigma = noise_px / 460.0;
  const double max_angle = 75 * kDeg;

  // Landmarks in front of and left of rig 0.
  std::vector<Eigen::Vector3d> points;
  std::uniform_real_distribution<double> azimuth(-75 * kDeg, 20 * kDeg), elevation(-20 * kDeg, 20 * kDeg),
      range(4.0, 30.0);
  while (points.size() < 200) {
    const double az = azimuth(rng), el = elevation(rng), d = range(rng);
    const Eigen::Vector3d in_rig =
        d * Eigen::Vector3d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), -std::sin(el));
    points.push_back(world_from_rig[0] * (Eigen::Vector3d(1.0, 0.0, -0.8) + in_rig));
  }

  // Storage at stable addresses.
  std::vector<std::array<double, kPoseParamSize>> poses(2), extrinsics(2);
  for (int f = 0; f < 2; ++f)
    PoseToParams(world_from_rig[static_cast<size_t>(f)], poses[static_cast<size_t>(f)].data());
  for (int c = 0; c < 2; ++c)
    PoseToParams(rig_from_cam[static_cast<size_t>(c)], extrinsics[static_cast<size_t>(c)].data());
  std::vector<double> inverse_depths;
  std::vector<double> true_inverse_depths;
  std::vector<std::vector<BaObservation>> tracks;
  for (const Eigen::Vector3d& p : points) {
    std::vector<BaObservation> track;
    for (int f = 0; f < 2; ++f) {
      for (int c = 0; c < 2; ++c) {
        const Eigen::Vector3d in_cam = rig_from_cam[static_cast<size_t>(c)].Inverse() *
                                       (world_from_rig[static_cast<size_t>(f)].Inverse() * p);
        if (std::acos(in_cam.normalized().z()) > max_angle) continue;
        track.push_back({f, c, test::NoisyBearing(in_cam.normalized(), sigma, &rng)});
      }
    }
    if (track.size() < 2) continue;
    const BaObservation& anchor = track.front();
    const Eigen::Vector3d in_anchor = rig_from_cam[static_cast<size_t>(anchor.camera)].Inverse() *
                                      (world_from_rig[static_cast<size_t>(anchor.frame)].Inverse() * p);
    true_inverse_depths.push_back(1.0 / in_anchor.norm());
    inverse_depths.push_back(true_inverse_depths.back() *
                             std::uniform_real_distribution<double>(0.7, 1.3)(rng));
    tracks.push_back(std::move(track));
  }

  // Perturb frame 1.
  const Rigid3d truth1 = world_from_rig[1];
  const Rigid3d start1(Eigen::Quaterniond(Ypr(2 * kDeg, -1 * kDeg, 1 * kDeg)) * truth1.rotation,
                       truth1.translation + Eigen::Vector3d(0.2, -0.15, 0.1));
  PoseToParams(start1, poses[1].data());

  ceres::Problem problem;
  BaResult result;
  for (size_t l = 0; l < tracks.size(); ++l) {
    const BaObservation& anchor = tracks[l].front();
    for (size_t o = 1; o < tracks[l].size(); ++o) {
      const BaObservation& ob = tracks[l][o];
      double* pose_a = poses[static_cast<size_t>(anchor.frame)].data();
      double* pose_o = poses[static_cast<size_t>(ob.frame)].data();
      double* ext_a = extrinsics[static_cast<size_t>(anchor.camera)].data();
      double* ext_o = extrinsics[static_cast<size_t>(ob.camera)].data();
      const Rigid3d& cam_a = rig_from_cam[static_cast<size_t>(anchor.camera)];
      const Rigid3d& cam_o = rig_from_cam[static_cast<size_t>(ob.camera)];
      const bool autodiff = variant == Variant::kAutoDiff;
      if (variant == Variant::kConstExtrinsics) {
        if (ob.frame == anchor.frame) {
          problem.AddResidualBlock(NewReprojectionFactorSameFrameConstExtrinsics(anchor.bearing, ob.bearing,
                                                                                 cam_a, cam_o, kSqrtInfo),
                                   nullptr, &inverse_depths[l]);
        } else if (ob.camera == anchor.camera) {
          problem.AddResidualBlock(
              NewReprojectionFactorSameCameraConstExtrinsics(anchor.bearing, ob.bearing, cam_a, kSqrtInfo),
              nullptr, pose_a, pose_o, &inverse_depths[l]);
        } else {
          problem.AddResidualBlock(NewReprojectionFactorOtherCameraConstExtrinsics(anchor.bearing, ob.bearing,
                                                                                   cam_a, cam_o, kSqrtInfo),
                                   nullptr, pose_a, pose_o, &inverse_depths[l]);
        }
      } else if (ob.frame == anchor.frame) {
        problem.AddResidualBlock(
            autodiff ? NewReprojectionFactorSameFrameAutoDiff(anchor.bearing, ob.bearing, kSqrtInfo)
                     : NewReprojectionFactorSameFrame(anchor.bearing, ob.bearing, kSqrtInfo),
            nullptr, ext_a, ext_o, &inverse_depths[l]);
      } else if (ob.camera == anchor.camera) {
        problem.AddResidualBlock(
            autodiff ? NewReprojectionFactorSameCameraAutoDiff(anchor.bearing, ob.bearing, kSqrtInfo)
                     : NewReprojectionFactorSameCamera(anchor.bearing, ob.bearing, kSqrtInfo),
            nullptr, pose_a, pose_o, ext_a, &inverse_depths[l]);
      } else {
        problem.AddResidualBlock(
            autodiff ? NewReprojectionFactorOtherCameraAutoDiff(anchor.bearing, ob.bearing, kSqrtInfo)
                     : NewReprojectionFactorOtherCamera(anchor.bearing, ob.bearing, kSqrtInfo),
            nullptr, pose_a, pose_o, ext_a, ext_o, &inverse_depths[l]);
      }
      ++result.kinds[ob.frame == anchor.frame ? 2 : ob.camera == anchor.camera ? 1 : 0];
      ++result.num_residuals;
    }
  }
  for (auto& pose : poses) problem.SetManifold(pose.data(), NewPoseManifold());
  for (auto& ext : extrinsics) {
    if (!problem.HasParameterBlock(ext.data())) continue;  // constant-extrinsic factors
    problem.SetManifold(ext.data(), NewPoseManifold());
    problem.SetParameterBlockConstant(ext.data());
  }
  problem.SetParameterBlockConstant(poses[0].data());  // gauge

  ceres::Solver::Options options = test::TightSolverOptions();
  options.linear_solver_type = ceres::DENSE_SCHUR;
  options.trust_region_strategy_type = ceres::DOGLEG;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  EXPECT_TRUE(summary.IsSolutionUsable()) << summary.BriefReport();

  const Rigid3d estimate1 = PoseFromParams(poses[1].data());
  result.translation_error_m = (estimate1.translation - truth1.translation).norm();
  result.rotation_error_rad = test::RotationAngle(estimate1.rotation, truth1.rotation);
  result.rms_residual = std::sqrt(2.0 * summary.final_cost / (2.0 * result.num_residuals));
  std::vector<double> depth_errors;
  for (size_t l = 0; l < inverse_depths.size(); ++l) {
    depth_errors.push_back(std::abs(true_inverse_depths[l] / inverse_depths[l] - 1.0));
  }
  std::nth_element(depth_errors.begin(), depth_errors.begin() + depth_errors.size() / 2, depth_errors.end());
  result.median_depth_error = depth_errors[depth_errors.size() / 2];
  result.pose1 = estimate1;
  result.inverse_depths = inverse_depths;
  return result;
}

TEST(SmallBundleAdjustment, NoiseFreeConvergesToTruth) {
  const BaResult r = RunSmallBa(0.0, 21);
  std::printf(
      "noise-free BA: %d residuals (other camera %d, same camera %d, same frame %d), |dt| %.3g m, "
      "|dR| %.3g rad, median depth error %.3g\n",
      r.num_residuals, r.kinds[0], r.kinds[1], r.kinds[2], r.translation_error_m, r.rotation_error_rad,
      r.median_depth_error);
  EXPECT_GT(r.kinds[0], 20);
  EXPECT_GT(r.kinds[1], 20);
  EXPECT_GT(r.kinds[2], 20);
  EXPECT_LT(r.translation_error_m, 1e-8);
  EXPECT_LT(r.rotation_error_rad, 1e-9);
  EXPECT_LT(r.median_depth_error, 1e-8);
}

TEST(SmallBundleAdjustment, HalfPixelNoiseConvergesNearTruth) {
  const BaResult r = RunSmallBa(0.5, 22);
  std::printf(
      "0.5 px BA: |dt| %.3g m, |dR| %.3g deg, median depth error %.3g, rms residual %.3f "
      "(noise floor below %.3f)\n",
      r.translation_error_m, r.rotation_error_rad / kDeg, r.median_depth_error, r.rms_residual,
      std::sqrt(2.0) * 0.5 / 1.5);
  EXPECT_LT(r.translation_error_m, 0.02);
  EXPECT_LT(r.rotation_error_rad, 0.05 * kDeg);
  EXPECT_LT(r.median_depth_error, 0.03);
  // Converged to the noise floor: 0.5 px noise at sqrt_information 460 / 1.5
  // gives 0.33 per component for the observation, and as much again from the
  // anchor bearing's noise, which no residual absorbs (the landmark lies on
  // the anchor ray): about 0.33 sqrt(2) = 0.47, less the estimated dof.
  EXPECT_GT(r.rms_residual, 0.35);
  EXPECT_LT(r.rms_residual, 0.55);
}

TEST(SmallBundleAdjustment, SameSolutionWithEveryFactorVariant) {
  // Analytic, AutoDiff and constant-extrinsic factors: the same estimate up
  // to rounding.
  const BaResult reference = RunSmallBa(0.5, 23, Variant::kAutoDiff);
  for (Variant variant : {Variant::kAnalytic, Variant::kConstExtrinsics}) {
    const BaResult r = RunSmallBa(0.5, 23, variant);
    double depth_difference = 0.0;
    ASSERT_EQ(r.inverse_depths.size(), reference.inverse_depths.size());
    for (size_t l = 0; l < r.inverse_depths.size(); ++l) {
      depth_difference =
          std::max(depth_difference, std::abs(r.inverse_depths[l] / reference.inverse_depths[l] - 1.0));
    }
    const double dt = (r.pose1.translation - reference.pose1.translation).norm();
    const double dr = test::RotationAngle(r.pose1.rotation, reference.pose1.rotation);
    std::printf("%s vs autodiff BA: |dt| %.3g m, |dR| %.3g rad, max relative inverse depth difference %.3g\n",
                VariantName(variant), dt, dr, depth_difference);
    EXPECT_LT(dt, 1e-9);
    EXPECT_LT(dr, 1e-9);
    EXPECT_LT(depth_difference, 1e-8);
  }
}

// The monocular scale gauge: zero at the anchored distance, (d - distance) /
// sigma away from it, its Jacobian the finite difference in translation and
// zero in rotation; a Ceres solve moves the pose onto the sphere, its
// rotation untouched.
TEST(DistanceAnchorCost, ResidualJacobianAndSolve) {
  const Eigen::Vector3d origin(1.0, -2.0, 0.5);
  std::unique_ptr<ceres::CostFunction> cost(NewDistanceAnchorCost(origin, 3.0, 0.01));
  std::array<double, kPoseParamSize> pose{};
  PoseToParams(Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY())),
                       origin + Eigen::Vector3d(2.0, 2.0, 1.5)),
               pose.data());
  double residual = 0.0;
  std::array<double, kPoseParamSize> jacobian{};
  const double* parameters[] = {pose.data()};
  double* jacobians[] = {jacobian.data()};
  ASSERT_TRUE(cost->Evaluate(parameters, &residual, jacobians));
  const double d = std::sqrt(2.0 * 2.0 + 2.0 * 2.0 + 1.5 * 1.5);
  EXPECT_NEAR(residual, (d - 3.0) / 0.01, 1e-9);
  for (int i = 0; i < kPoseParamSize; ++i) {
    std::array<double, kPoseParamSize> plus = pose, minus = pose;
    plus[i] += 1e-6;
    minus[i] -= 1e-6;
    double rp = 0.0, rm = 0.0;
    const double* pp[] = {plus.data()};
    const double* pm[] = {minus.data()};
    ASSERT_TRUE(cost->Evaluate(pp, &rp, nullptr));
    ASSERT_TRUE(cost->Evaluate(pm, &rm, nullptr));
    EXPECT_NEAR(jacobian[i], (rp - rm) / 2e-6, 1e-4) << "parameter " << i;
  }
  // Solve: the pose ends on the sphere of radius 3 (where on it is the
  // trust region's choice: one residual, three unknowns).
  std::unique_ptr<ceres::Manifold> manifold(NewPoseManifold());
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  problem.AddParameterBlock(pose.data(), kPoseParamSize, manifold.get());
  problem.AddResidualBlock(cost.get(), nullptr, pose.data());
  ceres::Solver::Options options;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  const Rigid3d solved = PoseFromParams(pose.data());
  EXPECT_NEAR((solved.translation - origin).norm(), 3.0, 1e-6);
  EXPECT_LT(solved.rotation.angularDistance(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()))),
            1e-12);
}

}  // namespace
}  // namespace mcvo

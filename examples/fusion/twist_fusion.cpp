#include "twist_fusion.h"

#include <Eigen/Geometry>

namespace pplvo::examples {

std::optional<BodyTwist> twistOf(const BodyOdometry& o) {
  if (!(o.dt_s > 0.0) || o.twist_covariance.diagonal().minCoeff() >= kUnknownTwistVariance) {
    return std::nullopt;
  }
  BodyTwist t;
  t.xi << o.linear_velocity, o.angular_velocity;
  t.covariance = o.twist_covariance;
  return t;
}

BodyTwist fuseTwists(const BodyTwist& a, const BodyTwist& b) {
  const Matrix6d info_a = a.covariance.inverse(), info_b = b.covariance.inverse();
  BodyTwist f;
  f.covariance = (info_a + info_b).inverse();
  f.covariance = 0.5 * (f.covariance + f.covariance.transpose());
  f.xi = f.covariance * (info_a * a.xi + info_b * b.xi);
  return f;
}

WheelErrorEstimator::WheelErrorEstimator(WheelErrorOptions options) : options_(options) {
  covariance_ = Eigen::Vector2d(options_.bias_sigma_rad_s * options_.bias_sigma_rad_s,
                                options_.scale_sigma * options_.scale_sigma)
                    .asDiagonal();
}

void WheelErrorEstimator::predict(double dt_s) {
  covariance_(0, 0) += options_.bias_walk_rad_s_per_sqrt_s * options_.bias_walk_rad_s_per_sqrt_s * dt_s;
  covariance_(1, 1) += options_.scale_walk_per_sqrt_s * options_.scale_walk_per_sqrt_s * dt_s;
}

BodyTwist WheelErrorEstimator::fuse(const BodyTwist& pplvo, const BodyTwist& wheels, double dt_s) {
  predict(dt_s);
  // Unknowns z = [xi (6); b; k], linearised at the wheels' reading: the wheels' model
  // h(z) = [(1 + k) vx, vy, vz, wx, wy, wz + b].
  using Vector8d = Eigen::Matrix<double, 8, 1>;
  using Matrix8d = Eigen::Matrix<double, 8, 8>;
  Vector8d z;
  z << pplvo.xi, state_;
  Matrix8d info = Matrix8d::Zero();
  Vector8d rhs = Vector8d::Zero();
  for (int iteration = 0; iteration < 2; ++iteration) {  // k multiplies vx: one more step
    info.setZero();
    rhs.setZero();
    // pplvo: xi directly.
    const Matrix6d info_v = pplvo.covariance.inverse();
    info.topLeftCorner<6, 6>() += info_v;
    rhs.head<6>() += info_v * (pplvo.xi - z.head<6>());
    // The wheels.
    Vector6d h = z.head<6>();
    h(0) *= 1.0 + z(7);
    h(5) += z(6);
    Eigen::Matrix<double, 6, 8> H = Eigen::Matrix<double, 6, 8>::Zero();
    H.leftCols<6>().setIdentity();
    H(0, 0) = 1.0 + z(7);
    H(0, 7) = z(0);
    H(5, 6) = 1.0;
    const Matrix6d info_w = wheels.covariance.inverse();
    info += H.transpose() * info_w * H;
    rhs += H.transpose() * info_w * (wheels.xi - h);
    // The prior on (b, k).
    const Eigen::Matrix2d info_p = covariance_.inverse();
    info.bottomRightCorner<2, 2>() += info_p;
    rhs.tail<2>() += info_p * (state_ - z.tail<2>());
    z += info.ldlt().solve(rhs);
  }
  const Matrix8d cov = info.inverse();
  state_ = z.tail<2>();
  covariance_ = cov.bottomRightCorner<2, 2>();
  BodyTwist out;
  out.xi = z.head<6>();
  out.covariance = cov.topLeftCorner<6, 6>();
  return out;
}

BodyTwist WheelErrorEstimator::correctWheels(const BodyTwist& wheels, double dt_s) {
  predict(dt_s);
  BodyTwist out = wheels;
  const double s = 1.0 + state_(1);
  out.xi(0) = wheels.xi(0) / s;
  out.xi(5) = wheels.xi(5) - state_(0);
  out.covariance(0, 0) = wheels.covariance(0, 0) / (s * s) +
                         out.xi(0) * out.xi(0) * covariance_(1, 1) / (s * s);
  out.covariance(5, 5) = wheels.covariance(5, 5) + covariance_(0, 0);
  return out;
}

void TwistFusionFilter::propagate(const BodyTwist& twist, double dt_s) {
  // The motion's covariance over [dt'; dtheta'] to first order: V(w dt) dt dv, dt dw.
  Matrix6d J = Matrix6d::Zero();
  J.topLeftCorner<3, 3>() = leftJacobianSO3(twist.xi.tail<3>() * dt_s) * dt_s;
  J.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * dt_s;
  chain_.compose(motionOfTwist(twist.xi, dt_s), J * twist.covariance * J.transpose());
}

}  // namespace pplvo::examples

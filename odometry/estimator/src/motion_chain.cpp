#include "pplvo/estimator/motion_chain.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <optional>

#include "pplvo/estimator/pose_parameterisation.h"

namespace pplvo::estimator {

namespace {
/// The directions of xi in which an estimate knows more than the prediction: eigenvectors
/// with eigenvalue above 1 of the estimate's information whitened by the prediction's
/// (diagonal) covariance. Elsewhere the prediction decides.
class DirectionsBetterThanPrediction {
 public:
  DirectionsBetterThanPrediction(const Matrix6d& information, const Matrix6d& prediction_covariance)
      : prediction_sqrt_(prediction_covariance.cwiseSqrt()),
        whitened_(prediction_sqrt_ * information * prediction_sqrt_) {}

  int count() const { return static_cast<int>((whitened_.eigenvalues().array() > 1.0).count()); }
  /// An offset of xi in the prediction's standard deviations.
  Vector6d whiten(const Vector6d& xi_offset) const {
    return prediction_sqrt_.inverse() * xi_offset;
  }
  const Matrix6d& predictionSqrt() const { return prediction_sqrt_; }
  /// Calls visit(lambda, v) for each direction v (whitened, unit) with its eigenvalue lambda.
  template <typename Visit>
  void forEach(Visit visit) const {
    for (int k = 0; k < 6; ++k) {
      const double lambda = whitened_.eigenvalues()(k);
      if (lambda > 1.0) visit(lambda, whitened_.eigenvectors().col(k));
    }
  }

 private:
  Matrix6d prediction_sqrt_;  // diagonal
  Eigen::SelfAdjointEigenSolver<Matrix6d> whitened_;
};

/// The process noise of a velocity-model step, over [t; q_xyz].
Matrix6d velocityModelCovariance(const MotionChainOptions& o) {
  Matrix6d Q = Matrix6d::Zero();
  Q.topLeftCorner<3, 3>().diagonal().setConstant(o.velocity_model_sigma_t_m *
                                                 o.velocity_model_sigma_t_m);
  Q.bottomRightCorner<3, 3>().diagonal().setConstant(o.velocity_model_sigma_q *
                                                     o.velocity_model_sigma_q);
  return Q;
}
}  // namespace

Matrix6d frameErrorCovariance(const FrameErrorSigma& sigma) {
  const double var_t = sigma.t_m * sigma.t_m;
  const double half_angle = 0.5 * sigma.rot_rad;  // q_xyz
  Matrix6d C = Matrix6d::Zero();
  C.topLeftCorner<3, 3>().diagonal().setConstant(2 * var_t);
  C.bottomRightCorner<3, 3>().diagonal().setConstant(2 * half_angle * half_angle);
  return C;
}

Matrix6d frameErrorCovariance(const MotionChainOptions& o) {
  return frameErrorCovariance(
      FrameErrorSigma{o.frame_error_sigma_t_m, o.frame_error_sigma_rot_deg * M_PI / 180.0});
}

MotionChain::MotionChain(MotionChainOptions options)
    : options_(std::move(options)),
      estimator_(options_.estimator),
      frame_error_(options_.frame_error_window, options_.frame_error_min_samples),
      published_frame_error_(options_.frame_error_window, options_.frame_error_min_samples) {}

FrameErrorSource MotionChain::sourceOf(const FrameErrorEstimator& estimator) const {
  // Each block online once it has its own samples; one that nothing measured keeps the
  // configured sigma.
  const bool online = options_.frame_error_online;
  return FrameErrorSource{online && estimator.translationReady(),
                          online && estimator.rotationReady()};
}

FrameErrorSigma MotionChain::sigmaOf(const FrameErrorEstimator& estimator) const {
  const FrameErrorSource source = sourceOf(estimator);
  return FrameErrorSigma{
      source.translation_online ? estimator.sigma().t_m : options_.frame_error_sigma_t_m,
      source.rotation_online ? estimator.sigma().rot_rad
                             : options_.frame_error_sigma_rot_deg * M_PI / 180.0};
}

MeasuredDirections MotionChain::directionsMeasuredBy(const PoseEstimate& est) const {
  if (est.accepted()) return MeasuredDirections::all();
  // A weak estimate, combined with the prediction, measured the directions in which the
  // combination is as certain as an accepted estimate must be, given the redundancy to tell a
  // wrong match (min_residuals); the prediction gave the rest.
  const PoseEstimatorOptions& o = options_.estimator;
  if (est.n_residuals < o.min_residuals) return MeasuredDirections::none();
  return MeasuredDirections{o.max_translation_variance_m2, o.max_rotation_variance};
}

MotionChainOutput MotionChain::initialise(int64_t seq, const Pose3& T_w_c0) {
  initialised_ = true;
  status_ = TrackingStatus::kFirstFrame;
  T_w_c_ = isValidPose(T_w_c0, 1e-6) ? T_w_c0 : Pose3::Identity();
  velocity_.setZero();
  velocity_measured_ = false;
  consecutive_rejections_ = 0;
  last_T_curr_prev_ = Pose3::Identity();
  last_cov_.setZero();
  last_published_cov_.setZero();
  window_.clear();
  frame_error_.addGap();  // a sensor property: what was learnt stays, the differences restart
  published_frame_error_.addGap();
  if (frame_utime_) intervals_.add(*frame_utime_);  // the stream's period stays too
  frame_utime_.reset();
  last_motion_periods_ = 1;
  WindowEntry self;
  self.seq = seq;
  window_.push_back(self);
  return makeOutput(seq);
}

int MotionChain::periodsToFrame() const {
  return frame_utime_ ? intervals_.periodsUntil(*frame_utime_) : 1;
}

Matrix6d MotionChain::processNoise() const {
  int64_t intervals = periodsToFrame();
  if (const std::optional<double> period = intervals_.period_s()) {
    intervals *=
        std::max<int64_t>(1, std::lround(*period / options_.velocity_model_frame_interval_s));
  }
  const double n = static_cast<double>(intervals);
  return (n * n * n) * velocityModelCovariance(options_);
}

Pose3 MotionChain::predictedMotion() const {
  if (!options_.predict_from_velocity) return Pose3::Identity();
  return decayedMotion(consecutive_rejections_);
}

Pose3 MotionChain::decayedMotion(int rejected_frames) const {
  const double d = options_.velocity_decay;
  double periods = 1.0;  // 1 + d + ... + d^(n-1) for n periods
  for (int k = 1, n = periodsToFrame(); k < n; ++k) periods += std::pow(d, k);
  return vectorToMotion((std::pow(d, rejected_frames) * periods) * velocity_);
}

MotionChainOutput MotionChain::track(int64_t seq, const Correspondences& correspondences,
                                     const PinholeCamera& camera) {
  if (!initialised_) return initialise(seq);
  const PoseEstimate est = estimator_.estimate(correspondences, camera, predictedMotion());
  if (const std::optional<MotionPrior> prior = priorForWeakEstimate(est)) {
    const PoseEstimate solved_with_prior =
        estimator_.estimate(correspondences, camera, prior->T_curr_prev, prior);
    return update(seq, est, std::nullopt, &solved_with_prior);
  }
  return update(seq, est);
}

MotionChainOutput MotionChain::track(const FrameFeatures& prev, const FrameFeatures& curr,
                                     const FeatureMatches& matches) {
  return track(curr.seq, buildCorrespondences(prev, curr, matches, options_.estimator),
               curr.camera);
}

std::optional<MotionPrior> MotionChain::priorForWeakEstimate(const PoseEstimate& est) const {
  if (!options_.fuse_weak_estimates || status_ == TrackingStatus::kLost) return std::nullopt;
  if (est.status != EstimateStatus::kUncertain && est.status != EstimateStatus::kDegenerate) {
    return std::nullopt;
  }
  if (!isValidPose(est.T_curr_prev, 1e-6) || !est.covariance.allFinite()) return std::nullopt;
  MotionPrior prior;
  prior.covariance = processNoise();
  // The constrained subset: the directions in which the estimate knows more than the
  // prediction. Fewer than half of them: the features say too little, the frame is the
  // velocity model's.
  const Eigen::LDLT<Matrix6d> est_ldlt(est.covariance);
  if (est_ldlt.info() != Eigen::Success) return std::nullopt;
  const DirectionsBetterThanPrediction measured(est_ldlt.solve(Matrix6d::Identity()),
                                                prior.covariance);
  if (measured.count() < 3) return std::nullopt;
  // Where the estimate knows little the prediction's mean decides: the constant velocity, or
  // what the velocity model would give this frame if it were rejected.
  prior.T_curr_prev = options_.decay_unconstrained_velocity && options_.predict_from_velocity
                          ? decayedMotion(consecutive_rejections_ + 1)
                          : predictedMotion();
  return prior;
}

std::optional<MotionChain::CombinedMotion> MotionChain::fuseWithPrediction(
    const PoseEstimate& est, const PoseEstimate* solved_with_prior) const {
  const std::optional<MotionPrior> prior = priorForWeakEstimate(est);
  if (!prior) return std::nullopt;
  const Matrix6d info_prior = prior->covariance.inverse();
  const Vector6d xi_prior = poseToXi(prior->T_curr_prev);
  CombinedMotion out;
  Matrix6d info_features;
  if (solved_with_prior != nullptr &&
      (solved_with_prior->status == EstimateStatus::kOk ||
       solved_with_prior->status == EstimateStatus::kUncertain ||
       solved_with_prior->status == EstimateStatus::kDegenerate) &&
      isValidPose(solved_with_prior->T_curr_prev, 1e-6) &&
      solved_with_prior->covariance.allFinite()) {
    out.T_curr_prev = solved_with_prior->T_curr_prev;
    out.covariance = solved_with_prior->covariance;
    if (options_.publish_measured_spread && solved_with_prior->covariance_at_measured_spread &&
        solved_with_prior->covariance_at_measured_spread->allFinite()) {
      out.published_covariance = *solved_with_prior->covariance_at_measured_spread;
    } else {
      out.published_covariance = out.covariance;
    }
    out.current_depth_sensitivity = solved_with_prior->current_depth_sensitivity;
    info_features = out.covariance.inverse() - info_prior;
    out.solved_with_prior = true;
  } else {
    out.agrees_with_prediction = agreesWithPrediction(est);
    // Information form over xi = [t; q_xyz] of T_curr_prev: the estimate where it has
    // information, the prediction (with the velocity model's process noise) elsewhere. Exact
    // for a linear problem; callers that can solve the features with the prior do (above).
    info_features = est.covariance.ldlt().solve(Matrix6d::Identity());
    out.covariance = (info_features + info_prior).inverse();
    out.covariance = 0.5 * (out.covariance + out.covariance.transpose());
    out.published_covariance = out.covariance;
    const Vector6d xi =
        out.covariance * (info_features * poseToXi(est.T_curr_prev) + info_prior * xi_prior);
    if (!xi.allFinite()) return std::nullopt;
    out.T_curr_prev = xiToPose(xi);
    out.current_depth_sensitivity = out.covariance * info_features * est.current_depth_sensitivity;
  }
  if (!out.covariance.allFinite() || !info_features.allFinite()) return std::nullopt;
  // The velocity model carries on only what the features measured: the shift from the
  // prediction along the directions where they know more than it (whitened eigenvalues above
  // 1, the constrained subset above). Elsewhere their information is thousands of times below
  // the prediction's and what moves the solution there is the model's slightest bias (the
  // corridor's lines and planes pull ~0.03 mm a frame backwards); the constant velocity would
  // integrate it into a walk the scene never showed.
  const DirectionsBetterThanPrediction measured(info_features, prior->covariance);
  const Vector6d whitened_shift = measured.whiten(poseToXi(out.T_curr_prev) - xi_prior);
  Matrix6d projector = Matrix6d::Zero();  // onto the measured whitened directions
  double measured_chi2 = 0.0;
  measured.forEach([&](double lambda, const auto& v) {
    projector += v * v.transpose();
    // The solve moved the prediction by d along v (whitened units): the features' own reading
    // is d (lambda + 1) / lambda from the prediction, with variance 1 / lambda + 1.
    const double d = v.dot(whitened_shift);
    measured_chi2 += d * d * (1.0 + 1.0 / lambda);
  });
  out.velocity_motion = xiToPose(xi_prior + measured.predictionSqrt() * projector * whitened_shift);
  if (out.solved_with_prior) {
    // The prediction gate, along the measured directions only (the features' solve alone
    // wanders along the others, 845 m along a door's edges, and its mean elsewhere with it),
    // of both solves: the features' own catches a jump the adaptive weights of the solve with
    // the prior would absorb (a plane whose residual disagrees weighs less), the solve with
    // the prior one the features' own hides in its excursion.
    out.agrees_with_prediction =
        agreesAlongMeasuredDirections(est) &&
        (!hasPredictionToGate() || measured_chi2 <= options_.prediction_gate_chi2);
  }
  return out;
}

bool MotionChain::agreesAlongMeasuredDirections(const PoseEstimate& est) const {
  if (!hasPredictionToGate()) return true;
  const Matrix6d prior = (1.0 + consecutive_rejections_) * processNoise();
  const Eigen::LDLT<Matrix6d> est_ldlt(est.covariance);
  if (est_ldlt.info() != Eigen::Success) return false;
  const DirectionsBetterThanPrediction measured(est_ldlt.solve(Matrix6d::Identity()), prior);
  const Vector6d whitened_innovation =
      measured.whiten(poseToXi(est.T_curr_prev) - poseToXi(predictedMotion()));
  double chi2 = 0.0;
  measured.forEach([&](double lambda, const auto& v) {
    const double along = v.dot(whitened_innovation);
    chi2 += along * along / (1.0 + 1.0 / lambda);  // the prediction's 1, the estimate's 1/lambda
  });
  return std::isfinite(chi2) && chi2 <= options_.prediction_gate_chi2;
}

bool MotionChain::agreesWithPrediction(const PoseEstimate& est) const {
  if (!hasPredictionToGate()) return true;
  if (!isValidPose(est.T_curr_prev, 1e-6) || !est.covariance.allFinite()) return true;  // not used
  // Each frame since the last measured motion adds the velocity model's process noise.
  const Matrix6d prior = (1.0 + consecutive_rejections_) * processNoise();
  const Vector6d innovation = poseToXi(est.T_curr_prev) - poseToXi(predictedMotion());
  const Eigen::LDLT<Matrix6d> joint(est.covariance + prior);
  return joint.info() == Eigen::Success &&
         innovation.dot(joint.solve(innovation)) <= options_.prediction_gate_chi2;
}

MotionChainOutput MotionChain::update(int64_t seq, const PoseEstimate& est,
                                      std::optional<int64_t> held_reference) {
  return update(seq, est, held_reference, nullptr);
}

MotionChainOutput MotionChain::update(int64_t seq, const PoseEstimate& est,
                                      std::optional<int64_t> held_reference,
                                      const PoseEstimate* solved_with_prior) {
  if (!initialised_) return initialise(seq);
  const int periods = periodsToFrame();
  const bool accepted =
      est.accepted() && isValidPose(est.T_curr_prev, 1e-6) && est.covariance.allFinite();
  const bool good = accepted && agreesWithPrediction(est);
  std::optional<CombinedMotion> fused =
      accepted ? std::nullopt : fuseWithPrediction(est, solved_with_prior);
  if ((accepted && !good) || (fused && !fused->agrees_with_prediction)) {
    ++gated_estimates_;
    fused.reset();
  }
  Pose3 T_curr_prev = Pose3::Identity();
  Matrix6d Q = Matrix6d::Zero();
  Matrix6d sensitivity = Matrix6d::Zero();
  if (good || fused) {
    status_ = (status_ == TrackingStatus::kLost) ? TrackingStatus::kReinitialised
                                                 : TrackingStatus::kTracking;
    consecutive_rejections_ = 0;
    T_curr_prev = good ? est.T_curr_prev : fused->T_curr_prev;
    Q = good ? est.covariance : fused->covariance;
    sensitivity = good ? est.current_depth_sensitivity : fused->current_depth_sensitivity;
    velocity_ = motionToVector(fused ? fused->velocity_motion : T_curr_prev);
    if (periods > 1) velocity_ /= periods;  // per period: the next frame may come after one
    velocity_measured_ = true;
    if (fused) ++fused_estimates_;
  } else {
    ++consecutive_rejections_;
    if (consecutive_rejections_ <= options_.max_velocity_model_frames) {
      status_ = TrackingStatus::kVelocityModel;
      T_curr_prev = decayedMotion(consecutive_rejections_);
      Q = processNoise();
    } else {
      status_ = TrackingStatus::kLost;
      velocity_.setZero();
      velocity_measured_ = false;
      T_curr_prev = Pose3::Identity();
      Q = kLargeVariance * Matrix6d::Identity();
    }
  }
  if (frame_utime_) intervals_.add(*frame_utime_);
  frame_utime_.reset();
  last_motion_periods_ = periods;
  // T_w_curr = T_w_prev * T_prev_curr.
  T_w_c_ = T_w_c_ * T_curr_prev.inverse();
  T_w_c_.linear() = Eigen::Quaterniond(T_w_c_.linear()).normalized().toRotationMatrix();
  last_T_curr_prev_ = T_curr_prev;
  last_cov_ = Q;
  last_published_cov_ = Q;
  if (good && options_.publish_measured_spread) {
    last_published_cov_ = est.covariance_at_measured_spread.value_or(Q);
  } else if (fused) {
    last_published_cov_ = fused->published_covariance;
  }
  // Only measured motions show the shared error; a predicted one would smooth it. A weak
  // estimate combined with the prediction shows it in the directions it measured. (A motion
  // over dropped frames is read too, its step against one-period neighbours with it:
  // docs/estimator.md, "Time between frames".)
  if (good || fused) {
    const MeasuredDirections measured = directionsMeasuredBy(est);
    frame_error_.addMeasuredMotion(T_curr_prev.inverse(), invertedPoseCovariance(T_curr_prev, Q),
                                   held_reference, measured);
    published_frame_error_.addMeasuredMotion(
        T_curr_prev.inverse(), invertedPoseCovariance(T_curr_prev, last_published_cov_),
        held_reference, measured);
  } else {
    frame_error_.addGap();
    published_frame_error_.addGap();
  }
  if (status_ == TrackingStatus::kLost) {
    window_.clear();  // nothing links older frames to this one
    WindowEntry self;
    self.seq = seq;
    window_.push_back(self);
  } else {
    propagateWindow(seq, T_curr_prev, Q);
  }
  MotionChainOutput out = makeOutput(seq);
  out.estimate = est;
  out.current_depth_sensitivity = sensitivity;
  return out;
}

void MotionChain::correctPose(const Pose3& T_w_c) {
  if (initialised_ && isValidPose(T_w_c, 1e-6)) T_w_c_ = T_w_c;
}

void MotionChain::propagateWindow(int64_t seq, const Pose3& T_curr_prev, const Matrix6d& Q) {
  // Every entry held T^(k|j) and Sigma^(k|j); the last one is the previous frame (identity).
  const double sigma_t = frameError().t_m;
  const double var_t = sigma_t * sigma_t;
  for (WindowEntry& e : window_) {
    e.covariance = propagateCompositionCovariance(e.T_curr_frame, e.covariance, T_curr_prev, Q);
    e.T_curr_frame = T_curr_prev * e.T_curr_frame;
    e.T_curr_frame.linear() =
        Eigen::Quaterniond(e.T_curr_frame.linear()).normalized().toRotationMatrix();
    // Isotropic, so it adds to the largest eigenvalue as it is; it does not accumulate
    // along the chain (each frame's own error enters once).
    e.max_translation_variance_m2 = maxTranslationVariance(e.covariance) + 2 * var_t;
  }
  WindowEntry self;
  self.seq = seq;
  window_.push_back(self);
  while (static_cast<int>(window_.size()) > std::max(1, options_.window_length)) {
    window_.pop_front();
  }
}

FramePose toFramePose(const MotionChainOutput& out) {
  FramePose p;
  p.seq = out.seq;
  p.status = out.status;
  p.T_w_c = out.T_w_c;
  p.T_prev_curr = out.T_prev_curr;
  p.rel_covariance = out.covariance_prev_curr;
  p.frame_error_covariance = out.frame_error_covariance;
  p.max_translation_variance_m2 = maxTranslationVariance(out.covariance_prev_curr);
  p.n_point_matches = out.estimate.n_points_used;
  p.n_line_matches = out.estimate.n_lines_used;
  p.n_plane_matches = out.estimate.n_planes_used;
  p.iterations = out.estimate.lm_iterations;
  p.final_cost = out.estimate.final_cost;
  for (const WindowEntry& e : out.window) {
    if (e.seq == out.seq) continue;  // the current frame itself
    p.window.push_back({e.seq, e.max_translation_variance_m2});
  }
  return p;
}

MotionChainOutput MotionChain::makeOutput(int64_t seq) const {
  MotionChainOutput out;
  out.seq = seq;
  out.status = status_;
  out.T_w_c = T_w_c_;
  out.T_curr_prev = last_T_curr_prev_;
  out.covariance = last_cov_;
  out.T_prev_curr = last_T_curr_prev_.inverse();
  out.covariance_prev_curr = invertedPoseCovariance(last_T_curr_prev_, last_published_cov_);
  out.frame_error = sigmaOf(published_frame_error_);
  out.frame_error_source = sourceOf(published_frame_error_);
  if (status_ != TrackingStatus::kFirstFrame) {
    out.frame_error_covariance = frameErrorCovariance(out.frame_error);
    out.covariance_prev_curr += out.frame_error_covariance;
  }
  out.max_translation_variance_m2 = maxTranslationVariance(last_cov_);
  out.consecutive_rejections = consecutive_rejections_;
  out.window.assign(window_.begin(), window_.end());
  return out;
}

}  // namespace pplvo::estimator

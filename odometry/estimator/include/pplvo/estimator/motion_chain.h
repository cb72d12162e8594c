#pragma once
/// Frame-to-frame tracking state: accumulates T_w_c, falls back to a decaying constant-velocity
/// model when an estimate is rejected (paper Sec. "Pose Uncertainty"), and propagates the
/// transform uncertainty from each frame of the depth-filter window to the current one
/// (EKF step, eq. 24).
#include <cstdint>
#include <deque>
#include <optional>
#include <utility>
#include <vector>

#include "pplvo/core/config_schema.h"
#include "pplvo/core/frame_pose.h"
#include "pplvo/core/geometry.h"
#include "pplvo/estimator/frame_error_estimator.h"
#include "pplvo/estimator/frame_intervals.h"
#include "pplvo/estimator/pose_estimator.h"

namespace pplvo::estimator {

// TrackingStatus (values equal the pose_t STATUS_* constants) and FramePose: core/frame_pose.h

struct MotionChainOptions {
  PoseEstimatorOptions estimator;
  /// Per-frame decay of the constant-velocity model while estimates are rejected: the k-th
  /// consecutive rejected frame moves by decay^k times the last good motion (on se(3)).
  double velocity_decay = 0.8;
  /// Consecutive rejections handled by the velocity model; the next one is kLost.
  int max_velocity_model_frames = 5;
  /// Start each estimate from the constant-velocity prediction (else from identity).
  bool predict_from_velocity = true;
  /// Frames kept in the uncertainty window, the current one included (paper: 10).
  int window_length = 10;
  /// Process noise Q (eq. 24) used for a velocity-model step: isotropic std of the
  /// translation (m) and of q_xyz (~half-angle, rad). Large, so that the depth filter's
  /// threshold drops frames linked to the current one through a guessed motion.
  double velocity_model_sigma_t_m = 0.02;
  double velocity_model_sigma_q = 0.01;
  /// The frame interval the per-frame values above (and the prediction gate's noise) are
  /// given for: a Kinect's 30 Hz. When the stamps (MotionChain::setFrameTime) show more time
  /// since the last frame, n of these intervals (n = the stream's period in them, rounded, times
  /// the whole periods since the last frame: a lower frame rate, a dataset played at every
  /// third frame, dropped frames), the process noise is that of n intervals: sigma n^1.5, the
  /// growth of a constant-velocity prediction's error under white acceleration. Rounding keeps
  /// stamp jitter out.
  double velocity_model_frame_interval_s = 1.0 / 30.0;
  /// A weak estimate (EstimateStatus kUncertain or kDegenerate: some directions unconstrained,
  /// e.g. translation along a plain corridor) is not thrown away: it is combined with the
  /// velocity model's prediction (the prediction with the process noise above as a prior of
  /// the features' solve; in information form for callers without the features), so the
  /// constrained directions come from the features and only the unconstrained ones from the
  /// velocity model, with the covariance to match; only when the estimate knows more than the
  /// prediction in at least half of the six directions. false: such an estimate is rejected
  /// as a whole (the velocity model, then LOST).
  bool fuse_weak_estimates = true;
  /// What a weak estimate's unconstrained directions take from the prediction. false: the
  /// constant-velocity motion (a vehicle's steady motion along a corridor keeps going). true:
  /// the velocity model's motion for a rejected frame, decayed by velocity_decay once more
  /// (a hand-held camera's motion does not persist: the velocity there fades over a few
  /// frames instead of carrying one frame's error on). Measured in docs/estimator.md,
  /// "Degenerate structure": a trade between the two kinds of motion, hence an option.
  bool decay_unconstrained_velocity = false;
  /// An estimate, accepted or weak, is used only if it agrees with the constant-velocity
  /// prediction: the Mahalanobis distance of their difference, with the sum of the estimate's
  /// covariance and the prediction's process noise (velocity_model_sigma_*, once more for
  /// every frame since the last measured motion), below this (chi-square, 6 dof; 22.46 = its
  /// 99.9 % quantile). Otherwise the frame is the velocity model's: a wrong solution (a weak
  /// one wandered off along the direction it does not constrain, a confident one on wrong
  /// associations) would otherwise become the velocity, which the next frames inherit.
  /// Not applied before a motion has been measured, or without predict_from_velocity.
  double prediction_gate_chi2 = 22.46;
  /// Per-frame shared error: each frame's pose carries an error common to all of its
  /// measurements (std per axis), which no number of matches averages away and which does
  /// not accumulate from frame to frame. A relative pose between two frames gains 2 Q, Q =
  /// diag(sigma_t^2 I, (sigma_rot / 2)^2 I) in [t; q_xyz]; so do the window's transforms
  /// (the depth filter's drop rule). The estimate and the keyframe rule do not use it.
  /// Estimated online from the roughness of the measured motions (FrameErrorEstimator) over
  /// the last `frame_error_window` of them, the translation and the rotation apart (a weak
  /// estimate combined with the prediction measures the directions it constrains); each block's
  /// sigma below is used until `frame_error_min_samples` of that block are in, and always
  /// when `frame_error_online` is false.
  bool frame_error_online = true;
  int frame_error_window = 60;
  int frame_error_min_samples = 10;
  /// Until the data has spoken (the first ~13 frames), err on the large side: above what
  /// Kinect-class cameras show (1-2 mm, 0.05-0.1 deg), so no early frame is over-confident.
  /// With frame_error_online false, set a camera's value, e.g. from `pplvo-eval
  /// --fit-frame-error` (scripts/fit_frame_error.sh), or 0 for exact rendered images.
  double frame_error_sigma_t_m = 0.003;
  double frame_error_sigma_rot_deg = 0.1;
  /// Publish an accepted estimate's covariance at its residuals' measured spread where that is
  /// below the model (PoseEstimate::covariance_at_measured_spread; of a weak estimate, that of
  /// its solve with the prediction as a prior), and read the shared error against it.
  /// Decisions (acceptance, gates, landmark fusion, the keyframe rule, the window) keep the
  /// model as their floor, so trajectories do not change with it.
  bool publish_measured_spread = true;
};

/// Schema of MotionChainOptions (pplvo/core/config_schema.h): names, docs and ranges, once.
template <class V>
void visit(V& v, MotionChainOptions& o) {
  v.section("estimator", "Pose estimation and its uncertainty (Sec. 4.6, eqs. 19-25)",
            [&] { visit(v, o.estimator); });
  v.field("velocity_decay", o.velocity_decay,
          "constant-velocity motion scaled by decay^k on the k-th rejected frame",
          config::between(0, 1));
  v.field("max_velocity_model_frames", o.max_velocity_model_frames,
          "consecutive rejected frames bridged by the velocity model, then LOST",
          config::atLeast(0));
  v.field("fuse_weak_estimates", o.fuse_weak_estimates,
          "combine an uncertain or degenerate estimate with the velocity model's prediction "
          "(solved once more with it as a prior) instead of rejecting it");
  v.field("decay_unconstrained_velocity", o.decay_unconstrained_velocity,
          "a weak estimate's unconstrained directions follow the decayed velocity model "
          "(hand-held) instead of the constant velocity (a vehicle)");
  v.field("prediction_gate_chi2", o.prediction_gate_chi2,
          "an estimate is used only if its Mahalanobis distance to the constant-velocity "
          "prediction (chi-square, 6 dof) is below this (22.46: the 99.9 % quantile)",
          config::atLeast(0));
  v.field("predict_from_velocity", o.predict_from_velocity,
          "start each estimate from the constant-velocity prediction (false: identity)");
  v.field("window_length", o.window_length,
          "frames whose transform uncertainty to the current one is propagated (eq. 24), "
          "current included (paper: 10, the depth fusion window)",
          config::atLeast(1));
  v.field("velocity_model_sigma_t_m", o.velocity_model_sigma_t_m,
          "process noise std of the translation of a velocity-model step (m)", config::atLeast(0));
  v.field("velocity_model_sigma_q", o.velocity_model_sigma_q,
          "process noise std of q_xyz of a velocity-model step (~half-angle, rad)",
          config::atLeast(0));
  v.field("velocity_model_frame_interval_s", o.velocity_model_frame_interval_s,
          "frame interval the velocity model's sigmas are given for (s); n such intervals "
          "since the last frame (stamps: lower rate, dropped frames) give sigma n^1.5",
          config::positive());
  v.field("frame_error_online", o.frame_error_online,
          "estimate the per-frame shared error online from the roughness of the measured "
          "motions (their second differences); false: the fixed sigmas below");
  v.field("frame_error_window", o.frame_error_window,
          "measured motion triples over which the shared error is estimated (frames)",
          config::atLeast(1));
  v.field("frame_error_min_samples", o.frame_error_min_samples,
          "triples needed before the online estimate replaces the fixed sigmas (each of "
          "translation and rotation apart)",
          config::atLeast(1));
  v.field("frame_error_sigma_t_m", o.frame_error_sigma_t_m,
          "per-frame pose error shared by all of a frame's measurements, translation std per "
          "axis (m), added as 2 Q to the published relative covariance and the window: the "
          "value before the online estimate is ready, or always when it is off "
          "(fit: scripts/fit_frame_error.sh)",
          config::atLeast(0));
  v.field("frame_error_sigma_rot_deg", o.frame_error_sigma_rot_deg,
          "the same, rotation std per axis (deg)", config::atLeast(0));
  v.field("publish_measured_spread", o.publish_measured_spread,
          "publish an estimate's covariance with its residuals' spread as measured "
          "where it is below the model (exact images); decisions keep the model as floor");
}

/// 2 Q of a relative pose between two frames that each carry a per-frame shared error of
/// `sigma`, as a covariance of xi = [t; q_xyz].
Matrix6d frameErrorCovariance(const FrameErrorSigma& sigma);
/// The same for the fixed sigmas of `o` (frame_error_sigma_*).
Matrix6d frameErrorCovariance(const MotionChainOptions& o);

/// One frame of the window: the transform from that frame to the current one.
struct WindowEntry {
  int64_t seq = -1;
  Pose3 T_curr_frame = Pose3::Identity();
  Matrix6d covariance = Matrix6d::Zero();  ///< of xi(T_curr_frame), eq. 24
  /// Of `covariance` plus the per-frame shared error of both frames (2 sigma_t^2).
  double max_translation_variance_m2 = 0;
};

struct MotionChainOutput {
  int64_t seq = -1;
  TrackingStatus status = TrackingStatus::kFirstFrame;
  Pose3 T_w_c = Pose3::Identity();         ///< world = first camera frame
  Pose3 T_curr_prev = Pose3::Identity();   ///< the motion applied this frame
  Matrix6d covariance = Matrix6d::Zero();  ///< of xi(T_curr_prev) (Q of eq. 24)
  /// The same motion as T_prev_curr (pose_t.rel_*) and the covariance of its xi, the
  /// per-frame shared error of both frames included (frameErrorCovariance).
  Pose3 T_prev_curr = Pose3::Identity();
  Matrix6d covariance_prev_curr = Matrix6d::Zero();
  /// The shared-error part of covariance_prev_curr (2 Q; zero for the first frame), the
  /// per-frame shared error it comes from, and which of its blocks are the online estimate
  /// (else the fixed sigmas of the options).
  Matrix6d frame_error_covariance = Matrix6d::Zero();
  FrameErrorSigma frame_error;
  FrameErrorSource frame_error_source;
  /// The part of covariance_prev_curr that is the error of the current frame's depth moved to
  /// its colour instant, as its planes carry it into the motion (added by the tracker, which
  /// knows the alignment; zero when the depth was not moved or the motion not measured).
  Matrix6d depth_alignment_covariance = Matrix6d::Zero();
  /// d xi(T_curr_prev) / d e of the motion applied for a rigid error e of the current frame's
  /// depth (PoseEstimate::current_depth_sensitivity, of the combination with the prediction
  /// for a weak estimate; zero on the velocity model).
  Matrix6d current_depth_sensitivity = Matrix6d::Zero();
  double max_translation_variance_m2 = 0;  ///< of `covariance`
  int consecutive_rejections = 0;
  /// Oldest first; the last entry is the current frame (identity, zero covariance).
  std::vector<WindowEntry> window;
  PoseEstimate estimate;  ///< the estimator's result for this frame (if one was run)
};

/// The published form (pose_t via FramePose): T_prev_curr and the covariance of its xi,
/// counts and iterations of the estimate, and the window entries older than the current frame
/// (oldest first). utime and stamp are left to the caller.
FramePose toFramePose(const MotionChainOutput& out);

class MotionChain {
 public:
  explicit MotionChain(MotionChainOptions options = {});
  const MotionChainOptions& options() const { return options_; }

  /// Starts (or restarts) tracking at frame `seq` with T_w_c = T_w_c0.
  MotionChainOutput initialise(int64_t seq, const Pose3& T_w_c0 = Pose3::Identity());

  /// The stamp (microseconds) of the frame that the next initialise(), track() or update()
  /// is for. The prediction and the velocity model's process noise then cover the stream's
  /// frame periods since the last frame (FrameIntervals); without stamps, one period each.
  void setFrameTime(int64_t utime_us) { frame_utime_ = utime_us; }
  /// Whole stream periods from the last frame to the one of setFrameTime() (1 if unknown).
  int periodsToFrame() const;
  /// Whole stream periods the last update() covered (1 without stamps).
  int lastMotionPeriods() const { return last_motion_periods_; }

  /// Prediction of T_curr_prev for the next frame (constant velocity, over periodsToFrame()).
  Pose3 predictedMotion() const;
  /// The velocity model's T_curr_prev after `rejected_frames` consecutive rejections:
  /// velocity_decay^rejected_frames times the last good motion per period; over several
  /// periods (dropped frames) each period after the first decays once more (a motion not
  /// measured fades, as over rejected frames; bounded however long the gap).
  Pose3 decayedMotion(int rejected_frames) const;

  /// Estimates the motion from the previous frame to `seq` and updates the state. The
  /// previous frame is the one of the last call (or initialise()). If not initialised yet,
  /// this initialises at `seq`.
  MotionChainOutput track(int64_t seq, const Correspondences& correspondences,
                          const PinholeCamera& camera);
  MotionChainOutput track(const FrameFeatures& prev, const FrameFeatures& curr,
                          const FeatureMatches& matches);

  /// The state machine alone, given an estimate (used by track(); public for tests and for
  /// callers that run the estimator themselves). `held_reference`: the frame (a keyframe) this
  /// estimate and the previous frame's were both measured against, if any: the motion is then
  /// the difference of two estimates, which the shared-error estimate reads differently
  /// (FrameErrorEstimator).
  MotionChainOutput update(int64_t seq, const PoseEstimate& estimate,
                           std::optional<int64_t> held_reference = std::nullopt);
  /// The prior a weak estimate of this frame is combined with (fuse_weak_estimates): the
  /// prediction (or the decayed motion, decay_unconstrained_velocity) with the velocity
  /// model's process noise; nullopt when `estimate` would not be combined (accepted,
  /// measuring fewer than three directions better than the prediction, lost). The combination
  /// is best solved from the features themselves with this prior (PoseEstimator::estimate):
  /// along the directions the features hardly see, a solve without it wanders metres off
  /// (reprojection errors shrink as the camera backs away from the scene), and that mean,
  /// however wide its covariance, biases the combination the same way frame after frame. The
  /// prediction gate then reads both solves along the directions the features measured.
  std::optional<MotionPrior> priorForWeakEstimate(const PoseEstimate& estimate) const;
  /// Weak estimates combined with the prediction so far (fuse_weak_estimates).
  int64_t fusedEstimates() const { return fused_estimates_; }
  /// Estimates (accepted or weak) refused by the prediction gate so far.
  int64_t gatedEstimates() const { return gated_estimates_; }

  /// Moves the current frame's world pose to `T_w_c` (a local map's adjustment of it) and
  /// nothing else: the velocity, the shared-error estimate and the window hold measured
  /// motions, which a correction of the world pose is not, so the next frame's motion is
  /// measured from the corrected pose without a jump in it.
  void correctPose(const Pose3& T_w_c);

  bool initialised() const { return initialised_; }
  TrackingStatus status() const { return status_; }
  const Pose3& T_w_c() const { return T_w_c_; }
  /// The per-frame shared error the decisions use (read against the motions' covariance at
  /// the model's floor): per block (translation, rotation) the online estimate when that
  /// block is ready, else the fixed sigma of the options.
  FrameErrorSigma frameError() const { return sigmaOf(frame_error_); }
  /// Which blocks of frameError() are the online estimate (on, and enough samples of that
  /// block in).
  FrameErrorSource frameErrorSource() const { return sourceOf(frame_error_); }

 private:
  /// The directions of xi an estimate measured: all when accepted; of a weak one combined
  /// with the prediction, those within the estimator's acceptance bounds.
  MeasuredDirections directionsMeasuredBy(const PoseEstimate& est) const;
  void propagateWindow(int64_t seq, const Pose3& T_curr_prev, const Matrix6d& Q);
  MotionChainOutput makeOutput(int64_t seq) const;

  MotionChainOptions options_;
  PoseEstimator estimator_;
  bool initialised_ = false;
  TrackingStatus status_ = TrackingStatus::kFirstFrame;
  Pose3 T_w_c_ = Pose3::Identity();
  Vector6d velocity_ = Vector6d::Zero();  ///< last good motion, [t; angle-axis] (tangent)
  int consecutive_rejections_ = 0;
  int64_t fused_estimates_ = 0;
  int64_t gated_estimates_ = 0;
  /// The velocity comes from a measured motion (not zero after a start or a loss).
  bool velocity_measured_ = false;
  /// The prediction is a measured velocity's (predict_from_velocity, not after a start or a
  /// loss): only such a prediction can refuse an estimate that disagrees with it.
  bool hasPredictionToGate() const { return velocity_measured_ && options_.predict_from_velocity; }
  /// Whether `est` agrees with the prediction (prediction_gate_chi2).
  bool agreesWithPrediction(const PoseEstimate& est) const;
  /// The same along the directions `est` measured better than the prediction only (a weak
  /// solve wanders along the others).
  bool agreesAlongMeasuredDirections(const PoseEstimate& est) const;
  /// A weak estimate combined with the prediction: the frame's motion and its covariance,
  /// and the motion the velocity model carries on (the prediction moved along the measured
  /// directions only).
  struct CombinedMotion {
    Pose3 T_curr_prev = Pose3::Identity();
    Matrix6d covariance = Matrix6d::Zero();
    /// What is published of it: the solve with the prior at its residuals' measured spread
    /// (publish_measured_spread), else `covariance`.
    Matrix6d published_covariance = Matrix6d::Zero();
    Pose3 velocity_motion = Pose3::Identity();
    bool solved_with_prior = false;  ///< else the information form of the two means
    /// d xi / d e of the combination for a rigid error e of the current depth (the estimate's
    /// current_depth_sensitivity, through the share the features have in the combination).
    Matrix6d current_depth_sensitivity = Matrix6d::Zero();
    /// The prediction gate (prediction_gate_chi2): of both solves along the directions the
    /// features measured, else of the estimate.
    bool agrees_with_prediction = true;
  };
  /// A weak estimate combined with the prediction (fuse_weak_estimates), or nullopt: the
  /// solve with the prior when given, else the information-form combination of the two means.
  std::optional<CombinedMotion> fuseWithPrediction(const PoseEstimate& est,
                                                   const PoseEstimate* solved_with_prior) const;
  /// update() with a weak estimate's second solve with priorForWeakEstimate(est)
  /// (`solved_with_prior`, track()): when the frame is combined with the prediction, that solve
  /// is the combination; null: the information form of the two means.
  MotionChainOutput update(int64_t seq, const PoseEstimate& est,
                           std::optional<int64_t> held_reference,
                           const PoseEstimate* solved_with_prior);
  Pose3 last_T_curr_prev_ = Pose3::Identity();
  Matrix6d last_cov_ = Matrix6d::Zero();
  /// The published covariance of the same motion: last_cov_, or at the measured spread of
  /// an accepted estimate or of a weak one's solve with the prior (publish_measured_spread);
  /// the published shared error (MotionChainOutput::frame_error) is read against it.
  Matrix6d last_published_cov_ = Matrix6d::Zero();
  std::deque<WindowEntry> window_;
  FrameErrorEstimator frame_error_;
  /// The shared error read against the published covariances (equal to frame_error_ when
  /// they are the model's).
  FrameErrorEstimator published_frame_error_;
  FrameErrorSigma sigmaOf(const FrameErrorEstimator& estimator) const;
  FrameErrorSource sourceOf(const FrameErrorEstimator& estimator) const;
  /// The velocity model's process noise for the coming frame: velocityModelCovariance times
  /// n^3 for n nominal intervals (velocity_model_frame_interval_s).
  Matrix6d processNoise() const;
  FrameIntervals intervals_;
  std::optional<int64_t> frame_utime_;  ///< of the frame the next update is for
  int last_motion_periods_ = 1;
};

}  // namespace pplvo::estimator

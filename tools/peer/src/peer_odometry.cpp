#include "pplvo/peer/peer_odometry.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/rgbd/depth.hpp>
#include <utility>

#include "pplvo/core/enum_names.h"
#include "pplvo/core/stage_timer.h"

namespace pplvo::peer {

namespace {
constexpr EnumName<PeerMethod> kPeerMethodNames[] = {
    {PeerMethod::kRgbd, "rgbd"}, {PeerMethod::kIcp, "icp"}, {PeerMethod::kRgbdIcp, "rgbd_icp"}};
constexpr EnumName<PeerStatus> kPeerStatusNames[] = {
    {PeerStatus::kFirst, "first"},        {PeerStatus::kOk, "ok"},
    {PeerStatus::kNoDepth, "no_depth"},   {PeerStatus::kNotConverged, "not_converged"},
    {PeerStatus::kBadInput, "bad_input"}, {PeerStatus::kOpenCvError, "opencv_error"}};
constexpr EnumName<ReferenceMode> kReferenceModeNames[] = {
    {ReferenceMode::kPreviousFrame, "previous_frame"}, {ReferenceMode::kKeyframe, "keyframe"}};
}  // namespace

const char* methodName(PeerMethod method) { return enumName(kPeerMethodNames, method); }

bool parseMethod(const std::string& text, PeerMethod* method) {
  return parseEnum(kPeerMethodNames, text, method);
}

const char* statusName(PeerStatus status) { return enumName(kPeerStatusNames, status); }

const char* referenceModeName(ReferenceMode mode) { return enumName(kReferenceModeNames, mode); }

PinholeCamera unmirroredCamera(const PinholeCamera& camera, int* flip_code) {
  PinholeCamera c = camera;
  const bool flip_x = camera.fx < 0;
  const bool flip_y = camera.fy < 0;
  if (flip_x) {
    c.fx = -camera.fx;
    c.cx = (camera.width - 1) - camera.cx;
  }
  if (flip_y) {
    c.fy = -camera.fy;
    c.cy = (camera.height - 1) - camera.cy;
  }
  if (flip_code) *flip_code = flip_x && flip_y ? -1 : flip_y ? 0 : flip_x ? 1 : 2;
  return c;
}

namespace {

/// Relative motion `T` raised to a real power `s` (s = frames elapsed), via angle-axis.
Pose3 scaledMotion(const Pose3& T, double s) {
  Pose3 out = Pose3::Identity();
  const Eigen::AngleAxisd aa(T.linear());
  out.linear() = Eigen::AngleAxisd(aa.angle() * s, aa.axis()).toRotationMatrix();
  out.translation() = T.translation() * s;
  return out;
}

Pose3 matToPose(const cv::Mat& Rt) {
  Eigen::Matrix4d M;
  cv::cv2eigen(Rt, M);
  Pose3 T = Pose3::Identity();
  T.linear() = M.topLeftCorner<3, 3>();
  T.translation() = M.topRightCorner<3, 1>();
  return T;
}

cv::Mat poseToMat(const Pose3& T) {
  cv::Mat Rt;
  const Eigen::Matrix4d M = T.matrix();
  cv::eigen2cv(M, Rt);
  return Rt;
}

}  // namespace

struct PeerOdometry::Impl {
  cv::Ptr<cv::rgbd::Odometry> odometry;
  PinholeCamera camera;  ///< the camera the odometry was built for (as given)
  int flip_code = 2;     ///< cv::flip code applied to the images, 2 = none

  bool has_reference = false;
  cv::Ptr<cv::rgbd::OdometryFrame> reference;  ///< keeps OpenCV's pyramids between frames
  int64_t reference_seq = -1;
  Pose3 T_w_ref = Pose3::Identity();
  int frames_since_reference = 0;  ///< frames processed since the reference (incl. failures)
  int consecutive_failures = 0;

  bool has_motion = false;
  Pose3 T_prev_curr = Pose3::Identity();  ///< last estimated motion per frame (T_{k-1}_k)
  Pose3 T_w_last = Pose3::Identity();     ///< pose output for the last frame

  // ReferenceMode::kKeyframe only; `reference` above is then the last tracked frame (the
  // fallback), which may be the keyframe itself.
  cv::Ptr<cv::rgbd::OdometryFrame> keyframe;
  int64_t keyframe_seq = -1;
  Pose3 T_w_kf = Pose3::Identity();
  Pose3 T_kf_ref = Pose3::Identity();  ///< the last tracked frame relative to the keyframe

  void build(const PeerOdometryOptions& o, const PinholeCamera& cam) {
    camera = cam;
    PinholeCamera used = cam;
    if (o.mirror_handling == MirrorHandling::kFlipImage) {
      used = unmirroredCamera(cam, &flip_code);
    } else {
      flip_code = 2;
    }
    cv::Mat K = (cv::Mat_<double>(3, 3) << used.fx, 0, used.cx, 0, used.fy, used.cy, 0, 0, 1);
    const std::vector<int> iters = o.iter_counts;
    const std::vector<float> grads = o.min_gradient_magnitudes;
    switch (o.method) {
      case PeerMethod::kRgbd: {
        auto odo = cv::rgbd::RgbdOdometry::create(
            K, o.min_depth_m, o.max_depth_m, o.max_depth_diff_m, iters, grads, o.max_points_part);
        odo->setMaxTranslation(o.max_translation_m);
        odo->setMaxRotation(o.max_rotation_deg);
        odometry = odo;
        break;
      }
      case PeerMethod::kIcp: {
        auto odo = cv::rgbd::ICPOdometry::create(K, o.min_depth_m, o.max_depth_m,
                                                 o.max_depth_diff_m, o.max_points_part, iters);
        odo->setMaxTranslation(o.max_translation_m);
        odo->setMaxRotation(o.max_rotation_deg);
        odometry = odo;
        break;
      }
      case PeerMethod::kRgbdIcp: {
        auto odo = cv::rgbd::RgbdICPOdometry::create(
            K, o.min_depth_m, o.max_depth_m, o.max_depth_diff_m, o.max_points_part, iters, grads);
        odo->setMaxTranslation(o.max_translation_m);
        odo->setMaxRotation(o.max_rotation_deg);
        odometry = odo;
        break;
      }
    }
  }

  void forgetReference() {
    has_reference = false;
    reference.release();
    reference_seq = -1;
    frames_since_reference = 0;
    consecutive_failures = 0;
    keyframe.release();
    keyframe_seq = -1;
  }

  /// Makes `frame` (tracked, or starting/restarting the sequence, at T_w_frame) the reference:
  /// the frame registered to next (kPreviousFrame), the fallback (kKeyframe).
  void setReference(const cv::Ptr<cv::rgbd::OdometryFrame>& frame, int64_t seq,
                    const Pose3& T_w_frame) {
    reference = frame;
    reference_seq = seq;
    T_w_ref = T_w_frame;
    frames_since_reference = 0;
    consecutive_failures = 0;
  }

  void setKeyframe(const cv::Ptr<cv::rgbd::OdometryFrame>& frame, int64_t seq,
                   const Pose3& T_w_frame, PeerStats* stats) {
    keyframe = frame;
    keyframe_seq = seq;
    T_w_kf = T_w_frame;
    T_kf_ref = Pose3::Identity();
    ++stats->keyframes;
  }

  /// OpenCV's registration of `target` to `source` from the initial guess T_source_target;
  /// returns T_source_target, or nothing (with r->status and r->message set) on failure.
  /// (OpenCV prepares the frames' pyramids in place, hence the non-const frames.)
  bool registerTo(cv::Ptr<cv::rgbd::OdometryFrame>& source,
                  cv::Ptr<cv::rgbd::OdometryFrame>& target, const Pose3& T_src_tgt_guess,
                  Pose3* T_src_tgt, PeerFrameResult* r) {
    // OpenCV's Rt maps source points into the target frame: Rt = T_tgt_src.
    cv::Mat Rt;
    if (!odometry->compute(source, target, Rt, poseToMat(T_src_tgt_guess.inverse()))) {
      r->status = PeerStatus::kNotConverged;
      r->message = "OpenCV odometry did not converge or the motion exceeded its limits";
      return false;
    }
    *T_src_tgt = matToPose(Rt).inverse();
    if (!T_src_tgt->matrix().allFinite()) {
      r->status = PeerStatus::kNotConverged;
      r->message = "non-finite motion";
      return false;
    }
    return true;
  }

  /// ReferenceMode::kKeyframe, a frame with enough depth: registers `current` to the keyframe
  /// and, if that fails, to the last tracked frame. True when either succeeded: r holds the
  /// pose and the state has moved on (keyframe switched if the rule says so). False: r holds
  /// the failure, the state is unchanged.
  bool trackAgainstKeyframe(const PeerOdometryOptions& o, cv::Ptr<cv::rgbd::OdometryFrame>& current,
                            int64_t seq, PeerFrameResult* r, PeerStats* stats) {
    const int steps = frames_since_reference + 1;
    // Motion expected since the last tracked frame (identity without the prior).
    const Pose3 T_ref_pred =
        o.use_motion_prior && has_motion ? scaledMotion(T_prev_curr, steps) : Pose3::Identity();
    Pose3 T_kf_c;
    if (registerTo(keyframe, current, T_kf_ref * T_ref_pred, &T_kf_c, r)) {
      // With the keyframe as the last tracked frame this is T_kf_c itself, so that zero
      // thresholds give exactly the frame-to-frame poses.
      const Pose3 T_ref_c = keyframe_seq == reference_seq ? T_kf_c : T_kf_ref.inverse() * T_kf_c;
      r->status = PeerStatus::kOk;
      r->message.clear();
      r->reference_seq = keyframe_seq;
      r->T_ref_c = T_kf_c;
      r->T_w_c = T_w_kf * T_kf_c;
      T_prev_curr = scaledMotion(T_ref_c, 1.0 / steps);
      has_motion = true;
      setReference(current, seq, r->T_w_c);
      T_kf_ref = T_kf_c;
      // The keyframe rule: the motion from the keyframe passes either threshold.
      if (T_kf_c.translation().norm() > o.keyframe_translation_m ||
          rotationAngle(T_kf_c.linear()) * 180.0 / M_PI > o.keyframe_rotation_deg) {
        setKeyframe(current, seq, r->T_w_c, stats);
        ++stats->keyframes_by_motion;
        r->new_keyframe = true;
      }
      return true;
    }
    if (reference_seq == keyframe_seq) return false;  // the fallback would repeat the same call
    Pose3 T_ref_c;
    if (!registerTo(reference, current, T_ref_pred, &T_ref_c, r)) {
      r->message = "keyframe and previous frame: " + r->message;
      return false;
    }
    r->status = PeerStatus::kOk;
    r->message.clear();
    r->reference_seq = reference_seq;
    r->T_ref_c = T_ref_c;
    r->T_w_c = T_w_ref * T_ref_c;
    r->fell_back = true;
    r->new_keyframe = true;
    T_prev_curr = scaledMotion(T_ref_c, 1.0 / steps);
    has_motion = true;
    setReference(current, seq, r->T_w_c);
    setKeyframe(current, seq, r->T_w_c, stats);
    ++stats->keyframe_fallbacks;
    return true;
  }

  /// The pose given to a frame that is not tracked: the last output, moved on by the last
  /// motion under FailurePolicy::kConstantVelocity.
  Pose3 predictedPose(const PeerOdometryOptions& o) const {
    if (!has_reference) return T_w_last;
    if (o.failure_policy == FailurePolicy::kConstantVelocity && has_motion)
      return T_w_last * T_prev_curr;
    return T_w_last;
  }

  /// Every result leaves through here: counts it into `stats` and, for a failure, gives it the
  /// predicted pose and ages the reference.
  PeerFrameResult finish(PeerFrameResult& res, double compute_ms, const PeerOdometryOptions& o,
                         PeerStats* stats) {
    res.compute_ms = compute_ms;
    ++stats->frames;
    stats->total_ms += res.compute_ms;
    stats->max_ms = std::max(stats->max_ms, res.compute_ms);
    switch (res.status) {
      case PeerStatus::kFirst:
        break;
      case PeerStatus::kOk:
        ++stats->tracked;
        break;
      case PeerStatus::kNoDepth:
        ++stats->no_depth;
        break;
      case PeerStatus::kNotConverged:
        ++stats->not_converged;
        break;
      case PeerStatus::kBadInput:
        ++stats->bad_input;
        break;
      case PeerStatus::kOpenCvError:
        ++stats->opencv_errors;
        break;
    }
    if (!res.ok()) {
      ++stats->failures;
      res.T_w_c = predictedPose(o);
      res.T_ref_c = Pose3::Identity();
      if (has_reference) {
        ++frames_since_reference;
        ++consecutive_failures;
      }
    }
    T_w_last = res.T_w_c;
    return res;
  }

  /// Grey image and metric depth as OpenCV expects them (CV_8UC1, CV_32FC1 metres), with the
  /// mask of valid depth, flipped for mirrored cameras.
  struct OdometryInput {
    cv::Mat grey, depth, valid;
  };
  OdometryInput prepareImages(const RgbdFrame& frame, const PeerOdometryOptions& o) const {
    OdometryInput in;
    if (frame.bgr.type() == CV_8UC3) {
      cv::cvtColor(frame.bgr, in.grey, cv::COLOR_BGR2GRAY);
    } else {
      in.grey = frame.bgr.clone();
    }
    in.depth = frame.depth_m.clone();
    // Valid depth: finite and inside (min, max); everything else becomes 0 (missing), and the
    // mask tells OpenCV the same.
    in.valid = (in.depth == in.depth) & (in.depth > o.min_depth_m) & (in.depth < o.max_depth_m);
    in.depth.setTo(0.0f, ~in.valid);
    if (flip_code != 2) {
      cv::flip(in.grey, in.grey, flip_code);
      cv::flip(in.depth, in.depth, flip_code);
      cv::flip(in.valid, in.valid, flip_code);
    }
    return in;
  }

  /// ReferenceMode::kFrameToFrame, a frame with enough depth: registers `current` to the
  /// reference from the motion prior. True: r holds the pose and the reference moved on to
  /// `current`. False: r holds the failure, the state is unchanged.
  bool trackAgainstReference(const PeerOdometryOptions& o,
                             cv::Ptr<cv::rgbd::OdometryFrame>& current, int64_t seq,
                             PeerFrameResult* r) {
    const int steps = frames_since_reference + 1;
    cv::Mat init;
    if (o.use_motion_prior && has_motion) {
      // OpenCV's Rt maps reference points into the current frame: Rt = T_c_ref.
      init = poseToMat(scaledMotion(T_prev_curr, steps).inverse());
    }
    cv::Mat Rt;
    bool ok = odometry->compute(reference, current, Rt, init);
    Pose3 T_ref_c = Pose3::Identity();
    if (ok) {
      const Pose3 T_c_ref = matToPose(Rt);
      T_ref_c = T_c_ref.inverse();
      if (!T_ref_c.matrix().allFinite()) {
        ok = false;
        r->status = PeerStatus::kNotConverged;
        r->message = "non-finite motion";
      }
    } else {
      r->status = PeerStatus::kNotConverged;
      r->message = "OpenCV odometry did not converge or the motion exceeded its limits";
    }
    if (!ok) return false;
    r->status = PeerStatus::kOk;
    r->T_ref_c = T_ref_c;
    r->T_w_c = T_w_ref * T_ref_c;
    T_prev_curr = scaledMotion(T_ref_c, 1.0 / steps);
    has_motion = true;
    setReference(current, seq, r->T_w_c);
    return true;
  }
};

PeerOdometry::PeerOdometry(const PeerOdometryOptions& options)
    : options_(options), impl_(std::make_unique<Impl>()) {}
PeerOdometry::~PeerOdometry() = default;
PeerOdometry::PeerOdometry(PeerOdometry&&) noexcept = default;
PeerOdometry& PeerOdometry::operator=(PeerOdometry&&) noexcept = default;

void PeerOdometry::reset() {
  impl_ = std::make_unique<Impl>();
  stats_ = PeerStats{};
}

namespace {

/// Checks the frame; returns an empty string when it can be used.
std::string checkFrame(const RgbdFrame& f) {
  if (!f.camera.valid()) return "invalid camera";
  if (f.bgr.empty()) return "empty colour image";
  if (f.depth_m.empty()) return "empty depth image";
  if (f.bgr.type() != CV_8UC3 && f.bgr.type() != CV_8UC1)
    return "colour image is not CV_8UC3/CV_8UC1";
  if (f.depth_m.type() != CV_32FC1) return "depth is not CV_32FC1 metres";
  if (f.bgr.size() != f.depth_m.size()) return "colour and depth sizes disagree";
  if (f.bgr.cols != f.camera.width || f.bgr.rows != f.camera.height)
    return "image size differs from the camera's";
  return {};
}

}  // namespace

PeerFrameResult PeerOdometry::process(const RgbdFrame& frame) {
  Stopwatch watch;
  Impl& s = *impl_;
  const PeerOdometryOptions& o = options_;
  PeerFrameResult r;
  auto finish = [&](PeerFrameResult& res) { return s.finish(res, watch.elapsedMs(), o, &stats_); };

  const std::string bad = checkFrame(frame);
  if (!bad.empty()) {
    r.status = PeerStatus::kBadInput;
    r.message = bad;
    r.reference_seq = s.reference_seq;
    return finish(r);
  }

  try {
    if (!s.odometry || frame.camera != s.camera) {
      // New camera: rebuild OpenCV's odometry; the old reference cannot be reused.
      const bool had_reference = s.has_reference;
      s.build(o, frame.camera);
      if (had_reference) {
        s.forgetReference();
        ++stats_.reference_resets;
      }
    }
    Impl::OdometryInput in = s.prepareImages(frame, o);
    r.valid_depth_pixels = cv::countNonZero(in.valid);
    const bool enough_depth = r.valid_depth_pixels >= o.min_valid_depth_pixels;
    auto current = cv::rgbd::OdometryFrame::create(in.grey, in.depth, in.valid, cv::Mat(),
                                                   static_cast<int>(frame.seq));

    // The first frame (or the first after a reset) becomes the reference.
    if (!s.has_reference) {
      if (!enough_depth) {
        r.status = PeerStatus::kNoDepth;
        r.message = "too few valid depth pixels for a first frame";
        return finish(r);
      }
      s.has_reference = true;
      s.setReference(current, frame.seq, stats_.frames == 0 ? Pose3::Identity() : s.T_w_last);
      if (o.reference_mode == ReferenceMode::kKeyframe) {
        s.setKeyframe(current, frame.seq, s.T_w_ref, &stats_);
        r.new_keyframe = true;
      }
      r.status = PeerStatus::kFirst;
      r.T_w_c = s.T_w_ref;
      r.reference_seq = frame.seq;
      return finish(r);
    }

    // Tracking against the keyframe or the reference.
    r.reference_seq =
        o.reference_mode == ReferenceMode::kKeyframe ? s.keyframe_seq : s.reference_seq;
    if (!enough_depth) {
      r.status = PeerStatus::kNoDepth;
      r.message = "too few valid depth pixels";
    } else if (o.reference_mode == ReferenceMode::kKeyframe) {
      if (s.trackAgainstKeyframe(o, current, frame.seq, &r, &stats_)) return finish(r);
    } else {
      if (s.trackAgainstReference(o, current, frame.seq, &r)) return finish(r);
    }
    // Failure: keep the reference unless it has failed too often.
    PeerFrameResult res = finish(r);
    if (s.consecutive_failures >= o.max_consecutive_failures && enough_depth) {
      s.setReference(current, frame.seq, res.T_w_c);
      if (o.reference_mode == ReferenceMode::kKeyframe) {
        s.setKeyframe(current, frame.seq, res.T_w_c, &stats_);
        res.new_keyframe = true;
      }
      ++stats_.reference_resets;
    }
    return res;
  } catch (const cv::Exception& e) {
    r.status = PeerStatus::kOpenCvError;
    r.message = e.what();
    r.reference_seq = s.reference_seq;
    return finish(r);
  }
}

}  // namespace pplvo::peer

#pragma once
/// Online estimate of the per-frame shared error: an error of each frame's pose common to all
/// of its measurements (time offsets, shutter, depth calibration, ...), which no per-measurement
/// model contains and which the frame's own residuals cannot show (it moves every measurement
/// of the frame alike, like a motion). What shows it is the trajectory's roughness: a camera's
/// motion is smooth over four frames, while a white error e_k of each frame enters the motion
/// into and out of frame k with opposite signs. The second difference of three consecutive
/// motions (the third difference of four poses),
///
///     d_k = m_k - 2 m_{k-1} + m_{k-2},   m_k = xi(T_prev_curr of frame k) as [t; rotation vector]
///         = (true jerk) + e_k - 3 e_{k-1} + 3 e_{k-2} - e_{k-3} + (estimation noise),
///
/// has per-axis variance 20 sigma^2 + (C_k + 4 C_{k-1} + C_{k-2}) / axis + (jerk dt^3)^2, with
/// C the motions' published covariance without any shared error, when each motion was
/// measured on its own (frame to frame: the estimation errors of consecutive motions are
/// independent). When the frames were each measured against one reference held over them (a
/// keyframe), a motion is the difference of two frames' estimates: their estimation errors
/// enter like the shared error (into and out of each frame, the reference's own error
/// cancelling), so no model of them can be taken off; the white per-frame error of every kind
/// then has variance W = E|d|^2 / 60 per axis, a motion's is 2 W, and sigma^2 = W - C / 2 makes
/// the published C + 2 sigma^2 equal to it. A hand-held camera's jerk
/// over 33 ms is far below the error (20 m/s^3: 0.7 mm against sqrt(20) * 2 mm = 9 mm); it
/// only ever biases sigma up. The variance is the mean square over a window of samples (a
/// covariance is a second moment: a median would read only the core of a heavy-tailed
/// error, and real frames have tails: blur, a poor frame), each sample clipped at 10 times the
/// median so that one wrong estimate cannot set it; the estimation noise (mean) is taken off,
/// the rest divided by 20. The same idea estimates the ground truth's jitter in pplvo-eval
/// (eval::estimateGtJitter). A true motion that is rough at the frame rate reads as shared
/// error (ICL-NUIM's trajectories: docs/estimator.md). The translation and the rotation are
/// read apart, each from the directions the motions measured: a weak estimate (a plain
/// corridor: planes and lines fix the rotation and the translation across it, nothing the
/// translation along it) still measures those. No LCM, deterministic, bounded memory.
#include <algorithm>
#include <cstdint>
#include <deque>
#include <limits>
#include <optional>

#include "pplvo/core/geometry.h"

namespace pplvo::estimator {

/// The directions of a motion's xi = [t; q_xyz] a measurement fixed: in each block, those
/// along which the motion's variance is at most the bound (m^2; q_xyz). An accepted estimate
/// fixed all of them; a weak one combined with a prediction those it constrains (the others
/// are the prediction's, smooth: they would read as no error).
struct MeasuredDirections {
  double translation_max_variance = std::numeric_limits<double>::infinity();
  double rotation_max_variance = std::numeric_limits<double>::infinity();
  static MeasuredDirections all() { return {}; }
  static MeasuredDirections none() { return {0.0, 0.0}; }
};

/// Where each block of the shared error in use comes from: the online estimate or the
/// configured sigma.
struct FrameErrorSource {
  bool translation_online = false;
  bool rotation_online = false;
  bool online() const { return translation_online && rotation_online; }
  /// "estimated online", "configured", or which block is which.
  const char* describe() const;
};

/// Per-axis standard deviation of the shared error of one frame.
struct FrameErrorSigma {
  double t_m = 0.0;      ///< translation (m)
  double rot_rad = 0.0;  ///< rotation angle about each axis (rad)
};

class FrameErrorEstimator {
 public:
  /// `window_samples`: second differences kept (the newest); `min_samples`: needed before
  /// ready(). Both at least 1.
  FrameErrorEstimator(int window_samples, int min_samples);

  /// The next frame's motion T_prev_curr, measured (an accepted estimate), with the
  /// covariance of its xi = [t; q_xyz] without any shared error. `held_reference`: the frame
  /// (a keyframe) this frame's and the previous frame's poses were both measured against, if
  /// any; a motion measured on its own has none. `measured`: the directions the measurement
  /// fixed; a block in which it fixed none is a gap for that block (below). A sample of three
  /// motions reads the directions all three measured.
  void addMeasuredMotion(const Pose3& T_prev_curr, const Matrix6d& covariance,
                         std::optional<int64_t> held_reference = std::nullopt,
                         MeasuredDirections measured = MeasuredDirections::all());
  /// The next frame had no measured motion (velocity model, lost, restarted): the
  /// differences of both blocks restart after it.
  void addGap();

  /// Enough samples of the translation / the rotation; ready(): of both.
  bool translationReady() const { return translation_.samples() >= min_samples_; }
  bool rotationReady() const { return rotation_.samples() >= min_samples_; }
  bool ready() const { return translationReady() && rotationReady(); }
  /// Second differences in the window, of the block with fewer.
  int samples() const { return std::min(translation_.samples(), rotation_.samples()); }
  /// The estimate from the samples in each block's window (zero for a block without any);
  /// computed once per sample.
  const FrameErrorSigma& sigma() const { return sigma_; }

 private:
  /// One block (translation or rotation vector) of a measured motion.
  struct BlockMotion {
    Eigen::Vector3d m = Eigen::Vector3d::Zero();
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    /// Directions with at most this variance were measured (infinite: all).
    double max_variance = std::numeric_limits<double>::infinity();
    std::optional<int64_t> held_reference;
  };
  /// The second differences of one block: its last three motions without a gap and its
  /// window of samples.
  class Block {
   public:
    /// Adds a motion; returns whether it made a new sample.
    bool add(const BlockMotion& motion, int window_samples);
    void gap() { motions_.clear(); }
    int samples() const { return static_cast<int>(samples_.size()); }
    /// The shared error's per-axis std read from the window (0 without samples).
    double sigma() const;

   private:
    struct Sample {
      double d_sq = 0;   ///< |d|^2
      double noise = 0;  ///< per-axis variance of d from the estimate's own C
    };
    std::deque<BlockMotion> motions_;  ///< at most 3
    std::deque<Sample> samples_;
  };

  int window_samples_;
  int min_samples_;
  Block translation_, rotation_;
  FrameErrorSigma sigma_;
};

}  // namespace pplvo::estimator

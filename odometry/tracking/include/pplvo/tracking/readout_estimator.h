#pragma once
/// The colour camera's rolling-shutter readout read from the frames, for cameras whose
/// calibration does not give it (docs/estimator.md, "The readout read from the frames").
///
/// A frame read over r seconds sees a point on row fraction rho (-1/2 top .. 1/2 bottom) at
/// rho r after its stamp, displaced by rho r p_dot (p_dot: the point's image velocity under the
/// camera's motion). Its reference was read the same way, so its lifted point carries its own
/// rho' r p_dot' (moved sideways at its depth). A frame and its reference, both as read (neither
/// moved to its stamp nor fused with other frames, which would mix other frames' shears in),
/// give point residuals e = r g + J xi + noise, g = rho p_dot - (the reference's displacement
/// seen from the frame): a least-squares fit of r with the 6 pose parameters (so that nothing the
/// pose can absorb is read as readout) is one frame's reading. A camera at rest reads nothing
/// (g = 0, no information); a global shutter reads 0 within its error. A line end's distance
/// to the observed line reads it the same way along the line's normal; points and lines are
/// each fitted with pose parameters of their own (their poses can disagree by more than their
/// noise, and one pose for both would read that disagreement as readout).
#include <Eigen/Core>
#include <cstdint>
#include <deque>
#include <optional>
#include <utility>
#include <vector>

#include "pplvo/core/features.h"
#include "pplvo/core/geometry.h"
#include "pplvo/tracking/rolling_shutter.h"

namespace pplvo::tracking {

/// One frame's reading of the readout and its variance.
struct ReadoutReading {
  double readout_s = 0;
  double variance_s2 = 0;
  int points = 0;  ///< the point matches it was read from
  int lines = 0;   ///< the line ends it was read from
};

/// The reading of `current` against `reference`, both as read, from their matched points and
/// lines (`matches`: reference index, current index; a line by its two ends' distances to the
/// observed line), the estimated pose T_curr_ref and each frame's velocity as it moved (camera
/// frame). Each family is read with its own pose and the two readings combined by information;
/// a family needs 12 points or 24 line ends inside its residuals' gate. nullopt when neither
/// has them or neither holds information on the readout (a camera at rest).
std::optional<ReadoutReading> readReadout(const FrameFeatures& reference,
                                          const FrameFeatures& current,
                                          const FeatureMatches& matches, const Pose3& T_curr_ref,
                                          const CameraVelocity& reference_velocity,
                                          const CameraVelocity& current_velocity);

/// The readings of the last frames (the store) and the estimate they give (the policy): their
/// information-weighted mean and its standard error. Readings against the same reference share
/// its landmarks' errors, so the error counts references, not frames: the larger of the
/// frames' error (widened by their scatter beyond their own variances) and the spread of the
/// references' means. The estimate is used once it stands clear of zero (a global shutter
/// never does), and from then on follows the mean.
class ReadoutEstimator {
 public:
  /// Readings kept (10 s at 30 Hz: long enough to average a hand's motion, short enough to
  /// follow a camera that changed its mode).
  static constexpr size_t kWindow = 300;
  /// Readings, and references they were read against, before an estimate is used.
  static constexpr int kMinReadings = 30;
  static constexpr int kMinReferences = 5;
  /// Standard errors above zero before an estimate is used: a global shutter reads 0 within
  /// its error and keeps its trajectories. Five, not three: the test is made again at every
  /// frame and the first crossing is kept, and a few references make a poor error estimate.
  static constexpr double kSignificance = 5.0;
  /// Longest readout taken (a 30 Hz sensor reads at most its period; 50 ms covers 20 Hz).
  static constexpr double kMaxReadoutS = 0.05;

  /// The reading of frame `seq` against the reference (keyframe) `reference_seq`.
  void add(int64_t seq, int64_t reference_seq, const ReadoutReading& reading);
  /// The readout to compensate with; nullopt while it is not known to be above zero.
  std::optional<double> readout_s() const { return adopted_; }
  double mean_s() const { return mean_s_; }
  double standardError_s() const { return standard_error_s_; }
  int readings() const { return static_cast<int>(readings_.size()); }
  /// References (runs of readings against one keyframe) among them.
  int references() const;
  void reset();

 private:
  struct Entry {
    int64_t seq, reference_seq;
    ReadoutReading reading;
  };
  std::deque<Entry> readings_;
  /// The standard error from the spread of the references' means; 0 with fewer than
  /// kMinReferences references.
  double referenceStandardError() const;
  double mean_s_ = 0, standard_error_s_ = 0;
  std::optional<double> adopted_;
};

}  // namespace pplvo::tracking

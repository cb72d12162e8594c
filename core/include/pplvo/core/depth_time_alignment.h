#pragma once
/// How a frame's depth was moved from its own capture instant to the colour image's.
#include <cstdint>

namespace pplvo {

/// The depth filter moves a frame's depth by `scale` times one measured motion: that of frame
/// `motion_seq` from frame `motion_seq - 1` (T_prev_curr, the estimator's published motion),
/// scale = (depth instant - colour instant) / that motion's interval. The motion's error
/// moves every depth value of the frame alike: its covariance scaled by scale^2 is the error of
/// the frame's depth as a rigid transform, which the estimator adds to what the frame's own
/// depth measured (docs/estimator.md, "The published covariance", part 5).
struct DepthTimeAlignment {
  double scale = 0.0;
  int64_t motion_seq = -1;  ///< -1: the depth was not moved

  bool moved() const { return motion_seq >= 0 && scale != 0.0; }
};

}  // namespace pplvo

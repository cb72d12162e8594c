#pragma once
/// The feature frontend as one object (paper Sec. "Extraction" to "WLS Line Fitting"): 2D
/// points and lines from the colour image plus planes from the C-GM depth as soon as a frame
/// arrives (stage 2D), then 3D lifting of those points and lines and a second plane extraction
/// on the fused depth once the frame's pose has come back through the depth filter (stage 3D).
/// No LCM: pplvo-frontend and the tests call the same code.
#include <memory>
#include <string>

#include "pplvo/core/features.h"
#include "pplvo/core/rgbd_frame.h"
#include "pplvo/core/stage_timer.h"
#include "pplvo/features/line_extractor.h"
#include "pplvo/features/point_extractor.h"
#include "pplvo/geometry/lifting.h"
#include "pplvo/geometry/plane_extraction.h"

namespace pplvo::pipeline {

/// Which primitive families are extracted and used (the paper's ablations).
struct FeatureFamilies {
  bool points = true;
  bool lines = true;
  bool planes = true;
};

/// Parses "points,lines,planes" (any subset, any order, at least one). Returns false and
/// leaves `out` untouched on an unknown or empty list.
bool parseFeatureFamilies(const std::string& text, FeatureFamilies* out);
std::string toString(const FeatureFamilies& families);

struct FrontendOptions {
  FeatureFamilies families;
  features::PointExtractorOptions points;
  features::LineExtractorOptions lines;
  geometry::PlaneExtractionOptions planes;
  geometry::LiftOptions lift;
  /// Stage 3D extracts the planes again on the fused depth (paper); false keeps the C-GM ones.
  bool planes_from_fused_depth = true;
  /// Lines on a second thread during points and planes (stage 2D), fused-depth planes during
  /// lifting (stage 3D). The results are the same either way.
  bool parallel = true;
};

/// What the frontend did with one frame (for counters and the run summary).
struct FrontendStats {
  int points = 0, lines = 0, planes = 0;
  int points_3d = 0, lines_3d = 0;
  std::string warning;  ///< non-empty when an input was unusable (e.g. depth size mismatch)
};

class Frontend {
 public:
  explicit Frontend(const FrontendOptions& options = {});

  /// Stage 2D. `image` is the frame's colour (BGR8) or grey image, `cgm` the C-GM depth of the
  /// same frame (may be empty: then no planes). Identity fields (seq, utime, stamp, camera)
  /// come from `frame`. Features carry undistorted pixel coordinates.
  FrameFeatures extract2d(const RgbdFrame& frame, const DepthWithVariance& cgm,
                          FrontendStats* stats = nullptr);

  /// Stage 3D: lifts the points and lines of `features` on `fused` and, if configured,
  /// replaces its planes by those of the fused depth. A fused map whose size disagrees with
  /// the camera leaves the features without 3D and says so in stats->warning.
  void lift3d(FrameFeatures& features, const DepthWithVariance& fused,
              FrontendStats* stats = nullptr);

  const FrontendOptions& options() const { return options_; }
  const StageTimings& timings() const { return timings_; }

 private:
  /// Planes of `depth` into `features` (no timing: may run on a second thread).
  void extractPlanes(FrameFeatures& features, const DepthWithVariance& depth, FrontendStats* stats);
  void extractPlanesTimed(FrameFeatures& features, const DepthWithVariance& depth,
                          FrontendStats* stats);

  FrontendOptions options_;
  features::PointExtractor point_extractor_;
  features::LineExtractor line_extractor_;
  std::unique_ptr<geometry::PlaneExtractor> plane_extractor_;  ///< sized on first use
  PinholeCamera plane_camera_;
  StageTimings timings_;
};

}  // namespace pplvo::pipeline

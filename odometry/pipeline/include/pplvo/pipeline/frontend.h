#pragma once
/// The feature frontend as one object (paper Sec. "Extraction" to "WLS Line Fitting"): 2D
/// points and lines from the colour image plus planes from the C-GM depth as soon as a frame
/// arrives (stage 2D), then 3D lifting of those points and lines and a second plane extraction
/// on the fused depth once the frame's pose has come back through the depth filter (stage 3D).
/// No LCM: pplvo-frontend and the tests call the same code.
#include <memory>
#include <mutex>
#include <string>

#include "pplvo/core/config_schema.h"
#include "pplvo/core/features.h"
#include "pplvo/core/frame_pose.h"
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
  /// ... but only for frames that later frames are tracked against (ReferenceRole): in
  /// keyframe mode a frame that is not a new keyframe keeps its C-GM planes, which only a
  /// fallback to it would use.
  bool fused_planes_only_for_references = true;
  /// Lines on a second thread during points and planes (stage 2D), fused-depth planes during
  /// lifting (stage 3D). The results are the same either way.
  bool parallel = true;
};

/// Schema of FrontendOptions (pplvo/core/config_schema.h): names, docs and ranges, once.
template <class V>
void visit(V& v, FrontendOptions& o) {
  v.section("points", "2D points (Sec. 4.1)", [&] { visit(v, o.points); });
  v.section("lines", "2D line segments: LSD + LBD (Sec. 4.1)", [&] { visit(v, o.lines); });
  v.section("planes",
            "Planes: CAPE-like cell segmentation of the organised point cloud (Sec. 4.1) and "
            "WLS fit",
            [&] { visit(v, o.planes); });
  v.section("lift", "3D lifting of points and lines (Sec. 4.2 point backprojection, 4.4 lines)",
            [&] { visit(v, o.lift); });
  v.field("planes_from_fused_depth", o.planes_from_fused_depth,
          "extract the planes again on the fused depth once the pose is known (Sec. 5.3: "
          "\"plane extraction must be called once more after the depth fusion\")");
  v.field("fused_planes_only_for_references", o.fused_planes_only_for_references,
          "only for frames that later frames are tracked against (new keyframes; every frame "
          "when tracking frame to frame): the others keep their C-GM planes, which only a "
          "keyframe fallback would use (pose_t.reference)");
  v.field("parallel", o.parallel,
          "lines on a second thread during points and planes, fused-depth planes during "
          "lifting (same results)");
}

/// What the frontend did with one frame (for counters and the run summary).
struct FrontendStats {
  int points = 0, lines = 0, planes = 0;
  int points_3d = 0, lines_3d = 0;
  std::string warning;  ///< non-empty when an input was unusable (e.g. depth size mismatch)
};

/// Feature frontend of one camera. extract2d() of one frame may run on another thread while
/// lift3d() of an earlier frame runs (each has its own plane extractor; the stage timings are
/// shared under a lock); two calls of the same stage must not overlap.
class Frontend {
 public:
  explicit Frontend(const FrontendOptions& options = {});

  /// Stage 2D. `image` is the frame's colour (BGR8) or grey image, `cgm` the C-GM depth of the
  /// same frame (may be empty: then no planes). Identity fields (seq, utime, stamp, camera)
  /// come from `frame`. Features carry undistorted pixel coordinates.
  FrameFeatures extract2d(const RgbdFrame& frame, const DepthWithVariance& cgm,
                          FrontendStats* stats = nullptr);

  /// Stage 3D: lifts the points and lines of `features` on `fused` and, if configured,
  /// replaces its planes by those of the fused depth (for a frame whose `role` is
  /// kFallbackOnly only when fused_planes_only_for_references is off). A fused map whose size
  /// disagrees with the camera leaves the features without 3D and says so in stats->warning.
  void lift3d(FrameFeatures& features, const DepthWithVariance& fused,
              FrontendStats* stats = nullptr, ReferenceRole role = ReferenceRole::kUnknown);

  const FrontendOptions& options() const { return options_; }
  /// A snapshot of the stage timings (both stages).
  StageTimings timings() const;

 private:
  /// A plane extractor holds buffers sized for one camera: rebuilt only when it changes.
  struct PlaneStage {
    std::unique_ptr<geometry::PlaneExtractor> extractor;
    PinholeCamera camera;
  };
  /// Planes of `depth` into `features` (no timing: may run on a second thread).
  void extractPlanes(PlaneStage& stage, FrameFeatures& features, const DepthWithVariance& depth,
                     FrontendStats* stats);
  void addTiming(const char* stage, double ms);

  FrontendOptions options_;
  features::PointExtractor point_extractor_;
  features::LineExtractor line_extractor_;
  PlaneStage planes_2d_;  ///< C-GM planes of stage 2D
  PlaneStage planes_3d_;  ///< fused-depth planes of stage 3D
  mutable std::mutex timings_mutex_;
  StageTimings timings_;
};

}  // namespace pplvo::pipeline

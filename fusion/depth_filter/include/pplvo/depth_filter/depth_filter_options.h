#pragma once
/// Every option of the probabilistic depth filter (paper section 3) in one struct, with its
/// schema: what the `depth_filter` section of config/pplvo.yaml holds, what pplvo-depth-filter
/// reads (alone: it links nothing of odometry/) and what the pipeline composes
/// (pplvo::pipeline::PipelineOptions::depth_filter). No LCM, no YAML.
#include <string>
#include <vector>

#include "pplvo/core/config_schema.h"
#include "pplvo/depth_filter/cgm_filter.h"
#include "pplvo/depth_filter/depth_model.h"
#include "pplvo/depth_filter/ogm_fusion.h"
#include "pplvo/depth_filter/sensor_model.h"

namespace pplvo::depth_filter {

/// Load shedding of the pplvo-depth-filter process when a live pipeline falls behind the
/// sensor (not in the paper): when a pose comes while more than `backlog` newer frames wait for
/// theirs, that frame is fused over a window `window_step` frames shorter per frame of backlog
/// beyond it (its own frame and the newest past ones; at least 2), instead of frames being
/// dropped further down. The pose -> O-GM -> lifting loop runs once per frame and O-GM is its
/// largest part, so a shorter window lets the loop catch up; the window keeps every frame for
/// later fusions. pplvo-run and lockstep launches never shed (backlog 0).
/// 2 because a pose comes about one frame period after its frame's features (not after the
/// previous frame's fusion and lifting as before O-GM left the pose loop): 2 newer frames then
/// mean what 3 meant before, the depth filter behind by about two frames, with the frontend's
/// queue of frames waiting for fused depth (5) not yet full (docs/depth_filter.md).
struct DepthFilterOverloadOptions {
  int backlog = 2;      ///< newer frames waiting for their pose beyond which the window shortens
  int window_step = 2;  ///< frames shorter per frame of backlog beyond that (at least 2 left)
};

struct DepthFilterOptions {
  /// sensor: stage 1 only; cgm: stages 1-2; ogm: all three (paper's full filter). With sensor
  /// or cgm the fused output is the stage-1/2 map, unchanged.
  DepthModel model = DepthModel::kOgm;
  QuadraticSensorModel::Options sensor;  ///< sigma_z = coeff z^2 (paper eq. 1)
  CgmOptions cgm;
  OgmOptions ogm;
  DepthFilterOverloadOptions overload;
  /// Move depth captured at another instant than colour to the colour instant
  /// (depth_time_alignment.h); a no-op for sensors that capture both at once.
  bool time_alignment = true;
};

/// Schema of DepthFilterOverloadOptions (pplvo/core/config_schema.h).
template <class V>
void visit(V& v, DepthFilterOverloadOptions& o) {
  v.field("backlog", o.backlog,
          "when a pose comes while more than this many newer frames wait for theirs, the "
          "frame is fused over a shorter window (0 = never)",
          config::atLeast(0));
  v.field("window_step", o.window_step,
          "frames the window shortens per frame of backlog beyond that, down to 2",
          config::atLeast(1));
}

/// Schema of DepthFilterOptions (pplvo/core/config_schema.h).
template <class V>
void visit(V& v, DepthFilterOptions& o) {
  v.field("model", o.model,
          "depth used downstream: sensor (stage 1, Sec. 3.1), cgm (stages 1-2, Sec. 3.2) or "
          "ogm (all three, Sec. 3.3-3.4; the paper's full method)");
  v.field("time_alignment", o.time_alignment,
          "move depth captured at another instant than colour (rgbd_frame_t.depth_utime) to "
          "the colour instant with the camera's velocity (free-running sensors such as Kinect "
          "v1); no effect when both instants are the same");
  v.section("sensor", "Stage 1: depth sensor error model (Sec. 3.1, eq. 1)",
            [&] { visit(v, o.sensor); });
  v.section("cgm", "Stage 2: convolution of Gaussian mixtures, 3x3 kernel (Sec. 3.2, eqs. 2-6)",
            [&] { visit(v, o.cgm); });
  v.section("ogm",
            "Stage 3: Optimal-GM temporal fusion and its constraints (Sec. 3.3-3.4, eqs. 7-8)",
            [&] { visit(v, o.ogm); });
  v.section("overload",
            "Load shedding of pplvo-depth-filter when a live pipeline falls behind the sensor "
            "(not in the paper; pplvo-run and lockstep launches never shed, docs/depth_filter.md)",
            [&] { visit(v, o.overload); });
}

/// Key and documentation of the depth filter's section in the configuration file.
inline constexpr const char* kConfigSection = "depth_filter";
inline constexpr const char* kConfigSectionDoc =
    "Probabilistic depth filter (paper Sec. 3): sensor model, C-GM, O-GM fusion";

/// The depth filter's section of the configuration file (the file's other sections belong to
/// other modules).
template <class V>
void visitConfigFile(V& v, DepthFilterOptions& o) {
  v.section(kConfigSection, kConfigSectionDoc, [&] { visit(v, o); });
}

/// Command-line shortcuts of depth filter keys (pplvo-depth-filter and every program that runs
/// the pipeline): the same parsing and range as the key.
inline std::vector<config::Shortcut> depthModelShortcut() {
  return {{"--depth-model", "depth_filter.model", "MODEL  sensor | cgm | ogm (default ogm)"}};
}

}  // namespace pplvo::depth_filter

namespace pplvo::config {
template <>
struct EnumText<depth_filter::DepthModel> {
  static bool parse(const std::string& s, depth_filter::DepthModel* out) {
    return depth_filter::parseDepthModel(s, out);
  }
  static std::string name(depth_filter::DepthModel m) { return depth_filter::toString(m); }
  static const char* choices() { return "sensor, cgm, ogm"; }
};
}  // namespace pplvo::config

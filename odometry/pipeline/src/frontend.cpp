#include "pplvo/pipeline/frontend.h"

#include <future>
#include <opencv2/imgproc.hpp>
#include <sstream>

namespace pplvo::pipeline {

bool parseFeatureFamilies(const std::string& text, FeatureFamilies* out) {
  FeatureFamilies f{false, false, false};
  std::stringstream ss(text);
  std::string item;
  bool any = false;
  while (std::getline(ss, item, ',')) {
    if (item == "points")
      f.points = true;
    else if (item == "lines")
      f.lines = true;
    else if (item == "planes")
      f.planes = true;
    else if (item == "all")
      f = {true, true, true};
    else
      return false;
    any = true;
  }
  if (!any) return false;
  *out = f;
  return true;
}

std::string toString(const FeatureFamilies& f) {
  std::string s;
  auto add = [&](bool on, const char* name) {
    if (!on) return;
    if (!s.empty()) s += ',';
    s += name;
  };
  add(f.points, "points");
  add(f.lines, "lines");
  add(f.planes, "planes");
  return s.empty() ? "none" : s;
}

Frontend::Frontend(const FrontendOptions& options)
    : options_(options), point_extractor_(options.points), line_extractor_(options.lines) {}

FrameFeatures Frontend::extract2d(const RgbdFrame& frame, const DepthWithVariance& cgm,
                                  FrontendStats* stats) {
  FrontendStats local;
  FrontendStats& s = stats ? *stats : local;
  s = FrontendStats{};
  FrameFeatures f;
  f.seq = frame.seq;
  f.utime = frame.utime;
  f.stamp = frame.stamp;
  f.camera = frame.camera;
  f.depth_time_alignment = cgm.time_alignment;
  if (frame.bgr.empty()) {
    s.warning = "frame without colour image: no points or lines";
    if (options_.families.planes && !cgm.depth_m.empty()) {
      Stopwatch w;
      extractPlanes(planes_2d_, f, cgm, &s);
      addTiming("planes", w.elapsedMs());
    }
  } else {
    // Both extractors work on grey: convert once.
    cv::Mat gray;
    if (frame.bgr.channels() == 3)
      cv::cvtColor(frame.bgr, gray, cv::COLOR_BGR2GRAY);
    else if (frame.bgr.channels() == 4)
      cv::cvtColor(frame.bgr, gray, cv::COLOR_BGRA2GRAY);
    else
      gray = frame.bgr;
    // Lines and planes run on threads of their own while points run here (the OS packs the
    // three onto the cores); each part writes its own members, and the results do not depend
    // on the threading. Timings are recorded after the joins (one writer).
    FrameFeatures side;
    side.camera = frame.camera;
    double lines_ms = 0, planes_ms = 0;
    features::LineExtractionStats ls;
    FrontendStats plane_stats;
    const bool planes = options_.families.planes && !cgm.depth_m.empty();
    auto linesJob = [&] {
      Stopwatch w;
      ls = line_extractor_.extractInto(gray, frame.camera, side);
      lines_ms = w.elapsedMs();
    };
    FrameFeatures plane_part;
    plane_part.camera = frame.camera;
    auto planesJob = [&] {
      Stopwatch w;
      extractPlanes(planes_2d_, plane_part, cgm, &plane_stats);
      planes_ms = w.elapsedMs();
    };
    std::future<void> lines_job, planes_job;
    if (options_.families.lines) {
      if (options_.parallel)
        lines_job = std::async(std::launch::async, linesJob);
      else
        linesJob();
    }
    if (planes) {
      if (options_.parallel)
        planes_job = std::async(std::launch::async, planesJob);
      else
        planesJob();
    }
    if (options_.families.points) {
      Stopwatch w;
      const auto ps = point_extractor_.extractInto(gray, frame.camera, f);
      addTiming("points", w.elapsedMs());
      if (!ps.error.empty()) s.warning = "points: " + ps.error;
    }
    if (lines_job.valid()) lines_job.get();
    if (planes_job.valid()) planes_job.get();
    if (options_.families.lines) {
      addTiming("lines", lines_ms);
      if (!ls.error.empty()) s.warning = "lines: " + ls.error;
      f.lines = std::move(side.lines);
      f.line_descriptors = side.line_descriptors;
    }
    if (planes) {
      addTiming("planes", planes_ms);
      if (!plane_stats.warning.empty()) s.warning = plane_stats.warning;
      f.planes = std::move(plane_part.planes);
      f.plane_labels = plane_part.plane_labels;
    }
  }
  s.points = static_cast<int>(f.points.size());
  s.lines = static_cast<int>(f.lines.size());
  s.planes = static_cast<int>(f.planes.size());
  return f;
}

void Frontend::lift3d(FrameFeatures& features, const DepthWithVariance& fused,
                      FrontendStats* stats, ReferenceRole role) {
  FrontendStats local;
  FrontendStats& s = stats ? *stats : local;
  const std::string invalid = geometry::validateDepth(fused, features.camera);
  if (!invalid.empty()) {
    s.warning = "fused depth unusable: " + invalid;
    for (auto& p : features.points) p.has_3d = false;
    for (auto& l : features.lines) l.has_3d = false;
    return;
  }
  // Planes of the fused depth on a second thread while points and lines are lifted here
  // (disjoint members of `features`).
  const bool used = role != ReferenceRole::kFallbackOnly || !options_.fused_planes_only_for_references;
  const bool planes = options_.families.planes && options_.planes_from_fused_depth && used;
  FrontendStats plane_stats;
  double planes_ms = 0;
  std::vector<PlaneFeature> fused_planes;
  cv::Mat fused_labels;
  auto extractFusedPlanes = [&] {
    Stopwatch w;
    FrameFeatures tmp;
    tmp.camera = features.camera;
    extractPlanes(planes_3d_, tmp, fused, &plane_stats);
    fused_planes = std::move(tmp.planes);
    fused_labels = tmp.plane_labels;
    planes_ms = w.elapsedMs();
  };
  std::future<void> planes_job;
  if (planes && options_.parallel) planes_job = std::async(std::launch::async, extractFusedPlanes);
  {
    Stopwatch w;
    if (!features.points.empty())
      s.points_3d = geometry::liftPoints(features, fused, options_.lift).points_lifted;
    if (!features.lines.empty())
      s.lines_3d = geometry::liftLines(features, fused, options_.lift).lines_lifted;
    addTiming("lift", w.elapsedMs());
  }
  if (planes) {
    if (planes_job.valid())
      planes_job.get();
    else
      extractFusedPlanes();
    addTiming("planes", planes_ms);
    if (!plane_stats.warning.empty()) s.warning = plane_stats.warning;
    features.planes = std::move(fused_planes);
    features.plane_labels = fused_labels;
  }
  s.points = static_cast<int>(features.points.size());
  s.lines = static_cast<int>(features.lines.size());
  s.planes = static_cast<int>(features.planes.size());
}

void Frontend::addTiming(const char* stage, double ms) {
  const std::lock_guard<std::mutex> lock(timings_mutex_);
  timings_.add(stage, ms);
}

StageTimings Frontend::timings() const {
  const std::lock_guard<std::mutex> lock(timings_mutex_);
  return timings_;
}

void Frontend::extractPlanes(PlaneStage& stage, FrameFeatures& features,
                             const DepthWithVariance& depth, FrontendStats* stats) {
  const std::string invalid = geometry::validateDepth(depth, features.camera);
  if (!invalid.empty()) {
    stats->warning = "depth unusable for planes: " + invalid;
    features.planes.clear();
    features.plane_labels = cv::Mat();
    return;
  }
  if (!stage.extractor || stage.camera != features.camera) {
    stage.extractor = std::make_unique<geometry::PlaneExtractor>(features.camera, options_.planes);
    stage.camera = features.camera;
  }
  geometry::PlaneExtractionResult r = stage.extractor->extract(depth);
  features.planes = std::move(r.planes);
  features.plane_labels = r.labels;
}

}  // namespace pplvo::pipeline

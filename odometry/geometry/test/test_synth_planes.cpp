// Plane extraction and matching on pplvo::synth::SyntheticSequence frames (noisy depth with
// disparity quantisation and edge dropout): extracted planes must match the true planes of
// the surfaces they cover.
#include <gtest/gtest.h>

#include <cstdlib>
#include <map>
#include <opencv2/imgcodecs.hpp>

#include "pplvo/fixtures/synthetic_sequence.h"
#include "pplvo/geometry/plane_extraction.h"
#include "pplvo/geometry/plane_matching.h"

namespace pplvo::geometry {
namespace {

double angleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / M_PI;
}

bool coplanarWorld(const Eigen::Vector4d& a, const Eigen::Vector4d& b) {
  return angleDeg(a.head<3>(), b.head<3>()) < 2.0 && std::abs(a(3) - b(3)) < 0.02;
}

// Majority surface id under a plane's label, and the share of the plane's pixels on surfaces
// coplanar with it (posters lie on their wall: different ids, same plane).
std::pair<int, double> majoritySurface(const synth::SyntheticSequence& seq, const cv::Mat& labels,
                                       int label, const cv::Mat& surface_id) {
  std::map<int, int> votes;
  int total = 0;
  for (int v = 0; v < labels.rows; ++v)
    for (int u = 0; u < labels.cols; ++u)
      if (labels.at<uint8_t>(v, u) == label) {
        ++votes[surface_id.at<int>(v, u)];
        ++total;
      }
  int best = -1, best_n = 0;
  for (const auto& [id, n] : votes)
    if (n > best_n) {
      best = id;
      best_n = n;
    }
  Eigen::Vector4d pb;
  if (best < 0 || !seq.surfacePlane(best, &pb)) return {best, 0.0};
  int coplanar = 0;
  for (const auto& [id, n] : votes) {
    Eigen::Vector4d pi;
    if (id >= 0 && seq.surfacePlane(id, &pi) && coplanarWorld(pb, pi)) coplanar += n;
  }
  return {best, total > 0 ? static_cast<double>(coplanar) / total : 0.0};
}

struct Extracted {
  FrameFeatures feats;
  std::vector<int> surface;  // per plane
};

TEST(SynthPlanes, ExtractedPlanesMatchTruePlanes) {
  synth::SynthOptions so;
  so.frames = 120;
  so.seed = 3;
  const synth::SyntheticSequence seq(so);
  const PinholeCamera cam = seq.camera();
  PlaneExtractionOptions po;
  if (std::getenv("GEO_R")) po.refine_neighbourhood_cells = std::atoi(std::getenv("GEO_R"));
  if (std::getenv("GEO_NOREF")) po.refine_boundaries = false;
  PlaneExtractor ex(cam, po);
  const DepthNoiseModel model;
  int n_planes = 0, n_big_visible = 0, n_big_found = 0;
  double max_angle = 0, max_d = 0, max_centroid = 0, max_angle_small = 0;
  std::vector<Extracted> frames;
  for (int i = 0; i < so.frames; i += 10) {
    const synth::SynthFrame f = seq.render(i);
    DepthWithVariance d;
    d.depth_m = f.frame.depth_m;  // variance: sensor model fallback (empty map)
    const PlaneExtractionResult r = ex.extract(d);
    ASSERT_TRUE(r.stats.error.empty()) << r.stats.error;
    if (const char* dump = std::getenv("PPLVO_GEOMETRY_DUMP")) {  // debugging aid only
      cv::Mat l, s;
      r.labels.convertTo(l, CV_8U, 30);
      f.surface_id.convertTo(s, CV_8U, 7, 7);
      cv::imwrite(std::string(dump) + "/synth_labels_" + std::to_string(i) + ".png", l);
      cv::imwrite(std::string(dump) + "/synth_surfaces_" + std::to_string(i) + ".png", s);
      std::printf(
          "stats: planar %d grown %d small %d segs %d merges %d notplanar %d few %d rejected %d\n",
          r.stats.n_planar_cells, r.stats.n_regions_grown, r.stats.n_regions_too_small,
          r.stats.n_segments, r.stats.n_merges, r.stats.n_segments_not_planar,
          r.stats.n_too_few_points, r.stats.n_fit_rejected);
      for (const PlaneFeature& p : r.planes)
        std::printf("frame %d plane %d: n [%.3f %.3f %.3f] d %.3f, %d px\n", i, p.label,
                    p.plane.normal().x(), p.plane.normal().y(), p.plane.normal().z(), p.plane.d(),
                    p.n_points);
    }
    Extracted e;
    e.feats.camera = cam;
    e.feats.planes = r.planes;
    e.feats.plane_labels = r.labels;
    std::map<int, int> found;
    for (const PlaneFeature& p : r.planes) {
      const auto [sid, purity] = majoritySurface(seq, r.labels, p.label, f.surface_id);
      e.surface.push_back(sid);
      Eigen::Vector4d pw;
      if (sid < 0 || !seq.surfacePlane(sid, &pw)) {
        ADD_FAILURE() << "frame " << i << ": plane " << p.label << " on non-planar surface " << sid;
        continue;
      }
      // True plane in the camera frame: n_c = R^T n_w, d_c = n_w . t + d_w.
      const Pose3& T = f.T_w_c;
      const Eigen::Vector3d n_c = T.linear().transpose() * pw.head<3>();
      const double d_c = pw.head<3>().dot(T.translation()) + pw(3);
      const double ang = angleDeg(p.plane.normal(), n_c), derr = std::abs(p.plane.d() - d_c);
      ++n_planes;
      ++found[sid];
      // Small segments (< 5000 px) far away on quantised depth can tilt more (seen: 6 deg for a
      // 3600 px corner patch of a wall at 2.7 m): looser bounds for them (docs/geometry.md).
      const bool large = p.n_points >= 5000;
      EXPECT_LT(ang, large ? 3.0 : 8.0) << "frame " << i << " surface " << seq.surfaceName(sid);
      // The synthetic sensor quantises disparity (1/8 px: 2.7 cm depth steps at 3 m), which
      // tilts planes seen at grazing angles by up to ~2-3 deg; d then moves by the lever arm
      // (~10 cm at 3 m), while the fitted plane stays on the data: check the true plane's
      // distance at the segment centroid (3 cm) and d loosely (15 cm). docs/geometry.md.
      const double centroid_dist = std::abs(n_c.dot(p.centroid) + d_c);
      max_centroid = std::max(max_centroid, centroid_dist);
      EXPECT_LT(centroid_dist, 0.03) << "frame " << i << " surface " << seq.surfaceName(sid);
      EXPECT_LT(derr, large ? 0.15 : 0.3) << "frame " << i << " surface " << seq.surfaceName(sid);
      if (large) {
        max_angle = std::max(max_angle, ang);
        max_d = std::max(max_d, derr);
      } else {
        max_angle_small = std::max(max_angle_small, ang);
      }
      // Pixels within ~5 cm of a seam are ambiguous under quantised depth: purity > 0.7.
      EXPECT_GT(purity, 0.7) << "frame " << i << " surface " << seq.surfaceName(sid);
    }
    for (const synth::VisibleSurface& s : seq.visibleSurfaces(f, 30000)) {
      if (s.dynamic || s.pixels_with_depth < 30000) continue;
      ++n_big_visible;
      // Found if an extracted plane lies on this surface or on a coplanar one (a poster on its
      // wall).
      bool hit = false;
      for (const auto& [sid, cnt] : found) {
        Eigen::Vector4d pw;
        hit = hit || (seq.surfacePlane(sid, &pw) && coplanarWorld(pw, s.plane_w));
      }
      n_big_found += hit;
    }
    frames.push_back(std::move(e));
  }
  std::printf(
      "synth: %d planes over %zu frames, max angle %.3f deg (small planes %.3f), max d err %.4f m, "
      "max centroid-to-true-plane %.4f m, large surfaces found %d/%d\n",
      n_planes, frames.size(), max_angle, max_angle_small, max_d, max_centroid, n_big_found,
      n_big_visible);
  EXPECT_GT(n_planes, static_cast<int>(frames.size()));
  EXPECT_GE(n_big_found, 0.9 * n_big_visible);

  // Matching consecutive rendered frames (10 frames apart): matched planes are the same surface.
  int n_matches = 0, n_wrong = 0;
  for (size_t k = 0; k + 1 < frames.size(); ++k) {
    const auto T_curr_prev =
        seq.pose(static_cast<int>(10 * (k + 1))).inverse() * seq.pose(static_cast<int>(10 * k));
    const PlaneMatchResult m =
        matchPlanesWithStats(frames[k].feats, frames[k + 1].feats, {}, T_curr_prev);
    for (const auto& [a, b] : m.matches) {
      ++n_matches;
      Eigen::Vector4d pa, pb;
      const int sa = frames[k].surface[a], sb = frames[k + 1].surface[b];
      n_wrong += !(sa >= 0 && sb >= 0 && seq.surfacePlane(sa, &pa) && seq.surfacePlane(sb, &pb) &&
                   coplanarWorld(pa, pb));
    }
  }
  std::printf("synth: %d plane matches, %d wrong\n", n_matches, n_wrong);
  EXPECT_GT(n_matches, 0);
  EXPECT_EQ(n_wrong, 0);
}

}  // namespace
}  // namespace pplvo::geometry

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core/persistence.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "pplvo/synth/synthetic_sequence.h"

namespace pplvo::synth {
namespace {

SynthOptions smallOptions(const std::string& scene = "room", uint64_t seed = 1) {
  SynthOptions o;
  o.scene = scene;
  o.seed = seed;
  o.frames = 300;
  return o;
}

/// Plane of a surface transformed into the camera frame: n_c . p_c + d_c = 0.
Eigen::Vector4d planeInCamera(const Eigen::Vector4d& plane_w, const Pose3& T_w_c) {
  const Eigen::Vector3d n_w = plane_w.head<3>();
  Eigen::Vector4d pc;
  pc.head<3>() = T_w_c.linear().transpose() * n_w;
  pc[3] = plane_w[3] + n_w.dot(T_w_c.translation());
  return pc;
}

bool equalMats(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  for (int r = 0; r < a.rows; ++r) {
    if (std::memcmp(a.ptr(r), b.ptr(r), a.cols * a.elemSize()) != 0) return false;
  }
  return true;
}

// (a) Geometry: noiseless depth backprojected and moved by T_w_c lies on the surface plane.
void checkGeometry(const SyntheticSequence& seq, const std::vector<int>& frames, bool dynamic) {
  std::mt19937 rng(42);
  std::uniform_int_distribution<int> du(0, seq.camera().width - 1);
  std::uniform_int_distribution<int> dv(0, seq.camera().height - 1);
  int checked = 0, dynamic_hits = 0;
  for (int i : frames) {
    const SynthFrame f = seq.render(i);
    ASSERT_TRUE(f.T_w_c.isApprox(seq.pose(i), 0.0));
    for (int k = 0; k < 4000; ++k) {
      const int u = du(rng), v = dv(rng);
      const int id = f.surface_id.at<int32_t>(v, u);
      const float z = f.depth_true_m.at<float>(v, u);
      ASSERT_GE(id, 0) << "every ray inside the room hits a surface";
      ASSERT_GT(z, 0.0f);
      Eigen::Vector4d plane_w;
      if (seq.isDynamicSurface(id)) {
        ++dynamic_hits;
        EXPECT_EQ(f.dynamic_mask.at<uint8_t>(v, u), 255);
        EXPECT_FALSE(seq.surfacePlane(id, &plane_w));
        ASSERT_TRUE(seq.surfacePlaneAt(id, i, &plane_w));
      } else {
        EXPECT_EQ(f.dynamic_mask.at<uint8_t>(v, u), 0);
        ASSERT_TRUE(seq.surfacePlane(id, &plane_w)) << seq.surfaceName(id);
      }
      const Eigen::Vector3d p_w = f.T_w_c * seq.camera().backproject(u, v, z);
      ASSERT_NEAR(plane_w.head<3>().norm(), 1.0, 1e-12);
      EXPECT_LT(std::abs(plane_w.head<3>().dot(p_w) + plane_w[3]), 1e-6)
          << "frame " << i << " pixel " << u << "," << v << " surface " << seq.surfaceName(id);
      // Inside the 6 x 5 x 3 m room.
      EXPECT_GE(p_w.minCoeff(), -1e-6);
      EXPECT_LE(p_w.x(), 6.0 + 1e-6);
      EXPECT_LE(p_w.y(), 5.0 + 1e-6);
      EXPECT_LE(p_w.z(), 3.0 + 1e-6);
      // The camera sees the surface from its free side: d > 0 in the camera frame.
      EXPECT_GT(planeInCamera(plane_w, f.T_w_c)[3], 0.0) << seq.surfaceName(id);
      ++checked;
    }
  }
  EXPECT_EQ(checked, 4000 * static_cast<int>(frames.size()));
  if (dynamic) {
    EXPECT_GT(dynamic_hits, 0) << "the moving object should be seen";
  }
}

TEST(SynthGeometry, NoiselessDepthLiesOnSurfacePlanes) {
  for (const std::string scene : {"room", "textureless", "lines"}) {
    SCOPED_TRACE(scene);
    const SyntheticSequence seq(smallOptions(scene, 3));
    checkGeometry(seq, {0, 77, 150, 299}, false);
  }
}

TEST(SynthGeometry, MirroredCameraLikeIclNuim) {
  // ICL-NUIM uses fy < 0: geometry must stay consistent with the signed focal length.
  SynthOptions o = smallOptions("room", 6);
  o.fx = 481.2;
  o.fy = -480.0;
  const SyntheticSequence seq(o);
  checkGeometry(seq, {0, 200}, false);
}

TEST(SynthGeometry, MovingObjectPlanesFollowTheObject) {
  SynthOptions o = smallOptions("room", 5);
  o.moving_object = true;
  const SyntheticSequence seq(o);
  // Find frames where the moving box covers a good part of the image.
  std::vector<int> frames;
  for (int i = 0; i < seq.size() && frames.size() < 3; i += 5) {
    const SynthFrame f = seq.render(i);
    if (cv::countNonZero(f.dynamic_mask) > 2000) frames.push_back(i);
  }
  ASSERT_FALSE(frames.empty()) << "the moving object never shows up";
  checkGeometry(seq, frames, true);
}

TEST(SynthGeometry, SurfaceIdsAreBoundedAndPlanesAreUnit) {
  const SyntheticSequence seq(smallOptions());
  ASSERT_GT(seq.surfaceCount(), 30);
  Eigen::Vector4d plane;
  for (int id = 0; id < seq.surfaceCount(); ++id) {
    ASSERT_TRUE(seq.surfacePlane(id, &plane)) << id;
    EXPECT_NEAR(plane.head<3>().norm(), 1.0, 1e-12);
    EXPECT_FALSE(seq.surfaceName(id).empty());
  }
  // Posters lie in their wall's plane.
  int posters = 0;
  for (int id = 0; id < seq.surfaceCount(); ++id) {
    const int g = seq.planeGroup(id);
    ASSERT_GE(g, 0);
    ASSERT_LE(g, id);
    Eigen::Vector4d pg;
    ASSERT_TRUE(seq.surfacePlane(g, &pg));
    ASSERT_TRUE(seq.surfacePlane(id, &plane));
    EXPECT_TRUE(pg == plane);
    if (seq.surfaceName(id).rfind("poster", 0) == 0) {
      ++posters;
      EXPECT_EQ(seq.surfaceName(g).rfind("room", 0), 0u) << seq.surfaceName(id);
    }
  }
  EXPECT_GE(posters, 4);
  EXPECT_EQ(seq.planeGroup(-1), -1);
  EXPECT_FALSE(seq.surfacePlane(-1, &plane));
  EXPECT_FALSE(seq.surfacePlane(seq.surfaceCount(), &plane));
}

TEST(SynthGeometry, VisibleSurfacesGivePlanesInCameraFrame) {
  SynthOptions o = smallOptions("room", 8);
  o.moving_object = true;
  const SyntheticSequence seq(o);
  for (int i : {0, 30, 200}) {
    const SynthFrame f = seq.render(i);
    const std::vector<VisibleSurface> vis = seq.visibleSurfaces(f);
    ASSERT_FALSE(vis.empty());
    int total = 0;
    for (size_t k = 0; k < vis.size(); ++k) {
      const VisibleSurface& s = vis[k];
      total += s.pixels;
      if (k > 0) {
        EXPECT_LE(s.pixels, vis[k - 1].pixels);
      }
      EXPECT_LE(s.pixels_with_depth, s.pixels);
      EXPECT_EQ(s.dynamic, seq.isDynamicSurface(s.surface_id));
      EXPECT_GT(s.plane_c[3], 0.0) << s.name;
      EXPECT_NEAR(s.plane_c.head<3>().norm(), 1.0, 1e-12);
      Eigen::Vector4d plane_w;
      ASSERT_TRUE(seq.surfacePlaneAt(s.surface_id, i, &plane_w));
      EXPECT_TRUE(plane_w.isApprox(s.plane_w, 1e-12));
    }
    EXPECT_EQ(total, f.surface_id.rows * f.surface_id.cols);
    // The camera-frame plane holds the backprojected noiseless depth of its pixels.
    std::map<int, Eigen::Vector4d> plane_c;
    for (const VisibleSurface& s : vis) plane_c[s.surface_id] = s.plane_c;
    for (int v = 0; v < f.surface_id.rows; v += 7) {
      for (int u = 0; u < f.surface_id.cols; u += 7) {
        const Eigen::Vector4d& pc = plane_c.at(f.surface_id.at<int32_t>(v, u));
        const Eigen::Vector3d p_c = seq.camera().backproject(u, v, f.depth_true_m.at<float>(v, u));
        ASSERT_LT(std::abs(pc.head<3>().dot(p_c) + pc[3]), 1e-6);
      }
    }
    // min_pixels filters.
    for (const VisibleSurface& s : seq.visibleSurfaces(f, 5000)) EXPECT_GE(s.pixels, 5000);
  }
}

TEST(SynthGeometry, SceneEdgesLieOnTheirSurfaces) {
  SynthOptions o = smallOptions("room", 8);
  o.moving_object = true;
  const SyntheticSequence seq(o);
  for (int i : {0, 100}) {
    const std::vector<SceneEdge> edges = seq.sceneEdges(i);
    ASSERT_GT(edges.size(), 100u);
    for (const SceneEdge& e : edges) {
      EXPECT_GT((e.b_w - e.a_w).norm(), 0.0);
      // Axis-aligned.
      int moving_axes = 0;
      for (int k = 0; k < 3; ++k) moving_axes += std::abs(e.b_w[k] - e.a_w[k]) > 0 ? 1 : 0;
      EXPECT_EQ(moving_axes, 1);
      for (int id : {e.surface_a, e.surface_b}) {
        if (id < 0) continue;
        Eigen::Vector4d plane;
        ASSERT_TRUE(seq.surfacePlaneAt(id, i, &plane));
        EXPECT_LT(std::abs(plane.head<3>().dot(e.a_w) + plane[3]), 1e-9) << seq.surfaceName(id);
        EXPECT_LT(std::abs(plane.head<3>().dot(e.b_w) + plane[3]), 1e-9) << seq.surfaceName(id);
      }
    }
  }
}

// (b) Determinism.
TEST(SynthDeterminism, SameSeedSameFramesOtherSeedDiffers) {
  SynthOptions o = smallOptions("room", 11);
  o.moving_object = true;
  const SyntheticSequence a(o), b(o);
  const SynthFrame a7 = a.render(7);
  b.render(3);  // rendering order must not matter
  const SynthFrame b7 = b.render(7);
  EXPECT_TRUE(equalMats(a7.frame.bgr, b7.frame.bgr));
  EXPECT_TRUE(equalMats(a7.frame.depth_m, b7.frame.depth_m));
  EXPECT_TRUE(equalMats(a7.depth_true_m, b7.depth_true_m));
  EXPECT_TRUE(equalMats(a7.surface_id, b7.surface_id));
  EXPECT_TRUE(equalMats(a7.dynamic_mask, b7.dynamic_mask));
  EXPECT_EQ(a7.frame.stamp, b7.frame.stamp);
  EXPECT_TRUE(a.pose(123).isApprox(b.pose(123), 0.0));

  // Noise differs between frames (independent per-frame streams).
  const SynthFrame a8 = a.render(8);
  EXPECT_FALSE(equalMats(a7.frame.depth_m, a8.frame.depth_m));

  o.seed = 12;
  const SyntheticSequence c(o);
  const SynthFrame c7 = c.render(7);
  EXPECT_FALSE(equalMats(a7.frame.bgr, c7.frame.bgr));
  EXPECT_FALSE(equalMats(a7.frame.depth_m, c7.frame.depth_m));
  EXPECT_FALSE(a.pose(7).isApprox(c.pose(7), 1e-6));
}

TEST(SynthOptionsCheck, BadOptionsAndIndicesThrow) {
  SynthOptions o = smallOptions();
  o.scene = "castle";
  EXPECT_THROW(SyntheticSequence{o}, std::invalid_argument);
  o = smallOptions();
  o.width = 0;
  EXPECT_THROW(SyntheticSequence{o}, std::invalid_argument);
  o = smallOptions();
  o.fps = std::nan("");
  EXPECT_THROW(SyntheticSequence{o}, std::invalid_argument);
  o = smallOptions();
  o.frames = 3;
  const SyntheticSequence seq(o);
  EXPECT_THROW(seq.render(3), std::out_of_range);
  EXPECT_THROW(seq.render(-1), std::out_of_range);
  EXPECT_THROW(seq.pose(3), std::out_of_range);
  EXPECT_EQ(seq.stamp(0), "1.000000");
  EXPECT_EQ(seq.stamp(1), "1.033333");
}

TEST(SynthNoise, DisabledNoiseGivesTrueDepth) {
  SynthOptions o = smallOptions();
  o.noise.enabled = false;
  const SyntheticSequence seq(o);
  const SynthFrame f = seq.render(20);
  EXPECT_TRUE(equalMats(f.frame.depth_m, f.depth_true_m));
  EXPECT_EQ(cv::countNonZero(f.frame.depth_m == 0), 0);
}

/// Per-pixel incidence cosine from the surface plane and the viewing ray.
double incidenceCos(const SyntheticSequence& seq, const SynthFrame& f, int u, int v) {
  Eigen::Vector4d plane_w;
  const int id = f.surface_id.at<int32_t>(v, u);
  if (!seq.surfacePlaneAt(id, static_cast<int>(f.frame.seq), &plane_w)) return 0.0;
  const Eigen::Vector3d n_c = f.T_w_c.linear().transpose() * plane_w.head<3>();
  const Eigen::Vector3d r = seq.camera().ray(u, v);
  return std::abs(n_c.dot(r)) / r.norm();
}

/// Collects (noisy - true) depth on near fronto-parallel static walls away from edges.
struct Residuals {
  std::vector<double> normalised;      // (noisy - true) / model sigma
  std::vector<double> disparity_frac;  // fractional part of disparity / step
  int dropped = 0, total = 0;
};

Residuals collect(const SyntheticSequence& seq, const std::vector<int>& frames,
                  double model_extra) {
  Residuals r;
  const auto& n = seq.options().noise;
  const double fb = seq.camera().fx * n.baseline_m;
  for (int i : frames) {
    const SynthFrame f = seq.render(i);
    for (int v = 2; v < f.depth_true_m.rows - 2; v += 2) {
      for (int u = 2; u < f.depth_true_m.cols - 2; u += 2) {
        const float z = f.depth_true_m.at<float>(v, u);
        if (z < 1.0f || z > 4.0f) continue;
        // Flat neighbourhood (no discontinuity within 2 px).
        const cv::Mat win = f.depth_true_m(cv::Rect(u - 2, v - 2, 5, 5));
        double mn, mx;
        cv::minMaxLoc(win, &mn, &mx);
        if (mx - mn > 0.05) continue;
        if (incidenceCos(seq, f, u, v) < 0.9) continue;
        ++r.total;
        const float zn = f.frame.depth_m.at<float>(v, u);
        if (zn <= 0) {
          ++r.dropped;
          continue;
        }
        const double sigma = n.sigma_z_coeff_per_m * z * z;
        const double q = z * z / fb * n.disparity_step_px;  // depth step of one disparity step
        r.normalised.push_back((zn - z) / std::sqrt(sigma * sigma + model_extra * q * q / 12.0));
        const double steps = fb / zn / n.disparity_step_px;
        r.disparity_frac.push_back(std::abs(steps - std::round(steps)));
      }
    }
  }
  return r;
}

double stddev(const std::vector<double>& x) {
  double m = 0, s = 0;
  for (double v : x) m += v;
  m /= x.size();
  for (double v : x) s += (v - m) * (v - m);
  return std::sqrt(s / (x.size() - 1));
}

// (c) Noise statistics.
TEST(SynthNoise, GaussianDepthNoiseMatchesKinectModel) {
  SynthOptions o = smallOptions("room", 2);
  o.noise.quantise_disparity = false;
  const SyntheticSequence seq(o);
  const Residuals r = collect(seq, {0, 100, 200}, 0.0);
  ASSERT_GT(r.normalised.size(), 5000u);
  const double sd = stddev(r.normalised);
  std::printf("std((noisy - true) / sigma_z) = %.3f over %zu pixels\n", sd, r.normalised.size());
  EXPECT_NEAR(sd, 1.0, 0.1) << "std of (noisy - true) / (1.425e-3 z^2)";
  EXPECT_LT(r.dropped, r.total / 50) << "fronto-parallel walls in range should keep depth";
}

TEST(SynthNoise, DisparityQuantisationSteps) {
  const SyntheticSequence seq(smallOptions("room", 2));
  // Gaussian noise plus uniform quantisation error: variance sigma^2 + q^2 / 12.
  const Residuals r = collect(seq, {0, 100, 200}, 1.0);
  ASSERT_GT(r.normalised.size(), 5000u);
  const double sd = stddev(r.normalised);
  std::printf("std((noisy - true) / sqrt(sigma_z^2 + q^2/12)) = %.3f over %zu pixels\n", sd,
              r.normalised.size());
  EXPECT_NEAR(sd, 1.0, 0.25);
  // Against the paper's sigma_z alone the quantised depth error is about 1.19 times larger.
  const Residuals r_paper = collect(seq, {0, 100, 200}, 0.0);
  const double sd_paper = stddev(r_paper.normalised);
  std::printf("std((noisy - true) / sigma_z) with quantisation = %.3f\n", sd_paper);
  EXPECT_GT(sd_paper, 1.05);
  EXPECT_LT(sd_paper, 1.3);
  // Every depth comes from a disparity that is a multiple of 1/8 px (float rounding aside).
  double worst = 0;
  for (double fr : r.disparity_frac) worst = std::max(worst, fr);
  EXPECT_LT(worst, 0.01);
  // Quantisation: few distinct depth values on a flat wall patch.
  const SynthFrame f = seq.render(0);
  std::vector<float> vals;
  for (int v = 200; v < 280; ++v) {
    for (int u = 280; u < 360; ++u) {
      const float z = f.frame.depth_m.at<float>(v, u);
      if (z > 0) vals.push_back(z);
    }
  }
  std::sort(vals.begin(), vals.end());
  vals.erase(std::unique(vals.begin(), vals.end()), vals.end());
  EXPECT_LT(vals.size(), 200u) << "6400 pixels should collapse onto few disparity levels";
}

TEST(SynthNoise, MissingDepthAtRangeGrazingAndEdges) {
  SynthOptions o = smallOptions("room", 4);
  o.noise.max_range_m = 3.0;
  o.noise.min_range_m = 1.5;
  o.noise.grazing_angle_deg = 60.0;
  const SyntheticSequence seq(o);
  int far = 0, close = 0, grazing = 0, edges = 0, valid_checked = 0;
  const double cos60 = std::cos(60.0 * M_PI / 180.0);
  for (int i : {0, 60, 120, 180, 240}) {
    const SynthFrame f = seq.render(i);
    for (int v = 1; v < f.depth_true_m.rows - 1; ++v) {
      for (int u = 1; u < f.depth_true_m.cols - 1; ++u) {
        const float z = f.depth_true_m.at<float>(v, u);
        const float zn = f.frame.depth_m.at<float>(v, u);
        if (z > 3.0f) {
          ++far;
          ASSERT_EQ(zn, 0.0f);
        } else if (z < 1.5f) {
          ++close;
          ASSERT_EQ(zn, 0.0f);
        } else if (incidenceCos(seq, f, u, v) < cos60 - 1e-3) {
          ++grazing;
          ASSERT_EQ(zn, 0.0f) << u << "," << v;
        } else {
          const float jumps[4] = {
              f.depth_true_m.at<float>(v, u - 1), f.depth_true_m.at<float>(v, u + 1),
              f.depth_true_m.at<float>(v - 1, u), f.depth_true_m.at<float>(v + 1, u)};
          bool edge = false;
          for (float zz : jumps) edge = edge || std::abs(zz - z) > 0.1f;
          if (edge) {
            ++edges;
            ASSERT_EQ(zn, 0.0f);
          } else if (incidenceCos(seq, f, u, v) > cos60 + 1e-3) {
            ++valid_checked;
            ASSERT_GT(zn, 0.0f);
          }
        }
      }
    }
  }
  EXPECT_GT(far, 1000);
  EXPECT_GT(close, 100);
  EXPECT_GT(grazing, 1000);
  EXPECT_GT(edges, 100);
  EXPECT_GT(valid_checked, 10000);
}

// (d) Texture: corner counts.
int fastCount(const SynthFrame& f) {
  cv::Mat grey;
  cv::cvtColor(f.frame.bgr, grey, cv::COLOR_BGR2GRAY);
  std::vector<cv::KeyPoint> kps;
  cv::FAST(grey, kps, 20, true);
  return static_cast<int>(kps.size());
}

TEST(SynthTexture, RoomIsCornerRichTexturelessIsNot) {
  const SyntheticSequence room(smallOptions("room", 1));
  const SyntheticSequence plain(smallOptions("textureless", 1));
  int room_min = 1 << 30, plain_max = 0;
  long room_sum = 0, plain_sum = 0;
  for (int i = 0; i < 300; i += 30) {
    const int r = fastCount(room.render(i));
    const int p = fastCount(plain.render(i));
    room_min = std::min(room_min, r);
    plain_max = std::max(plain_max, p);
    room_sum += r;
    plain_sum += p;
  }
  std::printf("FAST(20) corners per frame: room min %d mean %ld, textureless max %d mean %ld\n",
              room_min, room_sum / 10, plain_max, plain_sum / 10);
  EXPECT_GT(room_min, 300);
  EXPECT_LT(plain_sum * 5, room_sum);
}

TEST(SynthTexture, LinesSceneIsLineRich) {
  auto lsd = cv::createLineSegmentDetector();
  auto longSegments = [&](const SynthFrame& f) {
    cv::Mat grey;
    cv::cvtColor(f.frame.bgr, grey, cv::COLOR_BGR2GRAY);
    std::vector<cv::Vec4f> lines;
    lsd->detect(grey, lines);
    int n = 0;
    for (const cv::Vec4f& l : lines) n += std::hypot(l[2] - l[0], l[3] - l[1]) > 30.0 ? 1 : 0;
    return n;
  };
  const SyntheticSequence lines(smallOptions("lines", 1));
  const SyntheticSequence plain(smallOptions("textureless", 1));
  int lines_min = 1 << 30, plain_sum = 0;
  for (int i = 0; i < 300; i += 60) {
    lines_min = std::min(lines_min, longSegments(lines.render(i)));
    plain_sum += longSegments(plain.render(i));
  }
  std::printf("LSD segments > 30 px: lines min %d, textureless sum over 5 frames %d\n", lines_min,
              plain_sum);
  EXPECT_GT(lines_min, 50);
  EXPECT_GT(plain_sum, 0) << "box edges should still give a few lines";
  EXPECT_LT(plain_sum, 5 * lines_min / 3);
}

// (e) TUM folder output.
TEST(SynthWriter, TumFolderRoundTrip) {
  SynthOptions o = smallOptions("lines", 9);
  o.frames = 4;
  o.width = 320;
  o.height = 240;
  o.fx = o.fy = 262.5;
  o.cx = 159.5;
  o.cy = 119.5;
  const SyntheticSequence seq(o);
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("pplvo_test_synth_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  writeTumFolder(seq, dir.string(), true);

  std::ifstream assoc(dir / "associations.txt");
  ASSERT_TRUE(assoc.good());
  std::string line;
  int n = 0;
  while (std::getline(assoc, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    std::string s_depth, f_depth, s_rgb, f_rgb;
    ss >> s_depth >> f_depth >> s_rgb >> f_rgb;
    ASSERT_EQ(s_depth, seq.stamp(n));
    ASSERT_EQ(s_rgb, seq.stamp(n));
    EXPECT_EQ(f_depth, "depth/" + seq.stamp(n) + ".png");
    EXPECT_EQ(f_rgb, "rgb/" + seq.stamp(n) + ".png");
    const SynthFrame f = seq.render(n);
    const cv::Mat rgb = cv::imread((dir / f_rgb).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(rgb.empty());
    EXPECT_TRUE(equalMats(rgb, f.frame.bgr));
    const cv::Mat depth = cv::imread((dir / f_depth).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(depth.type(), CV_16UC1);
    int mismatches = 0;
    for (int v = 0; v < depth.rows; ++v) {
      for (int u = 0; u < depth.cols; ++u) {
        const long expect = std::lround(f.frame.depth_m.at<float>(v, u) * 5000.0);
        if (depth.at<uint16_t>(v, u) != expect) ++mismatches;
      }
    }
    EXPECT_EQ(mismatches, 0);
    const cv::Mat depth_true =
        cv::imread((dir / ("depth_true/" + seq.stamp(n) + ".png")).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(depth_true.type(), CV_16UC1);
    EXPECT_EQ(depth_true.at<uint16_t>(120, 160),
              std::lround(f.depth_true_m.at<float>(120, 160) * 5000.0));
    ++n;
  }
  EXPECT_EQ(n, 4);
  for (const char* name : {"rgb.txt", "depth.txt"}) {
    EXPECT_TRUE(std::filesystem::exists(dir / name)) << name;
  }

  const TrajectoryReadResult gt = readTumTrajectory((dir / "groundtruth.txt").string());
  EXPECT_EQ(gt.skipped_lines, 0);
  ASSERT_EQ(gt.poses.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(gt.poses[i].stamp_text, seq.stamp(i));
    EXPECT_LT((gt.poses[i].T_w_c.matrix() - seq.pose(i).matrix()).cwiseAbs().maxCoeff(), 1e-8);
  }

  cv::FileStorage fs((dir / "calib_params.xml").string(), cv::FileStorage::READ);
  ASSERT_TRUE(fs.isOpened());
  cv::Mat K, dist, K_ir, R, t;
  fs["RGB_intrinsic_params"] >> K;
  fs["RGB_distortion_coefficients"] >> dist;
  fs["IR_intrinsic_params"] >> K_ir;
  fs["Rotation"] >> R;
  fs["Translation"] >> t;
  ASSERT_EQ(K.rows, 3);
  ASSERT_EQ(K.cols, 3);
  EXPECT_DOUBLE_EQ(K.at<double>(0, 0), 262.5);
  EXPECT_DOUBLE_EQ(K.at<double>(1, 1), 262.5);
  EXPECT_DOUBLE_EQ(K.at<double>(0, 2), 159.5);
  EXPECT_DOUBLE_EQ(K.at<double>(1, 2), 119.5);
  EXPECT_EQ(dist.total(), 5u);
  EXPECT_EQ(K_ir.total(), 9u);
  EXPECT_EQ(R.total(), 9u);
  EXPECT_EQ(t.total(), 3u);
  EXPECT_DOUBLE_EQ(static_cast<double>(fs["depth_scale"]), 5000.0);
  std::filesystem::remove_all(dir);
}

TEST(SynthWriter, UnwritableFolderThrows) {
  SynthOptions o = smallOptions();
  o.frames = 1;
  const SyntheticSequence seq(o);
  EXPECT_THROW(writeTumFolder(seq, "/proc/pplvo_no_such_dir/x"), std::runtime_error);
}

TEST(SynthProgram, WritesFolderAndRejectsBadArguments) {
  const char* bin_dir = std::getenv("PPLVO_BINARY_DIR");
  if (bin_dir == nullptr) GTEST_SKIP() << "PPLVO_BINARY_DIR not set (run through ctest)";
  const std::string exe = std::string(bin_dir) + "/bin/pplvo-synth";
  ASSERT_TRUE(std::filesystem::exists(exe)) << exe;
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("pplvo_test_synth_cli_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const std::string ok_cmd = exe + " --output " + dir.string() +
                             " --frames 3 --width 160 --height 120 --scene textureless --seed 4"
                             " --moving-object --true-depth > /dev/null";
  EXPECT_EQ(std::system(ok_cmd.c_str()), 0);
  EXPECT_TRUE(std::filesystem::exists(dir / "depth_true" / "1.066667.png"));
  const cv::Mat rgb = cv::imread((dir / "rgb" / "1.000000.png").string());
  EXPECT_EQ(rgb.cols, 160);
  EXPECT_EQ(rgb.rows, 120);
  cv::FileStorage fs((dir / "calib_params.xml").string(), cv::FileStorage::READ);
  ASSERT_TRUE(fs.isOpened());
  cv::Mat K;
  fs["RGB_intrinsic_params"] >> K;
  EXPECT_DOUBLE_EQ(K.at<double>(0, 0), 525.0 / 4.0);
  EXPECT_DOUBLE_EQ(K.at<double>(0, 2), 79.5);
  std::filesystem::remove_all(dir);
  // Bad option values exit 1, unusable command lines exit 2; neither crashes.
  const std::string bad_scene = exe + " --output " + dir.string() + " --scene castle 2> /dev/null";
  EXPECT_EQ(WEXITSTATUS(std::system(bad_scene.c_str())), 1);
  const std::string bad_arg = exe + " --output " + dir.string() + " --bogus 2> /dev/null";
  EXPECT_EQ(WEXITSTATUS(std::system(bad_arg.c_str())), 2);
  const std::string bad_num = exe + " --output " + dir.string() + " --frames x 2> /dev/null";
  EXPECT_EQ(WEXITSTATUS(std::system(bad_num.c_str())), 2);
  const std::string no_out = exe + " 2> /dev/null";
  EXPECT_EQ(WEXITSTATUS(std::system(no_out.c_str())), 2);
  std::filesystem::remove_all(dir);
}

// (f) Smooth trajectory.
TEST(SynthTrajectory, SmoothBoundedHandHeldMotion) {
  for (uint64_t seed : {1u, 2u, 3u, 4u}) {
    const SyntheticSequence seq(smallOptions("room", seed));
    const double dt = 1.0 / seq.options().fps;
    double max_speed = 0, max_rate = 0, max_acc = 0;
    for (int i = 1; i < seq.size(); ++i) {
      const Pose3 a = seq.pose(i - 1), b = seq.pose(i);
      ASSERT_TRUE(isValidPose(b));
      const Pose3 rel = a.inverse() * b;
      max_speed = std::max(max_speed, rel.translation().norm() / dt);
      max_rate = std::max(max_rate, rotationAngle(rel.linear()) / dt);
      if (i + 1 < seq.size()) {
        const Eigen::Vector3d acc =
            (seq.pose(i + 1).translation() - 2 * b.translation() + a.translation()) / (dt * dt);
        max_acc = std::max(max_acc, acc.norm());
      }
      // Camera stays well inside the room, away from walls and furniture.
      const Eigen::Vector3d p = b.translation();
      EXPECT_GT(p.x(), 1.5);
      EXPECT_LT(p.x(), 4.5);
      EXPECT_GT(p.y(), 1.2);
      EXPECT_LT(p.y(), 3.3);
      EXPECT_GT(p.z(), 1.0);
      EXPECT_LT(p.z(), 1.8);
    }
    const double deg = 180.0 / M_PI;
    std::printf("seed %llu: peak speed %.2f m/s, peak rate %.1f deg/s, peak accel %.2f m/s^2\n",
                static_cast<unsigned long long>(seed), max_speed, max_rate * deg, max_acc);
    EXPECT_GT(max_speed, 0.15);
    EXPECT_LT(max_speed, 0.6);
    EXPECT_GT(max_rate * deg, 8.0);
    EXPECT_LT(max_rate * deg, 35.0);
    EXPECT_LT(max_acc, 2.0);
  }
}

}  // namespace
}  // namespace pplvo::synth

namespace pplvo::synth {
namespace {

TEST(SynthTrajectory, ScaleZeroIsStaticAndLargeScalesStayInside) {
  SynthOptions o = smallOptions("room", 21);
  o.trajectory_scale = 0.0;
  const SyntheticSequence still(o);
  for (int i = 1; i < still.size(); i += 37) {
    EXPECT_TRUE(still.pose(i).isApprox(still.pose(0), 1e-12)) << i;
  }
  o.trajectory_scale = 5.0;
  const SyntheticSequence wild(o);
  double max_step = 0;
  for (int i = 0; i < wild.size(); ++i) {
    const Eigen::Vector3d p = wild.pose(i).translation();
    EXPECT_GT(p.x(), 2.0);
    EXPECT_LT(p.x(), 4.0);
    EXPECT_GT(p.y(), 1.5);
    EXPECT_LT(p.y(), 3.1);
    if (i > 0) {
      max_step = std::max(max_step, (p - wild.pose(i - 1).translation()).norm());
    }
  }
  EXPECT_LT(max_step, 0.05) << "capped amplitudes keep the motion smooth";
}

TEST(SynthFrameFields, StampsSequenceNumbersAndCamera) {
  SynthOptions o = smallOptions("textureless", 2);
  o.fps = 25.0;
  o.width = 200;
  o.height = 150;
  o.fx = o.fy = 180.0;
  o.cx = 99.5;
  o.cy = 74.5;
  const SyntheticSequence seq(o);
  const SynthFrame f = seq.render(10);
  EXPECT_EQ(f.frame.seq, 10);
  EXPECT_EQ(f.frame.stamp, "1.400000");
  EXPECT_EQ(seq.stamp(10), "1.400000");
  EXPECT_EQ(f.frame.utime, 1400000);
  EXPECT_TRUE(f.frame.camera == seq.camera());
  EXPECT_EQ(f.frame.bgr.type(), CV_8UC3);
  EXPECT_EQ(f.frame.depth_m.type(), CV_32FC1);
  EXPECT_EQ(f.frame.bgr.cols, 200);
  EXPECT_EQ(f.frame.bgr.rows, 150);
  EXPECT_EQ(f.depth_true_m.size(), f.frame.bgr.size());
  EXPECT_EQ(f.surface_id.size(), f.frame.bgr.size());
  EXPECT_EQ(f.dynamic_mask.size(), f.frame.bgr.size());
  EXPECT_EQ(cv::countNonZero(f.dynamic_mask), 0);
  const Trajectory gt = seq.groundTruth();
  ASSERT_EQ(static_cast<int>(gt.size()), seq.size());
  EXPECT_EQ(gt[10].stamp_text, "1.400000");
  EXPECT_DOUBLE_EQ(gt[10].stamp, 1.4);
  EXPECT_TRUE(gt[10].T_w_c.isApprox(seq.pose(10), 0.0));
}

}  // namespace
}  // namespace pplvo::synth

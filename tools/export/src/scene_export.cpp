#include "pplvo/export/scene_export.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <opencv2/imgproc.hpp>
#include <pplvo_msgs/features_t.hpp>
#include <pplvo_msgs/pose_t.hpp>
#include <stdexcept>

#include "pplvo/logging/event_log.h"
#include "pplvo/msgs/channels.h"
#include "pplvo/msgs/convert_features.h"
#include "pplvo/msgs/convert_pose.h"
#include "pplvo/msgs/decode.h"

namespace pplvo::exporting {

std::vector<Eigen::Vector3d> planeOutline(const PlaneFeature& plane, const cv::Mat& labels,
                                          const PinholeCamera& camera) {
  if (labels.empty() || labels.type() != CV_8UC1 || labels.cols != camera.width ||
      labels.rows != camera.height) {
    return {};
  }
  std::vector<cv::Point> pixels;
  cv::findNonZero(labels == plane.label, pixels);
  if (pixels.size() < 3) return {};
  std::vector<cv::Point> hull;
  cv::convexHull(pixels, hull);
  std::vector<Eigen::Vector3d> outline;
  const Eigen::Vector3d n = plane.plane.normal();
  for (const cv::Point& p : hull) {
    const Eigen::Vector3d ray = camera.ray(p.x + 0.5, p.y + 0.5);
    const double denom = n.dot(ray);
    if (std::abs(denom) < 1e-9) continue;
    const double t = -plane.plane.d() / denom;  // n . (t ray) + d = 0
    if (!(t > 0) || !std::isfinite(t)) continue;
    outline.push_back(t * ray);
  }
  if (outline.size() < 3) return {};
  return outline;
}

void SceneCollector::addKeyframe(const Pose3& T_w_c, const FrameFeatures& f) {
  const int k = scene_.keyframes++;
  const Eigen::Matrix3d R = T_w_c.linear();
  for (const PointFeature& p : f.points) {
    if (!p.has_3d || !p.point.p.allFinite()) continue;
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(p.point.cov);
    const double sigma = std::sqrt(std::max(0.0, es.eigenvalues().maxCoeff()));
    if (!(sigma <= max_sigma_)) continue;
    scene_.points.push_back(T_w_c * p.point.p);
    scene_.point_sigma_m.push_back(sigma);
    scene_.point_keyframe.push_back(k);
  }
  for (const LineFeature& l : f.lines) {
    if (!l.has_3d || !l.line.p1.allFinite() || !l.line.p2.allFinite()) continue;
    scene_.lines.emplace_back(T_w_c * l.line.p1, T_w_c * l.line.p2);
    scene_.line_keyframe.push_back(k);
  }
  for (const PlaneFeature& p : f.planes) {
    std::vector<Eigen::Vector3d> outline = planeOutline(p, f.plane_labels, f.camera);
    if (outline.empty()) continue;
    for (Eigen::Vector3d& v : outline) v = T_w_c * v;
    scene_.plane_outlines.push_back(std::move(outline));
    scene_.plane_normals.push_back(R * p.plane.normal());
  }
}

SceneExport exportFromLog(const std::string& log_path, const LogExportOptions& options,
                          int* skipped) {
  if (!std::filesystem::is_regular_file(log_path)) {
    throw std::runtime_error("no event log at " + log_path);
  }
  // The project's reader: a log cut mid-event (a killed logger) gives its complete events.
  logging::EventLogReader log(log_path);
  std::map<int64_t, FramePose> poses;
  std::map<int64_t, FrameFeatures> lifted;
  int bad = 0;
  // Decodes and converts one message; false for a bad one (counted, skipped).
  const auto convert = [&bad](const logging::LogEvent& e, auto* msg, auto* out) {
    try {
      if (!msgs::decodeMessage(e.data.data(), static_cast<unsigned>(e.data.size()), msg).empty()) {
        ++bad;
        return;
      }
      (*out)[msg->seq] = msgs::fromMsg(*msg);
    } catch (const std::exception&) {
      ++bad;  // decodes but does not convert (NaN, sizes that disagree)
    }
  };
  while (const std::optional<logging::LogEvent> e = log.next()) {
    if (e->channel == channels::kPose) {
      pplvo_msgs::pose_t m;
      convert(*e, &m, &poses);
    } else if (e->channel == channels::kFeatures3d) {
      pplvo_msgs::features_t m;
      convert(*e, &m, &lifted);
    }
  }
  if (log.truncated()) ++bad;  // the incomplete last event
  if (skipped != nullptr) *skipped = bad;
  SceneCollector collector(options.max_point_sigma_m);
  for (const auto& [seq, pose] : poses) {
    const auto f = lifted.find(seq);
    if (f == lifted.end()) continue;
    const bool keyframe = pose.reference != ReferenceRole::kFallbackOnly;
    if (!options.all_frames && !keyframe) continue;
    if (pose.status == TrackingStatus::kLost) continue;  // its pose is a guess
    collector.addKeyframe(pose.T_w_c, f->second);
  }
  if (collector.scene().keyframes == 0) {
    throw std::runtime_error(log_path + " holds no posed frame with its lifted features (" +
                             std::string(channels::kPose) + " and " + channels::kFeatures3d +
                             ": record them, e.g. pplvo-run --log)");
  }
  return collector.scene();
}

namespace {

/// A colour per keyframe (a hue wheel), so that where each keyframe saw what shows.
std::array<int, 3> keyframeColour(int k) {
  const double h = std::fmod(k * 0.61803398875, 1.0) * 6.0;
  const double x = 1.0 - std::abs(std::fmod(h, 2.0) - 1.0);
  const double rgb[6][3] = {{1, x, 0}, {x, 1, 0}, {0, 1, x}, {0, x, 1}, {x, 0, 1}, {1, 0, x}};
  const auto& c = rgb[static_cast<int>(h) % 6];
  return {static_cast<int>(55 + 200 * c[0]), static_cast<int>(55 + 200 * c[1]),
          static_cast<int>(55 + 200 * c[2])};
}

std::ofstream openPly(const std::filesystem::path& path) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write " + path.string());
  out << "ply\nformat ascii 1.0\ncomment pplvo: world frame = the first camera's (x right, "
         "y down, z forward), metres\n";
  return out;
}

}  // namespace

void writePly(const SceneExport& s, const std::string& dir) {
  const std::filesystem::path d(dir);
  std::filesystem::create_directories(d);
  {
    std::ofstream out = openPly(d / "points.ply");
    out << "element vertex " << s.points.size()
        << "\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\n"
           "property uchar green\nproperty uchar blue\nproperty float sigma\n"
           "property int keyframe\nend_header\n";
    for (size_t i = 0; i < s.points.size(); ++i) {
      const auto c = keyframeColour(s.point_keyframe[i]);
      out << s.points[i].x() << ' ' << s.points[i].y() << ' ' << s.points[i].z() << ' ' << c[0]
          << ' ' << c[1] << ' ' << c[2] << ' ' << s.point_sigma_m[i] << ' '
          << s.point_keyframe[i] << '\n';
    }
  }
  {
    std::ofstream out = openPly(d / "lines.ply");
    out << "element vertex " << 2 * s.lines.size()
        << "\nproperty float x\nproperty float y\nproperty float z\nelement edge "
        << s.lines.size() << "\nproperty int vertex1\nproperty int vertex2\nend_header\n";
    for (const auto& [a, b] : s.lines) {
      out << a.x() << ' ' << a.y() << ' ' << a.z() << '\n'
          << b.x() << ' ' << b.y() << ' ' << b.z() << '\n';
    }
    for (size_t i = 0; i < s.lines.size(); ++i) out << 2 * i << ' ' << 2 * i + 1 << '\n';
  }
  {
    std::ofstream out = openPly(d / "planes.ply");
    size_t vertices = 0;
    for (const auto& o : s.plane_outlines) vertices += o.size();
    out << "element vertex " << vertices
        << "\nproperty float x\nproperty float y\nproperty float z\nelement face "
        << s.plane_outlines.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
    for (const auto& o : s.plane_outlines) {
      for (const Eigen::Vector3d& v : o) out << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
    }
    size_t first = 0;
    for (const auto& o : s.plane_outlines) {
      const size_t n = std::min<size_t>(o.size(), 255);
      out << n;
      for (size_t i = 0; i < n; ++i) out << ' ' << first + i;
      out << '\n';
      first += o.size();
    }
  }
}

}  // namespace pplvo::exporting

#pragma once
/// What pplvo knows of the scene, for a 3D viewer: the keyframes' 3D points, line segments and
/// plane segments in the world frame (the first camera's), written as PLY.
///
/// Built from a run's event log (pplvo-run --log, or pplvo-logger): the poses (PPLVO_POSE,
/// T_w_c and whether the frame is a reference, i.e. a keyframe) and the lifted features
/// (PPLVO_FEATURES_3D: points and lines with their covariance, planes with their pixels).
#include <string>
#include <vector>

#include "pplvo/core/features.h"
#include "pplvo/core/geometry.h"

namespace pplvo::exporting {

struct SceneExport {
  int keyframes = 0;
  std::vector<Eigen::Vector3d> points;
  std::vector<double> point_sigma_m;  ///< sqrt of the largest eigenvalue of its covariance
  std::vector<int> point_keyframe;    ///< index of the keyframe it came from
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> lines;
  std::vector<int> line_keyframe;
  /// Each plane segment's outline: the convex hull of its pixels cast onto the plane.
  std::vector<std::vector<Eigen::Vector3d>> plane_outlines;
  std::vector<Eigen::Vector3d> plane_normals;
};

/// A plane segment's outline in the camera frame: the convex hull of the pixels labelled with
/// it (`labels`, FrameFeatures::plane_labels) cast along their rays onto the plane. Empty when
/// the labels do not match the camera or no ray meets the plane in front of the camera.
std::vector<Eigen::Vector3d> planeOutline(const PlaneFeature& plane, const cv::Mat& labels,
                                          const PinholeCamera& camera);

/// Collects keyframes into a SceneExport.
class SceneCollector {
 public:
  /// Points whose position sigma is above this are left out (far or barely observed).
  explicit SceneCollector(double max_point_sigma_m = 0.05) : max_sigma_(max_point_sigma_m) {}
  void addKeyframe(const Pose3& T_w_c, const FrameFeatures& lifted);
  const SceneExport& scene() const { return scene_; }

 private:
  double max_sigma_;
  SceneExport scene_;
};

struct LogExportOptions {
  bool all_frames = false;  ///< every posed frame, not only the keyframes (reference frames)
  double max_point_sigma_m = 0.05;
};

/// Reads a run's event log; throws std::runtime_error on a log that cannot be read or holds no
/// pose with lifted features. Bad messages are skipped and counted in `skipped`, as is the
/// incomplete last event of a log cut mid-event (everything before it is used).
SceneExport exportFromLog(const std::string& log_path, const LogExportOptions& options,
                          int* skipped = nullptr);

/// Writes DIR/points.ply (vertices coloured by keyframe, with a sigma property),
/// DIR/lines.ply (vertex pairs and edges) and DIR/planes.ply (faces), ASCII PLY.
void writePly(const SceneExport& scene, const std::string& dir);

}  // namespace pplvo::exporting

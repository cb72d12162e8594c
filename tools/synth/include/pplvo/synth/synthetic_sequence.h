#pragma once
/// Ray-cast synthetic RGB-D sequences with known ground truth (no LCM, no I/O except
/// writeTumFolder). Deterministic for a given SynthOptions (seed included).
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "pplvo/core/camera.h"
#include "pplvo/core/geometry.h"
#include "pplvo/core/rgbd_frame.h"
#include "pplvo/core/trajectory.h"

namespace pplvo::synth {

/// Depth noise of a Kinect-like structured-light sensor.
struct DepthNoiseOptions {
  bool enabled = true;
  double sigma_z_coeff_per_m = 1.425e-3;  ///< sigma_z = coeff * z^2 (paper eq. 1: 1.425e-6 mm^-1)
  bool quantise_disparity = true;         ///< Kinect disparity steps (1/8 px, f*b = 0.075 m baseline)
  double max_range_m = 6.0;               ///< beyond: missing
  double min_range_m = 0.4;               ///< closer: missing
  double grazing_angle_deg = 80.0;        ///< incidence angles above this: missing
  bool edge_dropout = true;               ///< drop pixels at depth discontinuities
  double edge_jump_m = 0.1;               ///< neighbour depth jump that counts as a discontinuity
  double rgb_noise_sigma = 2.0;           ///< additive Gaussian noise on colour, grey levels
  double baseline_m = 0.075;              ///< projector-camera baseline b for disparity f*b/z
  double disparity_step_px = 0.125;       ///< disparity quantisation step (Kinect: 1/8 px)
};

struct SynthOptions {
  std::string scene = "room";   ///< "room" (textured room with boxes, posters, a cabinet)
                                ///< "textureless" (mostly plain walls), "lines" (line-rich)
  int frames = 300;
  uint64_t seed = 1;
  double fps = 30.0;
  int width = 640;
  int height = 480;
  double fx = 525.0, fy = 525.0, cx = 319.5, cy = 239.5;
  double trajectory_scale = 1.0;  ///< scales the hand-held motion amplitude
  bool moving_object = false;     ///< a box that moves independently of the room
  /// Replaces the hand-held trajectory (e.g. a still camera, or one that turns away and
  /// back): called once per frame with the frame index and the hand-held pose of that frame,
  /// returns T_w_c. Empty: the hand-held trajectory.
  std::function<Pose3(int frame, const Pose3& hand_held_T_w_c)> trajectory;
  DepthNoiseOptions noise;
};

/// One rendered frame with its truth.
struct SynthFrame {
  RgbdFrame frame;          ///< noisy colour and depth as a sensor would give them
  cv::Mat depth_true_m;     ///< CV_32FC1 noiseless depth (0 where no surface is hit)
  cv::Mat surface_id;       ///< CV_32SC1 id of the surface hit (-1: none), for plane truth
  cv::Mat dynamic_mask;     ///< CV_8UC1 255 where the moving object is seen
  Pose3 T_w_c = Pose3::Identity();
};

/// A surface seen in a rendered frame (plane-extraction ground truth).
struct VisibleSurface {
  int surface_id = -1;
  int pixels = 0;             ///< pixels of the frame showing this surface
  int pixels_with_depth = 0;  ///< of those, pixels with (noisy) sensor depth
  bool dynamic = false;       ///< part of the moving object
  Eigen::Vector4d plane_w = Eigen::Vector4d::Zero();  ///< [n; d] world, at this frame's time
  Eigen::Vector4d plane_c = Eigen::Vector4d::Zero();  ///< [n; d] camera frame, d > 0
  std::string name;
};

/// A straight edge of the scene geometry (box edge, poster/door border, room corner), world
/// frame, at one frame's time. Visibility is not checked: project it and compare with
/// depth_true_m / surface_id if needed.
struct SceneEdge {
  Eigen::Vector3d a_w = Eigen::Vector3d::Zero();  ///< end points, metres
  Eigen::Vector3d b_w = Eigen::Vector3d::Zero();
  int surface_a = -1;  ///< the (up to) two surfaces meeting at the edge; -1 if none
  int surface_b = -1;
};

/// A procedural indoor scene and a smooth hand-held trajectory through it. World frame: room
/// corner at the origin, x in [0, 6], y in [0, 5], z in [0, 3] m, z up (docs/synthetic.md).
class SyntheticSequence {
 public:
  explicit SyntheticSequence(const SynthOptions& options);
  ~SyntheticSequence();
  SyntheticSequence(SyntheticSequence&&) noexcept;
  SyntheticSequence& operator=(SyntheticSequence&&) noexcept;

  int size() const;
  const PinholeCamera& camera() const;
  const SynthOptions& options() const;
  /// Ground-truth camera-to-world pose of frame i.
  Pose3 pose(int i) const;
  /// Stamp text of frame i as written to rgb.txt / groundtruth.txt ("%.6f", starting at 1.0 s).
  std::string stamp(int i) const;
  /// Renders frame i (independent of the order frames are rendered in). Thread-safe: frames
  /// may be rendered concurrently. Throws std::out_of_range for i outside [0, size()).
  SynthFrame render(int i) const;
  /// Plane [n; d] (n.p + d = 0, world frame) of a surface id, if that surface is planar and
  /// static. n (unit) is the outward normal, pointing into the free space the surface is seen
  /// from, so the plane transformed into any camera frame that sees it has d > 0.
  bool surfacePlane(int surface_id, Eigen::Vector4d* plane_w) const;
  /// The ground-truth trajectory (stamps as stamp(i)).
  Trajectory groundTruth() const;

  /// Plane of a surface id at frame i: like surfacePlane() but also valid for the surfaces of
  /// the moving object (whose planes change with time). Throws std::out_of_range for a bad i.
  bool surfacePlaneAt(int surface_id, int i, Eigen::Vector4d* plane_w) const;
  /// Number of surface ids (ids are 0 .. surfaceCount() - 1).
  int surfaceCount() const;
  /// True for the surfaces of the moving object (surfacePlane() returns false for them).
  bool isDynamicSurface(int surface_id) const;
  /// Surfaces seen in a rendered frame of this sequence with at least `min_pixels` pixels,
  /// most pixels first, with their planes in the world and the camera frame.
  std::vector<VisibleSurface> visibleSurfaces(const SynthFrame& frame, int min_pixels = 1) const;
  /// Every straight edge of the scene at frame i (static ones do not move).
  std::vector<SceneEdge> sceneEdges(int i) const;
  /// The smallest surface id lying on exactly the same plane as `surface_id` (e.g. a poster
  /// and its wall, or coplanar faces of different boxes); the id itself for the moving object;
  /// -1 for an unknown id.
  int planeGroup(int surface_id) const;
  /// Human-readable name of a surface, e.g. "room+z" (floor) or "cabinet-x"; "" if unknown.
  std::string surfaceName(int surface_id) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Writes a TUM-layout folder: rgb/, depth/ (16-bit PNG, scale 5000), rgb.txt, depth.txt,
/// associations.txt (depth first, like the shared ICL folder), groundtruth.txt and
/// calib_params.xml. Optionally depth_true/ (+ depth_true.txt) with the noiseless depth.
/// Uses two threads. Throws std::runtime_error naming the path that could not be written.
void writeTumFolder(const SyntheticSequence& sequence, const std::string& dir,
                    bool write_true_depth = false);

}  // namespace pplvo::synth

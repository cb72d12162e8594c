#pragma once
/// Internal: the procedural room (objects, surfaces, textures) used by SyntheticSequence.
/// World frame: room corner at the origin, x in [0, 6], y in [0, 5], z in [0, 3] metres, z up.
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace pplvo::synth::detail {

/// Procedural texture styles (grey albedo patterns, tinted per surface).
enum class TextureStyle {
  kPlain,     ///< constant albedo: texture-less, smooth shading only
  kNoise,     ///< multi-octave value noise (corner-rich)
  kBlobs,     ///< noise background with random discs and ellipses (corner-rich)
  kText,      ///< light page with rows of dark "words" (corner- and line-rich)
  kStripesU,  ///< bands along the surface u axis (parallel lines)
  kStripesV,  ///< bands along the surface v axis (parallel lines)
  kTiles,     ///< tiles with dark grout lines (line grid)
  kGrid,      ///< thin dark grid lines on a light background
  kPoster,    ///< framed poster: border, blocks, text, discs
  kDoor,      ///< door panel with frame, inner panels and a handle
};

/// One planar, axis-aligned face. Its outward normal (into free space) is sign * e_axis.
struct Surface {
  std::string name;
  int object = -1;          ///< owning object index
  int axis = 0;             ///< normal axis 0 (x), 1 (y), 2 (z)
  double sign = 1.0;        ///< +1 or -1: direction of the outward normal along axis
  int ax_u = 0, ax_v = 1;   ///< in-plane axes for texture coordinates
  int texture = -1;         ///< index into Scene::textures
  cv::Vec3f tint{1, 1, 1};  ///< BGR albedo multiplier
};

/// An axis-aligned box seen from outside, the room seen from inside, or a rectangle.
struct Object {
  enum class Kind { kRoomInside, kBox, kRect } kind = Kind::kBox;
  Eigen::Vector3d lo = Eigen::Vector3d::Zero();  ///< min corner (world, at time 0 if dynamic)
  Eigen::Vector3d hi = Eigen::Vector3d::Zero();  ///< max corner; a rect has lo == hi on rect_axis
  int rect_axis = 0;                             ///< rect only: normal axis
  double rect_sign = 1.0;                        ///< rect only: outward normal sign
  int first_surface = 0;  ///< box/room: face (axis, positive normal) = first + 2 axis + pos
  bool dynamic = false;   ///< moves with Scene::dynamicOffset(t)
};

struct Scene {
  std::vector<Object> objects;
  std::vector<Surface> surfaces;
  /// Per texture a mip pyramid of CV_8UC1 albedo maps (rows along v, cols along u); level L
  /// has 2^L times coarser texels. Sampling picks the level matching the pixel footprint.
  std::vector<std::vector<cv::Mat>> textures;
  double texels_per_m = 200.0;
  Eigen::Vector3d point_light_w{3.0, 2.5, 2.85};
  Eigen::Vector3d dir_light_w{0.6, -0.4, 0.7};  ///< towards the light (normalised on build)
  // Moving object path (centre offset from the time-0 position), see dynamicOffset().
  double dyn_w_rad_s = 0.35;
  double dyn_phase_rad = 0.0;

  /// Translation of dynamic objects at time t seconds relative to their time-0 position.
  Eigen::Vector3d dynamicOffset(double t_s) const;
};

/// Builds the scene: `scene` is "room", "textureless" or "lines" (throws std::invalid_argument
/// otherwise). Deterministic for `seed`. With `moving_object`, a box starts at angle
/// `moving_start_rad` (about the room centre, world z axis) on its elliptic path.
Scene buildScene(const std::string& scene, uint64_t seed, bool moving_object,
                 double moving_start_rad = 0.0);

/// splitmix64 step: deterministic 64-bit hashing/random numbers on every platform.
inline uint64_t splitmix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

/// Small deterministic generator (uniform doubles) for scene and trajectory parameters.
class SplitMix {
 public:
  explicit SplitMix(uint64_t seed) : state_(seed) {}
  uint64_t next() {
    state_ += 0x9E3779B97F4A7C15ull;
    return splitmix64(state_);
  }
  double uniform(double a, double b) {
    return a + (b - a) * static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0);
  }

 private:
  uint64_t state_;
};

}  // namespace pplvo::synth::detail

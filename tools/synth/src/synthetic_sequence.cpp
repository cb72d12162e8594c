#include "pplvo/synth/synthetic_sequence.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <vector>

#include "scene.h"

namespace pplvo::synth {
namespace {

using detail::Object;
using detail::Scene;
using detail::SplitMix;
using detail::Surface;

/// Sum of sinusoids a_k sin(w_k t + phi_k).
struct Wave {
  double a[2] = {0, 0};
  double w[2] = {0, 0};
  double phi[2] = {0, 0};
  double operator()(double t) const {
    return a[0] * std::sin(w[0] * t + phi[0]) + a[1] * std::sin(w[1] * t + phi[1]);
  }
  double amplitude() const { return std::abs(a[0]) + std::abs(a[1]); }
  void scale(double s) {
    a[0] *= s;
    a[1] *= s;
  }
};

Wave makeWave(SplitMix& rng, double a0_lo, double a0_hi, double w0_lo, double w0_hi, double a1_lo,
              double a1_hi, double w1_lo, double w1_hi) {
  Wave wv;
  wv.a[0] = rng.uniform(a0_lo, a0_hi);
  wv.w[0] = rng.uniform(w0_lo, w0_hi);
  wv.phi[0] = rng.uniform(0.0, 2.0 * M_PI);
  wv.a[1] = rng.uniform(a1_lo, a1_hi);
  wv.w[1] = rng.uniform(w1_lo, w1_hi);
  wv.phi[1] = rng.uniform(0.0, 2.0 * M_PI);
  return wv;
}

/// Hand-held trajectory: slow walk around the room centre while looking around.
struct HandHeldTrajectory {
  Eigen::Vector3d centre_w{3.0, 2.3, 1.4};
  Wave x, y, z, yaw, pitch, roll;
  double yaw0 = 0.0, pitch0 = 0.0;

  HandHeldTrajectory(uint64_t seed, double scale) {
    SplitMix rng(detail::splitmix64(seed ^ 0x7A3C0FFEEull));
    x = makeWave(rng, 0.5, 0.75, 0.22, 0.38, 0.02, 0.05, 1.5, 2.5);
    y = makeWave(rng, 0.4, 0.6, 0.22, 0.38, 0.02, 0.05, 1.5, 2.5);
    z = makeWave(rng, 0.05, 0.1, 0.4, 0.6, 0.01, 0.02, 2.0, 3.0);
    yaw = makeWave(rng, 0.5, 0.9, 0.2, 0.32, 0.03, 0.06, 1.0, 1.6);
    pitch = makeWave(rng, 0.08, 0.14, 0.3, 0.5, 0.01, 0.025, 1.5, 2.2);
    roll = makeWave(rng, 0.03, 0.06, 0.3, 0.6, 0.005, 0.012, 1.8, 2.6);
    yaw0 = rng.uniform(0.0, 2.0 * M_PI);
    pitch0 = rng.uniform(0.1, 0.2);  // looking slightly down
    const double s = std::max(0.0, scale);
    // Keep the camera inside the free middle of the room whatever the scale.
    x.scale(std::min(s, 0.9 / x.amplitude()));
    y.scale(std::min(s, 0.7 / y.amplitude()));
    z.scale(std::min(s, 0.25 / z.amplitude()));
    yaw.scale(s);
    pitch.scale(std::min(s, 0.5 / pitch.amplitude()));
    roll.scale(std::min(s, 0.3 / roll.amplitude()));
  }

  Pose3 pose(double t) const {
    const Eigen::Vector3d p = centre_w + Eigen::Vector3d(x(t), y(t), z(t));
    // Body frame: x forward, y left, z up; positive pitch tilts the nose down.
    const Eigen::Matrix3d R_w_b = (Eigen::AngleAxisd(yaw0 + yaw(t), Eigen::Vector3d::UnitZ()) *
                                   Eigen::AngleAxisd(pitch0 + pitch(t), Eigen::Vector3d::UnitY()) *
                                   Eigen::AngleAxisd(roll(t), Eigen::Vector3d::UnitX()))
                                      .toRotationMatrix();
    Eigen::Matrix3d R_b_c;  // camera x right, y down, z forward
    R_b_c << 0, 0, 1, -1, 0, 0, 0, -1, 0;
    Pose3 T = Pose3::Identity();
    T.linear() = R_w_b * R_b_c;
    T.translation() = p;
    return T;
  }
};

void validate(const SynthOptions& o) {
  std::string err;
  if (o.frames < 0) err += " frames < 0;";
  if (o.width <= 0 || o.height <= 0) err += " width/height must be positive;";
  if (!(o.fps > 0) || !std::isfinite(o.fps)) err += " fps must be positive;";
  if (!(std::abs(o.fx) > 0) || !(std::abs(o.fy) > 0) || !std::isfinite(o.fx) ||
      !std::isfinite(o.fy) || !std::isfinite(o.cx) || !std::isfinite(o.cy)) {
    err += " intrinsics must be finite with non-zero focal lengths;";
  }
  if (!(o.trajectory_scale >= 0) || !std::isfinite(o.trajectory_scale)) {
    err += " trajectory_scale must be >= 0;";
  }
  const auto& n = o.noise;
  if (!(n.sigma_z_coeff_per_m >= 0)) err += " noise.sigma_z_coeff_per_m must be >= 0;";
  if (!(n.min_range_m >= 0) || !(n.max_range_m > n.min_range_m)) err += " noise range invalid;";
  if (!(n.rgb_noise_sigma >= 0)) err += " noise.rgb_noise_sigma must be >= 0;";
  if (!(n.baseline_m > 0) || !(n.disparity_step_px > 0)) {
    err += " noise.baseline_m and noise.disparity_step_px must be positive;";
  }
  if (!err.empty()) throw std::invalid_argument("invalid SynthOptions:" + err);
}

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Per-frame geometry of one object: bounds at this time and its image bounding box.
struct FrameObject {
  const Object* obj = nullptr;
  Eigen::Vector3d lo, hi;                // world bounds at this frame
  int u0 = 0, u1 = -1, v0 = 0, v1 = -1;  // pixel bounding box (inclusive)
};

}  // namespace

struct SyntheticSequence::Impl {
  SynthOptions options;
  PinholeCamera camera;
  Scene scene;
  std::vector<Pose3> poses;
  std::vector<float> ray_u;          // (u - cx) / fx per column
  std::vector<float> ray_v;          // (v - cy) / fy per row
  std::vector<int> dynamic_surface;  // 1 where the surface belongs to a moving object
  std::vector<int> plane_group;      // smallest id with the same plane (static surfaces)

  explicit Impl(const SynthOptions& o) : options(o) {
    validate(o);
    camera.width = o.width;
    camera.height = o.height;
    camera.fx = o.fx;
    camera.fy = o.fy;
    camera.cx = o.cx;
    camera.cy = o.cy;
    const HandHeldTrajectory traj(o.seed, o.trajectory_scale);
    // The moving box starts to the right of the initial viewing direction and moves
    // counter-clockwise (to the left), so it crosses the view early in the sequence.
    const double heading0 = traj.yaw0 + traj.yaw(0.0);
    scene = detail::buildScene(o.scene, o.seed, o.moving_object, heading0 - 0.9);
    poses.reserve(o.frames);
    for (int i = 0; i < o.frames; ++i) {
      const Pose3 hand_held = traj.pose(i / o.fps);
      poses.push_back(o.trajectory ? o.trajectory(i, hand_held) : hand_held);
    }
    dynamic_surface.resize(scene.surfaces.size());
    for (size_t s = 0; s < scene.surfaces.size(); ++s) {
      dynamic_surface[s] = scene.objects[scene.surfaces[s].object].dynamic ? 1 : 0;
    }
    const int n = static_cast<int>(scene.surfaces.size());
    plane_group.resize(n);
    for (int a = 0; a < n; ++a) {
      plane_group[a] = a;
      if (dynamic_surface[a]) continue;
      Eigen::Vector4d pa, pb;
      planeAt(a, 0.0, &pa);
      for (int b = 0; b < a; ++b) {
        if (dynamic_surface[b]) continue;
        planeAt(b, 0.0, &pb);
        if (pa == pb) {
          plane_group[a] = plane_group[b];
          break;
        }
      }
    }
  }

  double time(int i) const { return i / options.fps; }

  void checkIndex(int i) const {
    if (i < 0 || i >= static_cast<int>(poses.size())) {
      throw std::out_of_range("synthetic frame index " + std::to_string(i) + " outside [0, " +
                              std::to_string(poses.size()) + ")");
    }
  }

  /// World bounds of an object at time t.
  void bounds(const Object& obj, double t, Eigen::Vector3d* lo, Eigen::Vector3d* hi) const {
    *lo = obj.lo;
    *hi = obj.hi;
    if (obj.dynamic) {
      const Eigen::Vector3d off = scene.dynamicOffset(t);
      *lo += off;
      *hi += off;
    }
  }

  bool planeAt(int id, double t, Eigen::Vector4d* plane_w) const {
    if (id < 0 || id >= static_cast<int>(scene.surfaces.size())) return false;
    const Surface& s = scene.surfaces[id];
    const Object& obj = scene.objects[s.object];
    Eigen::Vector3d lo, hi;
    bounds(obj, t, &lo, &hi);
    double at;
    switch (obj.kind) {
      case Object::Kind::kRoomInside:
        at = s.sign > 0 ? lo[s.axis] : hi[s.axis];
        break;
      case Object::Kind::kBox:
        at = s.sign > 0 ? hi[s.axis] : lo[s.axis];
        break;
      default:
        at = lo[s.axis];
        break;
    }
    if (plane_w) {
      plane_w->setZero();
      (*plane_w)[s.axis] = s.sign;
      (*plane_w)[3] = -s.sign * at;
    }
    return true;
  }

  SynthFrame render(int i) const;
};

namespace {

/// Image-space bounding box of an axis-aligned box seen by the camera; false if invisible.
bool imageBounds(const PinholeCamera& cam, const Pose3& T_c_w, const Eigen::Vector3d& lo,
                 const Eigen::Vector3d& hi, FrameObject* fo) {
  double umin = kInf, umax = -kInf, vmin = kInf, vmax = -kInf;
  int in_front = 0;
  constexpr double kNear = 1e-3;
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d p_w((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(),
                              (k & 4) ? hi.z() : lo.z());
    const Eigen::Vector3d p_c = T_c_w * p_w;
    if (p_c.z() > kNear) {
      ++in_front;
      const Eigen::Vector2d uv = cam.project(p_c);
      umin = std::min(umin, uv.x());
      umax = std::max(umax, uv.x());
      vmin = std::min(vmin, uv.y());
      vmax = std::max(vmax, uv.y());
    }
  }
  if (in_front == 0) return false;
  if (in_front < 8) {  // straddles the camera plane: no safe projection, test every pixel
    fo->u0 = 0;
    fo->v0 = 0;
    fo->u1 = cam.width - 1;
    fo->v1 = cam.height - 1;
    return true;
  }
  fo->u0 = std::max(0, static_cast<int>(std::floor(umin)) - 1);
  fo->v0 = std::max(0, static_cast<int>(std::floor(vmin)) - 1);
  fo->u1 = std::min(cam.width - 1, static_cast<int>(std::ceil(umax)) + 1);
  fo->v1 = std::min(cam.height - 1, static_cast<int>(std::ceil(vmax)) + 1);
  return fo->u0 <= fo->u1 && fo->v0 <= fo->v1;
}

inline float sampleBilinear(const cv::Mat& tex, double u, double v) {
  u = std::min(std::max(u - 0.5, 0.0), tex.cols - 1.001);
  v = std::min(std::max(v - 0.5, 0.0), tex.rows - 1.001);
  const int iu = static_cast<int>(u), iv = static_cast<int>(v);
  const float fu = static_cast<float>(u - iu), fv = static_cast<float>(v - iv);
  const uint8_t* r0 = tex.ptr<uint8_t>(iv) + iu;
  const uint8_t* r1 = tex.ptr<uint8_t>(iv + 1) + iu;
  const float top = r0[0] + fu * (r0[1] - r0[0]);
  const float bot = r1[0] + fu * (r1[1] - r1[0]);
  return (top + fv * (bot - top)) * (1.0f / 255.0f);
}

}  // namespace

SynthFrame SyntheticSequence::Impl::render(int i) const {
  checkIndex(i);
  const int W = camera.width, H = camera.height;
  const double t = time(i);
  const Pose3& T_w_c = poses[i];
  const Pose3 T_c_w = T_w_c.inverse();
  const Eigen::Matrix3d R = T_w_c.linear();
  const Eigen::Vector3d o = T_w_c.translation();

  SynthFrame out;
  out.T_w_c = T_w_c;
  out.depth_true_m.create(H, W, CV_32FC1);
  out.surface_id.create(H, W, CV_32SC1);
  out.dynamic_mask = cv::Mat::zeros(H, W, CV_8UC1);
  cv::Mat cos_incidence(H, W, CV_32FC1);
  cv::Mat bgr(H, W, CV_8UC3);

  // Per-frame object list with image bounds; the room (always hit from inside) comes first.
  const Object* room = nullptr;
  std::vector<FrameObject> objs;
  objs.reserve(scene.objects.size());
  for (const Object& obj : scene.objects) {
    if (obj.kind == Object::Kind::kRoomInside) {
      room = &obj;
      continue;
    }
    FrameObject fo;
    fo.obj = &obj;
    bounds(obj, t, &fo.lo, &fo.hi);
    if (imageBounds(camera, T_c_w, fo.lo, fo.hi, &fo)) objs.push_back(fo);
  }
  // Per-surface texture origin in world coordinates at this frame (object lo corner).
  std::vector<Eigen::Vector3d> surf_lo(scene.surfaces.size());
  for (size_t s = 0; s < scene.surfaces.size(); ++s) {
    Eigen::Vector3d lo, hi;
    bounds(scene.objects[scene.surfaces[s].object], t, &lo, &hi);
    surf_lo[s] = lo;
  }

  const Eigen::Vector3d Ldir = scene.dir_light_w;
  const Eigen::Vector3d Lp = scene.point_light_w;
  const double s_tex = scene.texels_per_m;
  // Texels per pixel per metre of depth on a fronto-parallel surface.
  const double footprint_per_m = s_tex / std::min(std::abs(camera.fx), std::abs(camera.fy));
  const bool noisy = options.noise.enabled;
  const float rgb_sigma = static_cast<float>(noisy ? options.noise.rgb_noise_sigma : 0.0);

  // Per-frame random streams, independent of rendering order.
  const uint64_t frame_key = detail::splitmix64(options.seed ^ detail::splitmix64(0xF00Dull + i));
  cv::Mat rgb_noise;
  if (rgb_sigma > 0) {
    rgb_noise.create(H, W, CV_32FC3);
    cv::RNG rng(frame_key ^ 0xC0104ull);
    rng.fill(rgb_noise, cv::RNG::NORMAL, 0.0, rgb_sigma);
  }

  std::vector<const FrameObject*> row_objs;
  row_objs.reserve(objs.size());
  for (int v = 0; v < H; ++v) {
    row_objs.clear();
    for (const FrameObject& fo : objs) {
      if (v >= fo.v0 && v <= fo.v1) row_objs.push_back(&fo);
    }
    const double rv = (v - camera.cy) / camera.fy;
    const Eigen::Vector3d base = R.col(1) * rv + R.col(2);
    float* zrow = out.depth_true_m.ptr<float>(v);
    int32_t* idrow = out.surface_id.ptr<int32_t>(v);
    uint8_t* dynrow = out.dynamic_mask.ptr<uint8_t>(v);
    float* cosrow = cos_incidence.ptr<float>(v);
    cv::Vec3b* colrow = bgr.ptr<cv::Vec3b>(v);
    const cv::Vec3f* noiserow = rgb_sigma > 0 ? rgb_noise.ptr<cv::Vec3f>(v) : nullptr;
    for (int u = 0; u < W; ++u) {
      const double ru = (u - camera.cx) / camera.fx;
      Eigen::Vector3d d = R.col(0) * ru + base;  // world direction with unit camera depth
      for (int k = 0; k < 3; ++k) {
        if (std::abs(d[k]) < 1e-12) d[k] = 1e-12;
      }
      const Eigen::Vector3d inv = d.cwiseInverse();
      // Room from inside: exit distance.
      double best = kInf;
      int best_surface = -1;
      for (int k = 0; k < 3; ++k) {
        const bool pos = d[k] > 0;
        const double tk = ((pos ? room->hi[k] : room->lo[k]) - o[k]) * inv[k];
        if (tk < best) {
          best = tk;
          // exiting through the hi wall: its normal points to -axis (face 2k + 0)
          best_surface = room->first_surface + 2 * k + (pos ? 0 : 1);
        }
      }
      for (const FrameObject* fo : row_objs) {
        if (u < fo->u0 || u > fo->u1) continue;
        const Object& obj = *fo->obj;
        if (obj.kind == Object::Kind::kBox) {
          double tnear = -kInf, tfar = kInf;
          int axis = 0;
          for (int k = 0; k < 3; ++k) {
            const double t1 = (fo->lo[k] - o[k]) * inv[k];
            const double t2 = (fo->hi[k] - o[k]) * inv[k];
            const double tmin = std::min(t1, t2), tmax = std::max(t1, t2);
            if (tmin > tnear) {
              tnear = tmin;
              axis = k;
            }
            tfar = std::min(tfar, tmax);
          }
          if (tnear <= tfar && tnear > 0 && tnear < best) {
            best = tnear;
            // entering through the lo face when moving along +axis: normal -axis (2k + 0)
            best_surface = obj.first_surface + 2 * axis + (d[axis] > 0 ? 0 : 1);
          }
        } else {  // rectangle
          const int k = obj.rect_axis;
          const double tk = (fo->lo[k] - o[k]) * inv[k];
          // `<=`: a rectangle lying in a wall's plane wins over the wall (the same arithmetic
          // gives bit-identical distances).
          if (tk > 0 && tk <= best) {
            const int a = (k + 1) % 3, b = (k + 2) % 3;
            const double pa = o[a] + tk * d[a], pb = o[b] + tk * d[b];
            if (pa >= fo->lo[a] && pa <= fo->hi[a] && pb >= fo->lo[b] && pb <= fo->hi[b]) {
              best = tk;
              best_surface = obj.first_surface;
            }
          }
        }
      }
      zrow[u] = static_cast<float>(best);
      idrow[u] = best_surface;
      const Surface& surf = scene.surfaces[best_surface];
      if (dynamic_surface[best_surface]) dynrow[u] = 255;
      const Eigen::Vector3d p = o + best * d;
      // Normal along surf.axis with sign surf.sign.
      const double dn = surf.sign * d[surf.axis];
      cosrow[u] = static_cast<float>(std::abs(dn) / d.norm());
      // Lambertian shading: ambient + directional + point light with soft fall-off.
      const Eigen::Vector3d l = Lp - p;
      const double l2 = l.squaredNorm();
      const double cos_p = std::max(0.0, surf.sign * l[surf.axis]) / std::sqrt(l2);
      const double cos_d = std::max(0.0, surf.sign * Ldir[surf.axis]);
      const double shade = 0.42 + 0.28 * cos_d + 0.5 * cos_p * (4.0 / (4.0 + l2));
      const Eigen::Vector3d& slo = surf_lo[best_surface];
      const double tu = (p[surf.ax_u] - slo[surf.ax_u]) * s_tex;
      const double tv = (p[surf.ax_v] - slo[surf.ax_v]) * s_tex;
      // Mip level from the pixel footprint on the surface (texels per pixel), blended
      // linearly between the two nearest levels: no texture aliasing at distance.
      const std::vector<cv::Mat>& mips = scene.textures[surf.texture];
      double footprint = best * footprint_per_m / std::max(0.25, static_cast<double>(cosrow[u]));
      float albedo;
      if (footprint <= 1.0 || mips.size() == 1) {
        albedo = sampleBilinear(mips[0], tu, tv);
      } else {
        int level = 0;
        double scale = 1.0;
        while (footprint >= 2.0 && level + 2 < static_cast<int>(mips.size())) {
          footprint *= 0.5;
          scale *= 0.5;
          ++level;
        }
        const float w = static_cast<float>(std::min(1.0, footprint - 1.0));
        const float a0 = sampleBilinear(mips[level], tu * scale, tv * scale);
        const float a1 = sampleBilinear(mips[level + 1], tu * scale * 0.5, tv * scale * 0.5);
        albedo = a0 + w * (a1 - a0);
      }
      const float g = static_cast<float>(255.0 * shade) * albedo;
      cv::Vec3b& c = colrow[u];
      for (int ch = 0; ch < 3; ++ch) {
        float val = g * surf.tint[ch];
        if (noiserow) val += noiserow[u][ch];
        c[ch] = cv::saturate_cast<uint8_t>(val);
      }
    }
  }

  // Sensor depth.
  cv::Mat depth;
  if (!noisy) {
    depth = out.depth_true_m.clone();
  } else {
    const DepthNoiseOptions& n = options.noise;
    depth.create(H, W, CV_32FC1);
    cv::Mat gauss(H, W, CV_32FC1);
    cv::RNG rng(frame_key ^ 0xDE9742ull);
    rng.fill(gauss, cv::RNG::NORMAL, 0.0, 1.0);
    const double cos_graze = std::cos(n.grazing_angle_deg * M_PI / 180.0);
    const double fb = std::abs(camera.fx) * n.baseline_m;  // px * m
    const double step = n.disparity_step_px;
    const float jump = static_cast<float>(n.edge_jump_m);
    for (int v = 0; v < H; ++v) {
      const float* zt = out.depth_true_m.ptr<float>(v);
      const float* zup = v > 0 ? out.depth_true_m.ptr<float>(v - 1) : nullptr;
      const float* zdn = v + 1 < H ? out.depth_true_m.ptr<float>(v + 1) : nullptr;
      const float* cs = cos_incidence.ptr<float>(v);
      const float* gs = gauss.ptr<float>(v);
      float* zo = depth.ptr<float>(v);
      for (int u = 0; u < W; ++u) {
        const double z = zt[u];
        zo[u] = 0.0f;
        if (!(z > n.min_range_m) || z > n.max_range_m) continue;
        if (cs[u] < cos_graze) continue;
        if (n.edge_dropout) {
          const float zf = zt[u];
          if ((u > 0 && std::abs(zt[u - 1] - zf) > jump) ||
              (u + 1 < W && std::abs(zt[u + 1] - zf) > jump) ||
              (zup && std::abs(zup[u] - zf) > jump) || (zdn && std::abs(zdn[u] - zf) > jump)) {
            continue;
          }
        }
        double zn = z + n.sigma_z_coeff_per_m * z * z * gs[u];
        if (n.quantise_disparity) {
          if (!(zn > 0)) continue;
          const double disp_q = std::round(fb / zn / step) * step;
          if (!(disp_q > 0)) continue;
          zn = fb / disp_q;
        }
        if (zn > 0 && std::isfinite(zn)) zo[u] = static_cast<float>(zn);
      }
    }
  }

  out.frame.utime = static_cast<int64_t>(std::llround((1.0 + t) * 1e6));
  out.frame.seq = i;
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.6f", 1.0 + t);
  out.frame.stamp = buf;
  out.frame.camera = camera;
  out.frame.bgr = bgr;
  out.frame.depth_m = depth;
  return out;
}

SyntheticSequence::SyntheticSequence(const SynthOptions& options)
    : impl_(std::make_unique<Impl>(options)) {}
SyntheticSequence::~SyntheticSequence() = default;
SyntheticSequence::SyntheticSequence(SyntheticSequence&&) noexcept = default;
SyntheticSequence& SyntheticSequence::operator=(SyntheticSequence&&) noexcept = default;

int SyntheticSequence::size() const { return static_cast<int>(impl_->poses.size()); }
const PinholeCamera& SyntheticSequence::camera() const { return impl_->camera; }
const SynthOptions& SyntheticSequence::options() const { return impl_->options; }

Pose3 SyntheticSequence::pose(int i) const {
  impl_->checkIndex(i);
  return impl_->poses[i];
}

std::string SyntheticSequence::stamp(int i) const {
  impl_->checkIndex(i);
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.6f", 1.0 + impl_->time(i));
  return buf;
}

SynthFrame SyntheticSequence::render(int i) const { return impl_->render(i); }

bool SyntheticSequence::surfacePlane(int surface_id, Eigen::Vector4d* plane_w) const {
  if (surface_id < 0 || surface_id >= surfaceCount()) return false;
  if (impl_->dynamic_surface[surface_id]) return false;
  return impl_->planeAt(surface_id, 0.0, plane_w);
}

bool SyntheticSequence::surfacePlaneAt(int surface_id, int i, Eigen::Vector4d* plane_w) const {
  impl_->checkIndex(i);
  return impl_->planeAt(surface_id, impl_->time(i), plane_w);
}

int SyntheticSequence::planeGroup(int surface_id) const {
  if (surface_id < 0 || surface_id >= surfaceCount()) return -1;
  return impl_->plane_group[surface_id];
}

int SyntheticSequence::surfaceCount() const {
  return static_cast<int>(impl_->scene.surfaces.size());
}

bool SyntheticSequence::isDynamicSurface(int surface_id) const {
  return surface_id >= 0 && surface_id < surfaceCount() && impl_->dynamic_surface[surface_id];
}

std::string SyntheticSequence::surfaceName(int surface_id) const {
  if (surface_id < 0 || surface_id >= surfaceCount()) return "";
  return impl_->scene.surfaces[surface_id].name;
}

std::vector<VisibleSurface> SyntheticSequence::visibleSurfaces(const SynthFrame& frame,
                                                               int min_pixels) const {
  const int i = static_cast<int>(frame.frame.seq);
  impl_->checkIndex(i);
  if (frame.surface_id.type() != CV_32SC1 ||
      frame.surface_id.size() != frame.frame.depth_m.size()) {
    throw std::invalid_argument("visibleSurfaces: frame without matching surface_id/depth maps");
  }
  std::vector<int> pixels(surfaceCount(), 0), with_depth(surfaceCount(), 0);
  for (int v = 0; v < frame.surface_id.rows; ++v) {
    const int32_t* id = frame.surface_id.ptr<int32_t>(v);
    const float* z = frame.frame.depth_m.ptr<float>(v);
    for (int u = 0; u < frame.surface_id.cols; ++u) {
      if (id[u] < 0 || id[u] >= surfaceCount()) continue;
      ++pixels[id[u]];
      if (z[u] > 0) ++with_depth[id[u]];
    }
  }
  std::vector<VisibleSurface> out;
  const Pose3& T_w_c = impl_->poses[i];
  for (int id = 0; id < surfaceCount(); ++id) {
    if (pixels[id] < std::max(1, min_pixels)) continue;
    VisibleSurface vs;
    vs.surface_id = id;
    vs.pixels = pixels[id];
    vs.pixels_with_depth = with_depth[id];
    vs.dynamic = isDynamicSurface(id);
    impl_->planeAt(id, impl_->time(i), &vs.plane_w);
    const Eigen::Vector3d n_w = vs.plane_w.head<3>();
    vs.plane_c.head<3>() = T_w_c.linear().transpose() * n_w;
    vs.plane_c[3] = vs.plane_w[3] + n_w.dot(T_w_c.translation());
    vs.name = surfaceName(id);
    out.push_back(std::move(vs));
  }
  std::stable_sort(out.begin(), out.end(), [](const VisibleSurface& a, const VisibleSurface& b) {
    return a.pixels > b.pixels;
  });
  return out;
}

std::vector<SceneEdge> SyntheticSequence::sceneEdges(int i) const {
  impl_->checkIndex(i);
  const double t = impl_->time(i);
  std::vector<SceneEdge> edges;
  for (const Object& obj : impl_->scene.objects) {
    Eigen::Vector3d lo, hi;
    impl_->bounds(obj, t, &lo, &hi);
    if (obj.kind == Object::Kind::kRect) {
      const int k = obj.rect_axis, a = (k + 1) % 3, b = (k + 2) % 3;
      for (int e = 0; e < 4; ++e) {
        // Edges along a (at b = lo or hi) and along b (at a = lo or hi).
        SceneEdge edge;
        edge.a_w = lo;
        edge.b_w = lo;
        if (e < 2) {
          edge.a_w[b] = edge.b_w[b] = e ? hi[b] : lo[b];
          edge.b_w[a] = hi[a];
        } else {
          edge.a_w[a] = edge.b_w[a] = (e == 3) ? hi[a] : lo[a];
          edge.b_w[b] = hi[b];
        }
        edge.surface_a = obj.first_surface;
        edges.push_back(edge);
      }
      continue;
    }
    // Box or room: 12 edges, 4 along each axis k, at the corners of the other two axes.
    for (int k = 0; k < 3; ++k) {
      const int a = (k + 1) % 3, b = (k + 2) % 3;
      for (int c = 0; c < 4; ++c) {
        const bool a_hi = c & 1, b_hi = c & 2;
        SceneEdge edge;
        edge.a_w[k] = lo[k];
        edge.b_w[k] = hi[k];
        edge.a_w[a] = edge.b_w[a] = a_hi ? hi[a] : lo[a];
        edge.a_w[b] = edge.b_w[b] = b_hi ? hi[b] : lo[b];
        // Faces meeting there: box face at hi has a +axis normal (index 2 axis + 1); the room's
        // wall at hi faces inwards (-axis, index 2 axis + 0).
        const bool room = obj.kind == Object::Kind::kRoomInside;
        edge.surface_a = obj.first_surface + 2 * a + ((a_hi != room) ? 1 : 0);
        edge.surface_b = obj.first_surface + 2 * b + ((b_hi != room) ? 1 : 0);
        edges.push_back(edge);
      }
    }
  }
  return edges;
}

Trajectory SyntheticSequence::groundTruth() const {
  Trajectory traj;
  traj.reserve(impl_->poses.size());
  for (int i = 0; i < size(); ++i) {
    StampedPose p;
    p.stamp_text = stamp(i);
    p.stamp = 1.0 + impl_->time(i);
    p.T_w_c = impl_->poses[i];
    traj.push_back(p);
  }
  return traj;
}

}  // namespace pplvo::synth

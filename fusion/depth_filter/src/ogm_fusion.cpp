#include "pplvo/depth_filter/ogm_fusion.h"

#include <algorithm>
#include <cmath>

namespace pplvo::depth_filter {

OgmFusion::OgmFusion(const Options& options) : options_(options) {
  options_.max_window = std::max(1, options_.max_window);
  options_.k_consistency = std::max(1, options_.k_consistency);
}

void OgmFusion::warn(const std::string& what) {
  ++stats_.warnings;
  stats_.last_warning = what;
}

void OgmFusion::configure(const PinholeCamera& camera) {
  camera_ = camera;
  configured_ = true;
  const int w = camera.width, h = camera.height;
  slots_.assign(static_cast<size_t>(options_.max_window), Slot());
  for (Slot& s : slots_) {
    s.depth_m.create(h, w, CV_32FC1);
    s.weight.create(h, w, CV_32FC1);
  }
  ray_x_.resize(static_cast<size_t>(w));
  ray_y_.resize(static_cast<size_t>(h));
  for (int u = 0; u < w; ++u) ray_x_[u] = static_cast<float>((u - camera.cx) / camera.fx);
  for (int v = 0; v < h; ++v) ray_y_[v] = static_cast<float>((v - camera.cy) / camera.fy);
  cos_.resize(static_cast<size_t>(w) * h);
  inv_cos_.resize(static_cast<size_t>(w) * h);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const double x = ray_x_[u], y = ray_y_[v];
      const double norm = std::sqrt(x * x + y * y + 1.0);
      cos_[static_cast<size_t>(v) * w + u] = static_cast<float>(1.0 / norm);
      inv_cos_[static_cast<size_t>(v) * w + u] = static_cast<float>(norm);
    }
  }
  acc_.assign(static_cast<size_t>(w) * h, Acc{0, 0, 0, 0});
  count_.assign(static_cast<size_t>(w) * h, 0);
  ax_.assign(static_cast<size_t>(w), 0.f);
  ay_.assign(static_cast<size_t>(w), 0.f);
  az_.assign(static_cast<size_t>(w), 0.f);
  idx_.assign(static_cast<size_t>(w), -1);
  range_.assign(static_cast<size_t>(w), 0.f);
}

void OgmFusion::reset() {
  for (Slot& s : slots_) {
    s.used = false;
    s.has_pose = false;
  }
  ++stats_.window_resets;
}

int OgmFusion::windowSize() const {
  int n = 0;
  for (const Slot& s : slots_) n += s.used ? 1 : 0;
  return n;
}

OgmFusion::Slot* OgmFusion::find(int64_t seq) {
  for (Slot& s : slots_) {
    if (s.used && s.seq == seq) return &s;
  }
  return nullptr;
}

bool OgmFusion::contains(int64_t seq) const {
  for (const Slot& s : slots_) {
    if (s.used && s.seq == seq) return true;
  }
  return false;
}

bool OgmFusion::addFrame(int64_t seq, const PinholeCamera& camera, const DepthWithVariance& cgm) {
  if (!camera.valid() || cgm.depth_m.type() != CV_32FC1 || cgm.var_m2.type() != CV_32FC1 ||
      cgm.depth_m.rows != camera.height || cgm.depth_m.cols != camera.width ||
      cgm.var_m2.size() != cgm.depth_m.size()) {
    ++stats_.invalid_inputs;
    warn("addFrame: depth/variance not CV_32FC1 of the camera size (frame " + std::to_string(seq) +
         " ignored)");
    return false;
  }
  if (!configured_ || camera != camera_) {
    if (configured_) {
      ++stats_.size_changes;
      ++stats_.window_resets;
      warn("addFrame: camera changed (now " + std::to_string(camera.width) + "x" +
           std::to_string(camera.height) + "): window reset");
    }
    configure(camera);
  }
  Slot* slot = find(seq);
  if (!slot) {
    for (Slot& s : slots_) {
      if (!s.used) {
        slot = &s;
        break;
      }
    }
  }
  if (!slot) {
    slot = &slots_[0];
    for (Slot& s : slots_) {
      if (s.seq < slot->seq) slot = &s;
    }
    ++stats_.evicted_capacity;
  }
  slot->used = true;
  slot->has_pose = false;
  slot->seq = seq;
  const int w = camera.width, h = camera.height;
  int64_t bad = 0;
  for (int v = 0; v < h; ++v) {
    const float* zi = cgm.depth_m.ptr<float>(v);
    const float* vi = cgm.var_m2.ptr<float>(v);
    float* zo = slot->depth_m.ptr<float>(v);
    float* wo = slot->weight.ptr<float>(v);
    const float* cs = &cos_[static_cast<size_t>(v) * w];
    int32_t bad_row = 0;
    for (int u = 0; u < w; ++u) {  // branch-free (vectorised); NaN fails every comparison
      const float z = zi[u], var = vi[u];
      const bool ok = (z > 0.f) & (z < 1e30f) & (var > 0.f) & (var < 1e30f);
      bad_row += static_cast<int32_t>(!ok & (z != 0.f));
      const float var_safe = ok ? var : 1.f;
      zo[u] = ok ? z : 0.f;
      wo[u] = ok ? (cs[u] * cs[u]) / var_safe : 0.f;  // 1 / sigma_r^2, eq. (6)
    }
    bad += bad_row;
  }
  stats_.invalid_pixels += bad;
  ++stats_.frames_added;
  return true;
}

bool OgmFusion::setWindowUncertainty(int64_t seq, double max_translation_variance_m2) {
  Slot* s = find(seq);
  if (!s) return false;
  if (max_translation_variance_m2 <= options_.max_translation_variance_m2) return false;
  s->used = false;  // also for NaN: an unknown uncertainty is not a small one
  s->has_pose = false;
  ++stats_.evicted_uncertainty;
  return true;
}

namespace {

/// Inputs of projectRow: one row of a past frame and its transform into the current camera.
struct RowProjection {
  const float* z;             ///< depth of the row (0 = missing)
  const float *ax, *ay, *az;  ///< R * (x_u, 0, 0) per column
  float bx, by, bz;           ///< R * (0, y_v, 1) for the row
  float tx, ty, tz;           ///< translation of T_c_k
  float fx, fy, cx, cy, min_z, umax, vmax;
  int w;
};

/// Transforms and projects one row, branch-free so that it vectorises: p_c = z R ray + t,
/// idx = nearest pixel (-1: none), range = |p_c|. Compiled for AVX2 and for baseline x86-64,
/// chosen at load time (GCC function multi-versioning).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
__attribute__((target_clones("avx2", "default")))
#endif
void projectRow(const RowProjection& p, int32_t* __restrict idx, float* __restrict range) {
  const float* __restrict z = p.z;
  const float* __restrict ax = p.ax;
  const float* __restrict ay = p.ay;
  const float* __restrict az = p.az;
  const float bx = p.bx, by = p.by, bz = p.bz, tx = p.tx, ty = p.ty, tz = p.tz;
  const float fx = p.fx, fy = p.fy, cx = p.cx, cy = p.cy, min_z = p.min_z;
  const float umax = p.umax, vmax = p.vmax;
  const int w = p.w;
  for (int u = 0; u < w; ++u) {
    const float zk = z[u];
    const float px = zk * (ax[u] + bx) + tx;
    const float py = zk * (ay[u] + by) + ty;
    const float pz = zk * (az[u] + bz) + tz;
    const float pzc = pz > min_z ? pz : 1.f;
    const float inv = 1.f / pzc;
    const float uf = fx * px * inv + cx, vf = fy * py * inv + cy;
    // Selects rather than && / int-float round trips: GCC 12 vectorises this form for both
    // SSE2 and AVX2. Clamping before the conversion keeps it defined for any input (NaN too).
    float okf = zk > 0.f ? 1.f : 0.f;
    okf = pz > min_z ? okf : 0.f;
    okf = uf >= -0.5f ? okf : 0.f;
    okf = uf < umax ? okf : 0.f;
    okf = vf >= -0.5f ? okf : 0.f;
    okf = vf < vmax ? okf : 0.f;
    const float ur = uf + 0.5f, vr = vf + 0.5f;
    const float ufc = ur > 0.f ? (ur < umax + 0.5f ? ur : 0.f) : 0.f;
    const float vfc = vr > 0.f ? (vr < vmax + 0.5f ? vr : 0.f) : 0.f;
    const int32_t cand = static_cast<int32_t>(vfc) * w + static_cast<int32_t>(ufc);
    idx[u] = okf > 0.5f ? cand : -1;
    range[u] = std::sqrt(px * px + py * py + pz * pz);
  }
}

bool finitePose(const Pose3& T) {
  const auto& M = T.matrix();
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) {
      if (!std::isfinite(M(i, j))) return false;
    }
  }
  return isValidPose(T, 1e-4);
}

}  // namespace

OgmResult OgmFusion::fuse(int64_t seq, const Pose3& T_w_c) {
  OgmResult result;
  fuse(seq, T_w_c, &result);
  return result;
}

void OgmFusion::fuse(int64_t seq, const Pose3& T_w_c, OgmResult* result_ptr) {
  OgmResult& result = *result_ptr;
  result.ok = false;
  result.warning.clear();
  Slot* cur = find(seq);
  if (!cur) {
    ++stats_.unknown_frame_poses;
    result.warning = "fuse: pose for frame " + std::to_string(seq) + " not in the window";
    warn(result.warning);
    result.depth = DepthWithVariance();
    return;
  }
  if (!finitePose(T_w_c)) {
    ++stats_.invalid_poses;
    cur->used = false;  // a frame without a usable pose cannot serve later frames either
    result.warning = "fuse: invalid (NaN or non-rigid) pose for frame " + std::to_string(seq);
    warn(result.warning);
    result.depth = DepthWithVariance();
    return;
  }
  cur->T_w_c = T_w_c;
  cur->has_pose = true;

  const int w = camera_.width, h = camera_.height;
  std::fill(count_.begin(), count_.end(), static_cast<uint8_t>(0));

  // Current frame first, at its own pixels: the first point of a pixel sets its reference.
  for (int v = 0; v < h; ++v) {
    const float* z = cur->depth_m.ptr<float>(v);
    const float* wt = cur->weight.ptr<float>(v);
    const float* ic = &inv_cos_[static_cast<size_t>(v) * w];
    Acc* a = &acc_[static_cast<size_t>(v) * w];
    uint8_t* n = &count_[static_cast<size_t>(v) * w];
    for (int u = 0; u < w; ++u) {
      if (!(z[u] > 0.f)) continue;
      a[u] = Acc{z[u] * ic[u], wt[u], 0.f, 1.f};  // range z / cos; s_wq = w sigma^2 = 1
      n[u] = 1;
    }
  }

  // Past frames with a pose, newest to oldest.
  std::vector<Slot*>& past = past_;
  past.clear();
  for (Slot& s : slots_) {
    if (s.used && s.has_pose && s.seq < seq) past.push_back(&s);
  }
  std::sort(past.begin(), past.end(), [](const Slot* a, const Slot* b) { return a->seq > b->seq; });

  const Pose3 T_c_w = T_w_c.inverse();
  const float fx = static_cast<float>(camera_.fx), fy = static_cast<float>(camera_.fy);
  const float cx = static_cast<float>(camera_.cx), cy = static_cast<float>(camera_.cy);
  const float min_z = static_cast<float>(options_.min_depth_m);
  const int k = std::min(options_.k_consistency, 255);
  const float g2 = static_cast<float>(options_.gate_sigma * options_.gate_sigma);
  const float umax = static_cast<float>(w) - 0.5f, vmax = static_cast<float>(h) - 0.5f;
  float* ax = ax_.data();
  float* ay = ay_.data();
  float* az = az_.data();
  int32_t* idx = idx_.data();
  float* range = range_.data();
  int64_t projected = 0, gated = 0;
  for (Slot* s : past) {
    const Pose3 T_c_k = T_c_w * s->T_w_c;
    const Eigen::Matrix3f R = T_c_k.linear().cast<float>();
    const float tx = static_cast<float>(T_c_k.translation().x());
    const float ty = static_cast<float>(T_c_k.translation().y());
    const float tz = static_cast<float>(T_c_k.translation().z());
    for (int u = 0; u < w; ++u) {
      ax[u] = R(0, 0) * ray_x_[u];
      ay[u] = R(1, 0) * ray_x_[u];
      az[u] = R(2, 0) * ray_x_[u];
    }
    for (int v = 0; v < h; ++v) {
      const float* z = s->depth_m.ptr<float>(v);
      const float* wt = s->weight.ptr<float>(v);
      const float ry = ray_y_[v];
      const float bx = R(0, 1) * ry + R(0, 2), by = R(1, 1) * ry + R(1, 2),
                  bz = R(2, 1) * ry + R(2, 2);
      projectRow(RowProjection{z, ax, ay, az, bx, by, bz, tx, ty, tz, fx, fy, cx, cy, min_z, umax,
                               vmax, w},
                 idx, range);
      // Accumulate (scattered).
      for (int u = 0; u < w; ++u) {
        const int32_t i = idx[u];
        if (i < 0) continue;
        ++projected;
        Acc& a = acc_[static_cast<size_t>(i)];
        uint8_t& n = count_[static_cast<size_t>(i)];
        const float r = range[u], wk = wt[u];
        if (n == 0) {
          a = Acc{r, wk, 0.f, 1.f};
          n = 1;
          continue;
        }
        const float d = r - a.r0;
        if (n >= k) {  // consistency gate, section 3.4: |d - mean| > g sigma, times S_w^2
          const float e = d * a.s_w - a.s_wd;
          if (e * e > g2 * (a.s_wq * a.s_w - a.s_wd * a.s_wd)) {
            ++gated;
            continue;
          }
        }
        a.s_w += wk;
        a.s_wd += wk * d;
        a.s_wq += wk * d * d + 1.f;
        if (n < 255) ++n;
      }
    }
  }
  stats_.points_projected += projected;
  stats_.points_gated += gated;

  // Eq. (7) and the GM variance; back to depth with z = r cos(alpha).
  DepthWithVariance& out = result.depth;
  out.depth_m.create(h, w, CV_32FC1);
  out.var_m2.create(h, w, CV_32FC1);
  int64_t filled = 0;
  for (int v = 0; v < h; ++v) {
    const float* zc = cur->depth_m.ptr<float>(v);
    const float* cs = &cos_[static_cast<size_t>(v) * w];
    const Acc* a = &acc_[static_cast<size_t>(v) * w];
    const uint8_t* n = &count_[static_cast<size_t>(v) * w];
    float* oz = out.depth_m.ptr<float>(v);
    float* ov = out.var_m2.ptr<float>(v);
    int32_t filled_row = 0;
    for (int u = 0; u < w; ++u) {  // branch-free (vectorised); unused pixels select 0
      const bool has = n[u] != 0;
      const float sw = has ? a[u].s_w : 1.f;
      const float inv = 1.f / sw;
      const float mean_d = a[u].s_wd * inv;
      // The GM variance is at least 1/S_w for one point; the floor only guards rounding.
      const float var_r = std::max(a[u].s_wq * inv - mean_d * mean_d, 1e-3f * inv);
      const float c = cs[u];
      oz[u] = has ? (a[u].r0 + mean_d) * c : 0.f;
      ov[u] = has ? var_r * c * c : 0.f;
      filled_row += static_cast<int32_t>(has & !(zc[u] > 0.f));
    }
    filled += filled_row;
  }
  stats_.pixels_filled += filled;
  out.window_length = 1 + static_cast<int>(past.size());
  stats_.last_window_length = out.window_length;
  ++stats_.frames_fused;
  result.ok = true;
}

}  // namespace pplvo::depth_filter

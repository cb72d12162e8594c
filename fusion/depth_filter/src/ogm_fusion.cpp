#include "pplvo/depth_filter/ogm_fusion.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <thread>

#include "pplvo/core/parallel.h"

namespace pplvo::depth_filter {

int ogmThreads(const OgmOptions& options) {
  if (options.threads > 0) return options.threads;
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()) - 1);
}

OgmFusion::OgmFusion(const Options& options) : options_(options) {
  // Ranges: visit(V&, OgmOptions&) (the configuration rejects other values).
  assert(options_.max_window >= 1 && options_.k_consistency >= 1 && options_.threads >= 0);
  options_.threads = ogmThreads(options_);
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
    s.row_zmin.assign(static_cast<size_t>(h), 0.f);
    s.row_zmax.assign(static_cast<size_t>(h), 0.f);
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
  past_.reserve(slots_.size());
  frames_.reserve(slots_.size());
  ray_rot_.assign(slots_.size() * 3 * static_cast<size_t>(w), 0.f);
  const int n = std::min(options_.threads, h);
  bands_.assign(static_cast<size_t>(n), Band());
  for (int b = 0; b < n; ++b) {
    Band& band = bands_[static_cast<size_t>(b)];
    band.v0 = static_cast<int>(static_cast<int64_t>(h) * b / n);
    band.v1 = static_cast<int>(static_cast<int64_t>(h) * (b + 1) / n);
    band.idx.assign(static_cast<size_t>(w), -1);
    band.range.assign(static_cast<size_t>(w), 0.f);
  }
}

void OgmFusion::fuseOnPose(int64_t seq, const FramePose& pose, const PinholeCamera& camera,
                           const DepthWithVariance& depth, OgmResult* result, int window_limit) {
  if (pose.status == TrackingStatus::kLost || pose.status == TrackingStatus::kReinitialised) {
    reset();  // poses across a tracking loss cannot register the window
  }
  for (const WindowUncertainty& w : pose.window) {
    setWindowUncertainty(w.seq, w.max_translation_variance_m2);
  }
  addFrame(seq, camera, depth);
  fuse(seq, pose.T_w_c, result, window_limit);
  result->depth.time_alignment = depth.time_alignment;  // the current frame's depth leads
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

namespace {

/// One row of addFrame: depth and range weight 1 / sigma_r^2 (eq. 7) of the valid points (0
/// elsewhere), the row's depth range (both 0 without a point) and the count of invalid
/// non-zero samples. Compiled for AVX2 and for baseline x86-64, chosen at load time; the same
/// float operations either way, so the stored window is bit for bit the same.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
__attribute__((target_clones("avx2", "default")))
#endif
int32_t
storeRow(const float* __restrict zi, const float* __restrict vi, const float* __restrict cs, int w,
         float* __restrict zo, float* __restrict wo, float* zmin, float* zmax) {
  int32_t bad = 0;
  for (int u = 0; u < w; ++u) {  // branch-free: vectorised
    const float z = zi[u], var = vi[u];
    // Float selects, not && (which GCC 12 keeps as branches); NaN fails every comparison.
    float okf = z > 0.f ? 1.f : 0.f;
    okf = z < 1e30f ? okf : 0.f;
    okf = var > 0.f ? okf : 0.f;
    okf = var < 1e30f ? okf : 0.f;
    const bool ok = okf > 0.5f;
    bad += static_cast<int32_t>(z != 0.f ? 1.f - okf : 0.f);
    const float var_safe = ok ? var : 1.f;
    zo[u] = ok ? z : 0.f;
    wo[u] = ok ? (cs[u] * cs[u]) / var_safe : 0.f;
  }
  // Depth range of the stored points (0 = none) as integers: positive floats order like
  // their bits.
  int32_t zmin_bits = std::numeric_limits<int32_t>::max(), zmax_bits = 0;
  for (int u = 0; u < w; ++u) {
    int32_t bits;
    std::memcpy(&bits, &zo[u], sizeof bits);
    zmin_bits = std::min(zmin_bits, bits > 0 ? bits : std::numeric_limits<int32_t>::max());
    zmax_bits = std::max(zmax_bits, bits);
  }
  if (zmax_bits == 0) zmin_bits = 0;  // no point: both 0
  std::memcpy(zmin, &zmin_bits, sizeof zmin_bits);
  std::memcpy(zmax, &zmax_bits, sizeof zmax_bits);
  return bad;
}

}  // namespace

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
    bad += storeRow(cgm.depth_m.ptr<float>(v), cgm.var_m2.ptr<float>(v),
                    &cos_[static_cast<size_t>(v) * w], w, slot->depth_m.ptr<float>(v),
                    slot->weight.ptr<float>(v), &slot->row_zmin[static_cast<size_t>(v)],
                    &slot->row_zmax[static_cast<size_t>(v)]);
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

void OgmFusion::fuse(int64_t seq, const Pose3& T_w_c, OgmResult* result_ptr, int window_limit) {
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

  // Past frames with a pose, newest to oldest, and their transforms into the current camera.
  std::vector<Slot*>& past = past_;
  past.clear();
  for (Slot& s : slots_) {
    if (s.used && s.has_pose && s.seq < seq) past.push_back(&s);
  }
  std::sort(past.begin(), past.end(), [](const Slot* a, const Slot* b) { return a->seq > b->seq; });
  if (window_limit > 0 && past.size() + 1 > static_cast<size_t>(window_limit)) {
    past.resize(static_cast<size_t>(window_limit - 1));  // the oldest ones wait for later
    ++stats_.frames_fused_limited;
  }
  const Pose3 T_c_w = T_w_c.inverse();
  frames_.clear();
  for (size_t j = 0; j < past.size(); ++j) {
    const Pose3 T_c_k = T_c_w * past[j]->T_w_c;
    const Eigen::Matrix3f R = T_c_k.linear().cast<float>();
    PastFrame f;
    f.slot = past[j];
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) f.r[3 * r + c] = R(r, c);
    }
    f.tx = static_cast<float>(T_c_k.translation().x());
    f.ty = static_cast<float>(T_c_k.translation().y());
    f.tz = static_cast<float>(T_c_k.translation().z());
    float* ax = &ray_rot_[3 * j * static_cast<size_t>(w)];
    float* ay = ax + w;
    float* az = ay + w;
    for (int u = 0; u < w; ++u) {
      ax[u] = R(0, 0) * ray_x_[u];
      ay[u] = R(1, 0) * ray_x_[u];
      az[u] = R(2, 0) * ray_x_[u];
    }
    f.ax = ax;
    f.ay = ay;
    f.az = az;
    frames_.push_back(f);
  }

  DepthWithVariance& out = result.depth;
  out.depth_m.create(h, w, CV_32FC1);
  out.var_m2.create(h, w, CV_32FC1);
  for (Band& b : bands_) b.projected = b.gated = b.filled = 0;
  // Bands write disjoint rows of the accumulator, the counts and the output.
  const int n = static_cast<int>(bands_.size());
  forEachTask(n, n, [&](int b) { fuseBand(*cur, out, bands_[static_cast<size_t>(b)]); });
  for (const Band& b : bands_) {
    stats_.points_projected += b.projected;
    stats_.points_gated += b.gated;
    stats_.pixels_filled += b.filled;
  }
  out.window_length = 1 + static_cast<int>(past.size());
  stats_.last_window_length = out.window_length;
  ++stats_.frames_fused;
  result.ok = true;
}

bool OgmFusion::rowMayReach(const PastFrame& f, int v, int v0, int v1) const {
  // The target row of a point is floor(vf + 1/2), vf = fy py / pz + cy with
  // p = z (d_u + b) + t, d_u + b = R (x_u, y_v, 1) affine in u. Where pz > 0 on the whole
  // rectangle [0, w-1] x [z_min, z_max] of the row (pz is bilinear: checked at the corners),
  // vf is monotonic in u and in z, so its extremes are at the four corners. The float
  // projection differs from this (evaluated in double on the same float inputs) by rounding
  // only: bounded by the margin where p is far from the image plane and its components do not
  // cancel (pz >= (z |d|_1 + |t|_1) / 4 at the corners, hence everywhere). Otherwise the row
  // is not excluded.
  const Slot& s = *f.slot;
  const double zs[2] = {s.row_zmin[static_cast<size_t>(v)], s.row_zmax[static_cast<size_t>(v)]};
  const float ry = ray_y_[static_cast<size_t>(v)];
  const float bx = f.r[1] * ry + f.r[2], by = f.r[4] * ry + f.r[5], bz = f.r[7] * ry + f.r[8];
  const double t1 = std::abs(f.tx) + std::abs(f.ty) + std::abs(f.tz);
  const double min_z = options_.min_depth_m;
  const double fy = camera_.fy, cy = camera_.cy;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  const int us[2] = {0, camera_.width - 1};
  for (const int u : us) {
    const double dx = static_cast<double>(f.ax[u]) + bx, dy = static_cast<double>(f.ay[u]) + by,
                 dz = static_cast<double>(f.az[u]) + bz;
    const double d1 = std::abs(dx) + std::abs(dy) + std::abs(dz);
    for (const double z : zs) {
      const double py = z * dy + f.ty, pz = z * dz + f.tz;
      if (!(pz > min_z) || !(4.0 * pz >= z * d1 + t1)) return true;
      const double vf = fy * py / pz + cy;
      lo = std::min(lo, vf);
      hi = std::max(hi, vf);
    }
  }
  // Rounding of the float projection under the conditions above: < 1e-5 (|fy| + |cy|) px.
  const double margin = 1.0 + 1e-4 * (std::abs(fy) + std::abs(cy));
  return hi + 0.5 + margin >= v0 && lo + 0.5 - margin < v1;
}

void OgmFusion::fuseBand(const Slot& cur, DepthWithVariance& out, Band& band) {
  const int w = camera_.width, h = camera_.height;
  const int v0 = band.v0, v1 = band.v1;
  std::fill(count_.begin() + static_cast<ptrdiff_t>(v0) * w,
            count_.begin() + static_cast<ptrdiff_t>(v1) * w, static_cast<uint8_t>(0));

  // Current frame first, at its own pixels: the first point of a pixel sets its reference.
  for (int v = v0; v < v1; ++v) {
    const float* z = cur.depth_m.ptr<float>(v);
    const float* wt = cur.weight.ptr<float>(v);
    const float* ic = &inv_cos_[static_cast<size_t>(v) * w];
    Acc* a = &acc_[static_cast<size_t>(v) * w];
    uint8_t* n = &count_[static_cast<size_t>(v) * w];
    for (int u = 0; u < w; ++u) {
      if (!(z[u] > 0.f)) continue;
      a[u] = Acc{z[u] * ic[u], wt[u], 0.f, 1.f};  // range z / cos; s_wq = w sigma^2 = 1
      n[u] = 1;
    }
  }

  // Past frames, newest to oldest; each row row-major, only the points landing in the band.
  const float fx = static_cast<float>(camera_.fx), fy = static_cast<float>(camera_.fy);
  const float cx = static_cast<float>(camera_.cx), cy = static_cast<float>(camera_.cy);
  const float min_z = static_cast<float>(options_.min_depth_m);
  const int k = std::min(options_.k_consistency, 255);
  const float g2 = static_cast<float>(options_.gate_sigma * options_.gate_sigma);
  const float umax = static_cast<float>(w) - 0.5f, vmax = static_cast<float>(h) - 0.5f;
  const bool whole = v0 == 0 && v1 == h;
  const int32_t first = v0 * w;  // band's pixels: [first, first + size)
  const uint32_t size = static_cast<uint32_t>(v1 - v0) * static_cast<uint32_t>(w);
  int32_t* idx = band.idx.data();
  float* range = band.range.data();
  int64_t projected = 0, gated = 0;
  for (const PastFrame& f : frames_) {
    const Slot& s = *f.slot;
    for (int v = 0; v < h; ++v) {
      if (!(s.row_zmax[static_cast<size_t>(v)] > 0.f)) continue;  // no point in this row
      if (!whole && !rowMayReach(f, v, v0, v1)) continue;
      const float* z = s.depth_m.ptr<float>(v);
      const float* wt = s.weight.ptr<float>(v);
      const float ry = ray_y_[static_cast<size_t>(v)];
      const float bx = f.r[1] * ry + f.r[2], by = f.r[4] * ry + f.r[5], bz = f.r[7] * ry + f.r[8];
      projectRow(RowProjection{z, f.ax, f.ay, f.az, bx, by, bz, f.tx, f.ty, f.tz, fx, fy, cx, cy,
                               min_z, umax, vmax, w},
                 idx, range);
      // Accumulate (scattered).
      for (int u = 0; u < w; ++u) {
        const int32_t i = idx[u];
        // Outside the band or none (-1): i - first >= 0 and < size fails as unsigned.
        if (static_cast<uint32_t>(i - first) >= size) continue;
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
  band.projected = projected;
  band.gated = gated;

  // Eq. (7) and the GM variance; back to depth with z = r cos(alpha).
  int64_t filled = 0;
  for (int v = v0; v < v1; ++v) {
    const float* zc = cur.depth_m.ptr<float>(v);
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
  band.filled = filled;
}

}  // namespace pplvo::depth_filter

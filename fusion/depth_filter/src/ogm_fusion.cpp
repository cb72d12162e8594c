#include "pplvo/depth_filter/ogm_fusion.h"

#include <algorithm>
#include <cmath>
#include <cstring>

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
    s.var_r.create(h, w, CV_32FC1);
  }
  ray_x_.resize(static_cast<size_t>(w));
  ray_y_.resize(static_cast<size_t>(h));
  for (int u = 0; u < w; ++u) ray_x_[u] = static_cast<float>((u - camera.cx) / camera.fx);
  for (int v = 0; v < h; ++v) ray_y_[v] = static_cast<float>((v - camera.cy) / camera.fy);
  cos_.resize(static_cast<size_t>(w) * h);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const double x = ray_x_[u], y = ray_y_[v];
      cos_[static_cast<size_t>(v) * w + u] = static_cast<float>(1.0 / std::sqrt(x * x + y * y + 1.0));
    }
  }
  acc_.assign(static_cast<size_t>(w) * h, Acc{0, 0, 0, 0, 0});
  col_terms_.assign(static_cast<size_t>(3) * w, 0.f);
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
    warn("addFrame: depth/variance not CV_32FC1 of the camera size (frame " +
         std::to_string(seq) + " ignored)");
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
    float* vo = slot->var_r.ptr<float>(v);
    const float* cs = &cos_[static_cast<size_t>(v) * w];
    for (int u = 0; u < w; ++u) {
      const float z = zi[u], var = vi[u];
      const bool ok = z > 0.f && std::isfinite(z) && var > 0.f && std::isfinite(var);
      bad += (!ok && z != 0.f) ? 1 : 0;
      zo[u] = ok ? z : 0.f;
      vo[u] = ok ? var / (cs[u] * cs[u]) : 0.f;  // eq. (6)
    }
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
  Slot* cur = find(seq);
  if (!cur) {
    ++stats_.unknown_frame_poses;
    result.warning = "fuse: pose for frame " + std::to_string(seq) + " not in the window";
    warn(result.warning);
    return result;
  }
  if (!finitePose(T_w_c)) {
    ++stats_.invalid_poses;
    cur->used = false;  // a frame without a usable pose cannot serve later frames either
    result.warning = "fuse: invalid (NaN or non-rigid) pose for frame " + std::to_string(seq);
    warn(result.warning);
    return result;
  }
  cur->T_w_c = T_w_c;
  cur->has_pose = true;

  const int w = camera_.width, h = camera_.height;
  std::memset(static_cast<void*>(acc_.data()), 0, acc_.size() * sizeof(Acc));

  // Current frame first, at its own pixels.
  for (int v = 0; v < h; ++v) {
    const float* z = cur->depth_m.ptr<float>(v);
    const float* vr = cur->var_r.ptr<float>(v);
    const float* cs = &cos_[static_cast<size_t>(v) * w];
    Acc* a = &acc_[static_cast<size_t>(v) * w];
    for (int u = 0; u < w; ++u) {
      if (!(z[u] > 0.f)) continue;
      const double r = z[u] / cs[u];
      const double wgt = 1.0 / vr[u];
      a[u].s_w = wgt;
      a[u].s_wr = wgt * r;
      a[u].s_wq = wgt * r * r + 1.0;
      a[u].count = 1;
    }
  }

  // Past frames with a pose, newest to oldest.
  std::vector<Slot*> past;
  past.reserve(slots_.size());
  for (Slot& s : slots_) {
    if (s.used && s.has_pose && s.seq < seq) past.push_back(&s);
  }
  std::sort(past.begin(), past.end(), [](const Slot* a, const Slot* b) { return a->seq > b->seq; });

  const Pose3 T_c_w = T_w_c.inverse();
  const float fx = static_cast<float>(camera_.fx), fy = static_cast<float>(camera_.fy);
  const float cx = static_cast<float>(camera_.cx), cy = static_cast<float>(camera_.cy);
  const float min_z = static_cast<float>(options_.min_depth_m);
  const int k = options_.k_consistency;
  const double g2 = options_.gate_sigma * options_.gate_sigma;
  const float umax = static_cast<float>(w) - 0.5f, vmax = static_cast<float>(h) - 0.5f;
  std::vector<float>& col_terms = col_terms_;
  int64_t projected = 0, gated = 0;
  for (Slot* s : past) {
    const Pose3 T_c_k = T_c_w * s->T_w_c;
    const Eigen::Matrix3f R = T_c_k.linear().cast<float>();
    const Eigen::Vector3f t = T_c_k.translation().cast<float>();
    for (int u = 0; u < w; ++u) {
      col_terms[3 * u + 0] = R(0, 0) * ray_x_[u];
      col_terms[3 * u + 1] = R(1, 0) * ray_x_[u];
      col_terms[3 * u + 2] = R(2, 0) * ray_x_[u];
    }
    for (int v = 0; v < h; ++v) {
      const float* z = s->depth_m.ptr<float>(v);
      const float* vr = s->var_r.ptr<float>(v);
      const float ry = ray_y_[v];
      const float bx = R(0, 1) * ry + R(0, 2), by = R(1, 1) * ry + R(1, 2),
                  bz = R(2, 1) * ry + R(2, 2);
      for (int u = 0; u < w; ++u) {
        const float zk = z[u];
        if (!(zk > 0.f)) continue;
        const float px = zk * (col_terms[3 * u + 0] + bx) + t.x();
        const float py = zk * (col_terms[3 * u + 1] + by) + t.y();
        const float pz = zk * (col_terms[3 * u + 2] + bz) + t.z();
        if (!(pz > min_z)) continue;
        const float inv = 1.f / pz;
        const float uf = fx * px * inv + cx, vf = fy * py * inv + cy;
        if (!(uf >= -0.5f && uf < umax && vf >= -0.5f && vf < vmax)) continue;
        const int iu = static_cast<int>(uf + 0.5f), iv = static_cast<int>(vf + 0.5f);
        Acc& a = acc_[static_cast<size_t>(iv) * w + iu];
        const double r = std::sqrt(static_cast<double>(px) * px + static_cast<double>(py) * py +
                                   static_cast<double>(pz) * pz);
        ++projected;
        if (a.count >= k) {  // consistency gate, section 3.4
          const double mean = a.s_wr / a.s_w;
          const double var = a.s_wq / a.s_w - mean * mean;
          const double d = r - mean;
          if (d * d > g2 * var) {
            ++gated;
            continue;
          }
        }
        const double wgt = 1.0 / vr[u];
        a.s_w += wgt;
        a.s_wr += wgt * r;
        a.s_wq += wgt * r * r + 1.0;
        ++a.count;
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
    float* oz = out.depth_m.ptr<float>(v);
    float* ov = out.var_m2.ptr<float>(v);
    for (int u = 0; u < w; ++u) {
      if (a[u].count == 0) {
        oz[u] = 0.f;
        ov[u] = 0.f;
        continue;
      }
      const double r = a[u].s_wr / a[u].s_w;
      // The GM variance is at least the weighted harmonic mean of the variances (1/S_w * n);
      // the floor only guards rounding.
      const double var_r = std::max(a[u].s_wq / a[u].s_w - r * r, 1e-3 / a[u].s_w);
      const double c = cs[u];
      oz[u] = static_cast<float>(r * c);
      ov[u] = static_cast<float>(var_r * c * c);
      filled += zc[u] > 0.f ? 0 : 1;
    }
  }
  stats_.pixels_filled += filled;
  out.window_length = 1 + static_cast<int>(past.size());
  stats_.last_window_length = out.window_length;
  ++stats_.frames_fused;
  result.ok = true;
  return result;
}

}  // namespace pplvo::depth_filter

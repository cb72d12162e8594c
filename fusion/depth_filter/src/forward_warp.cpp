#include "forward_warp.h"

#include <cstdint>

namespace pplvo::depth_filter::detail {

namespace {

/// Inputs of moveRow: a source row and the transform and camera it is moved into.
struct RowMove {
  const float* z;       ///< the row's depth (0 = none)
  const double* ray_x;  ///< per column
  double ray_y;         ///< of the row
  double r[9], t[3];    ///< T_target_source, rotation row-major
  double fx, fy, cx, cy;
  int w;
};

/// Each point of the row moved -- p = R (x z, y z, z) + t, summed left to right as Eigen's
/// R * p + t does, then fx p_x / p_z + cx as PinholeCamera::project -- into its target
/// position (uf, vf) and depth; a point without depth or behind the camera gets uf = -1e9, off every
/// image. Branch-free so that it vectorises; AVX2 and baseline x86-64 clones (no FMA in
/// either, so every operation rounds as in the scalar code).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
__attribute__((target_clones("avx2", "default")))
#endif
void moveRow(const RowMove& m, double* __restrict uf, double* __restrict vf,
             float* __restrict zt) {
  const float* __restrict z = m.z;
  const double* __restrict rx = m.ray_x;
  const double ry = m.ray_y;
  const double r0 = m.r[0], r1 = m.r[1], r2 = m.r[2], r3 = m.r[3], r4 = m.r[4], r5 = m.r[5],
               r6 = m.r[6], r7 = m.r[7], r8 = m.r[8];
  const double t0 = m.t[0], t1 = m.t[1], t2 = m.t[2];
  const double fx = m.fx, fy = m.fy, cx = m.cx, cy = m.cy;
  const double kFinite = std::numeric_limits<double>::max();
  for (int u = 0; u < m.w; ++u) {
    const double zs = z[u];
    const double x = rx[u] * zs, y = ry * zs;
    const double px = r0 * x + r1 * y + r2 * zs + t0;
    const double py = r3 * x + r4 * y + r5 * zs + t1;
    const double pz = r6 * x + r7 * y + r8 * zs + t2;
    const bool ok = (zs > 0.0) & (zs <= kFinite) & (pz > 0.0);
    const double pzc = ok ? pz : 1.0;
    uf[u] = ok ? fx * px / pzc + cx : -1e9;
    vf[u] = ok ? fy * py / pzc + cy : -1e9;
    zt[u] = static_cast<float>(pz);
  }
}

}  // namespace

void forwardWarpPinholeNearest(const cv::Mat& depth_m, const std::vector<double>& ray_x,
                               const std::vector<double>& ray_y, const PinholeCamera& target,
                               const Pose3& T_target_source, cv::Mat* out_depth) {
  const int w = target.width, h = target.height;
  cv::Mat out(h, w, CV_32FC1, cv::Scalar(std::numeric_limits<float>::infinity()));
  RowMove m{};
  const Eigen::Matrix3d R = T_target_source.linear();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m.r[3 * i + j] = R(i, j);
    m.t[i] = T_target_source.translation()(i);
  }
  m.fx = target.fx;
  m.fy = target.fy;
  m.cx = target.cx;
  m.cy = target.cy;
  m.ray_x = ray_x.data();
  m.w = depth_m.cols;
  std::vector<double> uf(static_cast<size_t>(m.w)), vf(uf.size());
  std::vector<float> zt(uf.size());
  for (int v = 0; v < depth_m.rows; ++v) {
    m.z = depth_m.ptr<float>(v);
    m.ray_y = ray_y[static_cast<size_t>(v)];
    moveRow(m, uf.data(), vf.data(), zt.data());
    // Each point on its nearest pixel in row-major order: the nearest surface wins.
    for (int u = 0; u < m.w; ++u) {
      const long ut = std::lround(uf[static_cast<size_t>(u)]);
      const long vr = std::lround(vf[static_cast<size_t>(u)]);
      if (ut < 0 || vr < 0 || ut >= w || vr >= h) continue;
      float& d = out.at<float>(static_cast<int>(vr), static_cast<int>(ut));
      const float zu = zt[static_cast<size_t>(u)];
      if (zu < d) d = zu;
    }
  }
  closeCracks(out, nullptr, out_depth, nullptr);
}

}  // namespace pplvo::depth_filter::detail

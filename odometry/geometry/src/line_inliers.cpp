#include "line_inliers.h"

namespace pplvo::geometry::detail {

void PointColumns::assign(const std::vector<Eigen::Vector3d>& points) {
  x.resize(points.size());
  y.resize(points.size());
  z.resize(points.size());
  for (size_t q = 0; q < points.size(); ++q) {
    x[q] = points[q].x();
    y[q] = points[q].y();
    z[q] = points[q].z();
  }
}

namespace {

/// Compiled for AVX2 (no FMA, so no contraction) and for baseline x86-64, chosen at load time.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
__attribute__((target_clones("avx2", "default")))
#endif
int markWithinDistance(const double* __restrict px, const double* __restrict py,
                       const double* __restrict pz, int n, double ax, double ay, double az,
                       double dx, double dy, double dz, double dn2, double thr2,
                       char* __restrict inlier) {
  int count = 0;
  for (int q = 0; q < n; ++q) {
    const double ex = px[q] - ax, ey = py[q] - ay, ez = pz[q] - az;
    // Eigen's cross product, then squaredNorm summed left to right.
    const double cx = ey * dz - ez * dy;
    const double cy = ez * dx - ex * dz;
    const double cz = ex * dy - ey * dx;
    const double dist2 = (cx * cx + cy * cy + cz * cz) / dn2;
    const char in = dist2 < thr2 ? 1 : 0;
    inlier[q] = in;
    count += in;
  }
  return count;
}

}  // namespace

int markLineInliers(const PointColumns& points, const Eigen::Vector3d& a, const Eigen::Vector3d& d,
                    double dn2, double thr2, char* inlier) {
  return markWithinDistance(points.x.data(), points.y.data(), points.z.data(), points.size(), a.x(),
                            a.y(), a.z(), d.x(), d.y(), d.z(), dn2, thr2, inlier);
}

}  // namespace pplvo::geometry::detail

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "pplvo/fixtures/box_room.h"
#include "pplvo/geometry/backprojection.h"
#include "pplvo/geometry/line_fit.h"

namespace pplvo::geometry {
namespace {

struct Samples {
  std::vector<Eigen::Vector3d> P;
  std::vector<Eigen::Matrix3d> C;
  std::vector<double> V;
};

// n points uniformly along the true segment A-B, measured with pixel and depth noise
// (sigma_z = coeff z^2) drawn from the model of eqs. 9-10.
Samples sampleLine(const PinholeCamera& cam, const Eigen::Vector3d& A, const Eigen::Vector3d& B,
                   int n, std::mt19937& rng, double coeff = 1.425e-3) {
  std::normal_distribution<double> N(0.0, 1.0);
  std::uniform_real_distribution<double> jitter(-0.5, 0.5);
  Samples s;
  for (int i = 0; i < n; ++i) {
    const double t = (i + 0.5 + 0.3 * jitter(rng)) / n;
    const Eigen::Vector3d X = A + t * (B - A);
    const Eigen::Vector2d px = cam.project(X);
    // Pixel error drawn as the model assumes: iid uniform over one pixel (variance 1/12).
    // (Rounding the projection instead gives errors that are correlated along the line.)
    const double u = px.x() + jitter(rng), v = px.y() + jitter(rng);
    const double sz = coeff * X.z() * X.z();
    const double zm = X.z() + sz * N(rng);
    const Point3WithCov p = backprojectWithCov(cam, u, v, zm, sz * sz);
    s.P.push_back(p.p);
    s.C.push_back(p.cov);
    s.V.push_back(sz * sz);
  }
  return s;
}

TEST(LineFit, RecoversTrueLine) {
  const PinholeCamera cam = fixtures::iclVgaCamera(true);
  std::mt19937 rng(2);
  const Eigen::Vector3d A(-0.6, 0.3, 2.0), B(0.5, -0.2, 2.8);
  const Samples s = sampleLine(cam, A, B, 100, rng);
  const LineFitResult f = fitLineWls(s.P, s.C, s.V, s.P.front(), s.P.back());
  ASSERT_TRUE(f.ok()) << toString(f.status);
  EXPECT_DOUBLE_EQ(f.theta(f.fixed_dim), 1.0);
  EXPECT_LT(fixtures::angleDeg(f.theta, B - A), 1.0);
  const Eigen::Vector3d u = (B - A).normalized();
  auto distToLine = [&](const Eigen::Vector3d& p) { return (p - A).cross(u).norm(); };
  EXPECT_LT(distToLine(f.centroid), 0.01);
  EXPECT_LT(distToLine(f.line.p1), 0.02);
  EXPECT_LT(distToLine(f.line.p2), 0.02);
  EXPECT_LT((f.line.p1 - A).norm(), 0.05);
  EXPECT_LT((f.line.p2 - B).norm(), 0.05);
  // Fixed dimension has the largest range: x here.
  EXPECT_EQ(f.fixed_dim, 0);
  EXPECT_DOUBLE_EQ(f.cov_theta(0, 0), 0.0);
  EXPECT_DOUBLE_EQ(f.cov_theta(0, 1), 0.0);
}

// Monte-Carlo NEES: direction (2-dof theta_m), centroid and endpoints across the line (2 dof).
struct NeesOut {
  double dir = 0, centroid = 0, end1 = 0, end2 = 0;
};
NeesOut neesExperiment(const Eigen::Vector3d& A, const Eigen::Vector3d& B, int n) {
  const PinholeCamera cam = fixtures::iclVgaCamera(true);
  std::mt19937 rng(99);
  const int trials = 1000;
  NeesOut out;
  const Eigen::Vector3d u = (B - A).normalized();
  const Eigen::Vector3d b1 = u.unitOrthogonal(), b2 = u.cross(b1);
  Eigen::Matrix<double, 2, 3> Bt;
  Bt << b1.transpose(), b2.transpose();
  auto perpNees = [&](const Eigen::Vector3d& p, const Eigen::Matrix3d& C) {
    const Eigen::Vector2d e = Bt * (p - A);
    return e.dot((Bt * C * Bt.transpose()).ldlt().solve(e));
  };
  for (int t = 0; t < trials; ++t) {
    const Samples s = sampleLine(cam, A, B, n, rng);
    const LineFitResult f = fitLineWls(s.P, s.C, s.V, s.P.front(), s.P.back());
    EXPECT_TRUE(f.ok());
    if (!f.ok()) continue;
    const int k = f.fixed_dim;
    const Eigen::Vector3d th_true = (B - A) / (B - A)(k);
    const int a = (k == 0) ? 1 : 0, b = (k == 2) ? 1 : 2;
    const Eigen::Vector2d e(f.theta(a) - th_true(a), f.theta(b) - th_true(b));
    Eigen::Matrix2d Cm;
    Cm << f.cov_theta(a, a), f.cov_theta(a, b), f.cov_theta(b, a), f.cov_theta(b, b);
    out.dir += e.dot(Cm.ldlt().solve(e));
    out.centroid += perpNees(f.centroid, f.cov_centroid);
    out.end1 += perpNees(f.line.p1, f.line.cov1);
    out.end2 += perpNees(f.line.p2, f.line.cov2);
  }
  out.dir /= trials;
  out.centroid /= trials;
  out.end1 /= trials;
  out.end2 /= trials;
  return out;
}

TEST(LineFit, CovarianceIsConsistentNees) {
  struct Case {
    Eigen::Vector3d A, B;
    int n;
  };
  const Case cases[] = {
      {{-0.6, 0.3, 2.0}, {0.5, -0.2, 2.8}, 100},   // oblique
      {{-0.3, -0.5, 1.5}, {-0.25, 0.6, 1.6}, 80},  // nearly vertical, y fixed
      {{0.1, 0.2, 1.0}, {0.5, 0.05, 3.0}, 60},     // receding in depth, z fixed
  };
  for (const Case& c : cases) {
    const NeesOut o = neesExperiment(c.A, c.B, c.n);
    std::printf("line NEES: direction %.3f, centroid %.3f, endpoints %.3f %.3f (dof 2)\n", o.dir,
                o.centroid, o.end1, o.end2);
    // Direction and centroid: [0.8, 1.25] x dof. Endpoints: [0.8, 1.6] x dof, because eq. 17
    // propagates Sigma_O and Sigma_theta as independent (paper) while O (weights 1/sigma_z^2)
    // and theta (residual-covariance weights) are correlated when depth varies along the line
    // (receding line: measured ~1.5 x dof at the near end). Documented in docs/geometry.md.
    EXPECT_GT(o.dir, 0.8 * 2);
    EXPECT_LT(o.dir, 1.3 * 2);
    EXPECT_GT(o.centroid, 0.8 * 2);
    EXPECT_LT(o.centroid, 1.25 * 2);
    for (double v : {o.end1, o.end2}) {
      EXPECT_GT(v, 0.8 * 2);
      EXPECT_LT(v, 1.6 * 2);
    }
  }
}

TEST(LineFit, EndpointJacobianMatchesNumeric) {
  const Eigen::Vector3d O(0.1, -0.2, 2.0), th(1.0, 0.3, -0.2), Pe(0.8, 0.1, 1.9);
  // Random SPD covariances.
  Eigen::Matrix3d M1, M2;
  M1 << 2, 0.3, 0.1, 0.3, 1, 0.2, 0.1, 0.2, 3;
  M2 << 1, 0.1, 0, 0.1, 2, 0.5, 0, 0.5, 1;
  const Point3WithCov e = interpolateLineEndpoint(O, M1, th, M2, Pe);
  auto f = [&](const Eigen::Vector3d& o, const Eigen::Vector3d& t) {
    return Eigen::Vector3d(o + t.dot(Pe - o) / t.squaredNorm() * t);
  };
  EXPECT_LT((e.p - f(O, th)).norm(), 1e-12);
  Eigen::Matrix3d JO, Jt;
  const double h = 1e-6;
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    d(k) = h;
    JO.col(k) = (f(O + d, th) - f(O - d, th)) / (2 * h);
    Jt.col(k) = (f(O, th + d) - f(O, th - d)) / (2 * h);
  }
  const Eigen::Matrix3d C = JO * M1 * JO.transpose() + Jt * M2 * Jt.transpose();
  EXPECT_LT((C - e.cov).norm(), 1e-6 * C.norm());
}

TEST(LineFit, DegenerateInputs) {
  std::vector<Eigen::Vector3d> P = {{0, 0, 1}, {1, 0, 1}};
  std::vector<Eigen::Matrix3d> C(2, Eigen::Matrix3d::Identity() * 1e-6);
  std::vector<double> V(2, 1e-6);
  EXPECT_EQ(fitLineWls(P, C, V, P[0], P[1]).status, FitStatus::kTooFewPoints);
  // Three coincident points: no extent.
  P.assign(3, Eigen::Vector3d(0, 0, 1));
  C.assign(3, Eigen::Matrix3d::Identity() * 1e-6);
  V.assign(3, 1e-6);
  EXPECT_EQ(fitLineWls(P, C, V, P[0], P[2]).status, FitStatus::kDegenerate);
  // Exactly collinear noiseless points (r_i = 0: the perturbation path) still give finite cov.
  P = {{0, 0, 1}, {0.1, 0, 1}, {0.2, 0, 1}, {0.3, 0, 1}};
  C.assign(4, Eigen::Matrix3d::Identity() * 1e-6);
  V.assign(4, 1e-6);
  const LineFitResult f = fitLineWls(P, C, V, P[0], P[3]);
  ASSERT_TRUE(f.ok()) << toString(f.status);
  EXPECT_TRUE(f.cov_theta.allFinite());
  EXPECT_TRUE(f.line.cov1.allFinite());
  EXPECT_NEAR((f.line.p2 - f.line.p1).norm(), 0.3, 1e-9);
}

}  // namespace
}  // namespace pplvo::geometry

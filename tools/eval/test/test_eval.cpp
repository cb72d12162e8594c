// Hand-computed cases for the TUM ATE / RPE definitions (docs/evaluation.md).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "pplvo/eval/ate.h"
#include "pplvo/eval/report.h"
#include "pplvo/eval/rpe.h"
#include "pplvo/eval/tum_file.h"

namespace pplvo {
namespace eval {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

struct Stamped {
  double stamp_s;
  Eigen::Isometry3d T_w_c;
};

TumRow rowFrom(const Stamped& s, int line_no) {
  TumRow row;
  row.stamp_s = s.stamp_s;
  row.line_no = line_no;
  const Eigen::Quaterniond q(s.T_w_c.linear());
  const Eigen::Vector3d t = s.T_w_c.translation();
  row.values = {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()};
  return row;
}

TumFile fileFrom(const std::string& name, const std::vector<Stamped>& poses) {
  TumFile f;
  f.name = name;
  for (std::size_t i = 0; i < poses.size(); ++i) f.rows.push_back(rowFrom(poses[i], int(i) + 1));
  return f;
}

Eigen::Isometry3d pose(const Eigen::Vector3d& t, const Eigen::Matrix3d& R) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = t;
  return T;
}

Eigen::Matrix3d rotZ(double rad) {
  return Eigen::AngleAxisd(rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

// A curved trajectory with rotation, stamps every dt_s (binary-exact steps).
std::vector<Stamped> curvedTrajectory(int n, double dt_s) {
  std::vector<Stamped> out;
  for (int i = 0; i < n; ++i) {
    const double t = i * dt_s;
    const Eigen::Vector3d p(std::cos(0.4 * t), std::sin(0.3 * t), 0.1 * t);
    const Eigen::Matrix3d R = (Eigen::AngleAxisd(0.2 * t, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(0.1 * t, Eigen::Vector3d::UnitX()))
                                  .toRotationMatrix();
    out.push_back({100.0 + t, pose(p, R)});
  }
  return out;
}

TEST(TumFile, ParsesSeparatorsCommentsAndBlankLines) {
  std::istringstream in(
      "# header\n"
      "\n"
      "1.5 1 2 3 0 0 0 1\n"
      "2.5,1,2,3,0,0,0,1\r\n"
      "3.5\t1\t2 3 0 0 0 1 extra\n"
      "   \n"
      "  # indented comment\n");
  const auto r = parseTumFile(in, "mem");
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_EQ(r.file.rows.size(), 3u);
  EXPECT_EQ(r.file.comment_lines, 2);
  EXPECT_DOUBLE_EQ(r.file.rows[1].stamp_s, 2.5);
  EXPECT_DOUBLE_EQ(r.file.rows[2].values[2], 3.0);
  EXPECT_EQ(r.file.rows[2].line_no, 5);
  EXPECT_FALSE(r.file.all_stamps_integer);
}

TEST(TumFile, FpsDividesStampsAndIntegerStampsAreFlagged) {
  std::istringstream in("1 0 0 0 0 0 0 1\n31 0 0 0 0 0 0 1\n");
  TumReadOptions options;
  options.fps = 30.0;
  const auto r = parseTumFile(in, "icl", options);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_TRUE(r.file.all_stamps_integer);
  EXPECT_DOUBLE_EQ(r.file.rows[0].stamp_s, 1.0 / 30.0);
  EXPECT_DOUBLE_EQ(r.file.rows[1].stamp_s, 31.0 / 30.0);
}

TEST(TumFile, ClearErrorsNameFileAndLine) {
  std::istringstream short_line("1 0 0 0 0 0 0 1\n2 0 0 0\n");
  const auto a = parseTumFile(short_line, "est.txt");
  EXPECT_FALSE(a.ok);
  EXPECT_NE(a.error.find("'est.txt' line 2"), std::string::npos) << a.error;
  std::istringstream bad_number("1 0 0 x 0 0 0 1\n");
  const auto b = parseTumFile(bad_number, "est.txt");
  EXPECT_FALSE(b.ok);
  EXPECT_NE(b.error.find("'x' is not a number"), std::string::npos) << b.error;
  const auto c = readTumFile("/nonexistent/dir/gt.txt");
  EXPECT_FALSE(c.ok);
  EXPECT_NE(c.error.find("/nonexistent/dir/gt.txt"), std::string::npos) << c.error;
}

TEST(ErrorStats, MatchesNumpyDefinitions) {
  const ErrorStats s = computeErrorStats({4.0, 1.0, 3.0, 2.0});
  EXPECT_EQ(s.count, 4);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);  // mean of the two middle values
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(30.0 / 4.0));
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));  // population std
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 4.0);
}

TEST(Association, ToleranceIsStrictAndBoundaryCasesMatch) {
  const auto m = associateStamps({10.0, 11.0, 12.0}, {10.019, 11.021, 11.981});
  ASSERT_EQ(m.size(), 2u);
  EXPECT_DOUBLE_EQ(m[0].first_s, 10.0);
  EXPECT_DOUBLE_EQ(m[0].second_s, 10.019);
  EXPECT_DOUBLE_EQ(m[1].first_s, 12.0);
  EXPECT_DOUBLE_EQ(m[1].second_s, 11.981);
}

TEST(Association, GreedyOneToOneBySmallestDifference) {
  // (1.015, 1.010) is the closest pair and is taken first; it blocks both other candidates,
  // so only one match results although a two-pair matching exists.
  const auto m = associateStamps({1.000, 1.015}, {1.010, 1.030});
  ASSERT_EQ(m.size(), 1u);
  EXPECT_DOUBLE_EQ(m[0].first_s, 1.015);
  EXPECT_DOUBLE_EQ(m[0].second_s, 1.010);
  // Each stamp is used once: three estimates near one ground-truth stamp give one match.
  const auto one = associateStamps({1.0}, {0.995, 1.004, 1.010});
  ASSERT_EQ(one.size(), 1u);
  EXPECT_DOUBLE_EQ(one[0].second_s, 1.004);
  // Result sorted by ground-truth stamp.
  const auto sorted = associateStamps({3.0, 1.0, 2.0}, {2.001, 3.002, 1.003});
  ASSERT_EQ(sorted.size(), 3u);
  EXPECT_DOUBLE_EQ(sorted[0].first_s, 1.0);
  EXPECT_DOUBLE_EQ(sorted[2].second_s, 3.002);
}

// The nearest element with ties going to the lower index: what a plain search would give.
std::size_t nearestLowerOnTie(const std::vector<double>& L, double t) {
  std::size_t best = 0;
  for (std::size_t k = 1; k < L.size(); ++k) {
    if (std::abs(L[k] - t) < std::abs(L[best] - t)) best = k;
  }
  return best;
}

TEST(FindClosestIndex, ReproducesTheBinarySearchQuirk) {
  // t = 1.5 is exactly between 1 and 2. The search visits index 2 first (middle of [0, 5)) and
  // keeps it, because index 1 is not strictly closer: TUM returns 2, the plain nearest 1.
  const std::vector<double> L = {0.0, 1.0, 2.0, 3.0, 4.0};
  EXPECT_EQ(findClosestIndex(L, 1.5), 2u);
  EXPECT_EQ(nearestLowerOnTie(L, 1.5), 1u);
  // With three elements the first midpoint is index 1, so the same tie goes the other way.
  EXPECT_EQ(findClosestIndex({0.0, 1.0, 2.0}, 1.5), 1u);
  // Exact hits, ends, and an ordinary nearest.
  EXPECT_EQ(findClosestIndex(L, 3.0), 3u);
  EXPECT_EQ(findClosestIndex(L, -7.0), 0u);
  EXPECT_EQ(findClosestIndex(L, 9.0), 4u);
  EXPECT_EQ(findClosestIndex(L, 2.4), 2u);
  EXPECT_EQ(findClosestIndex({5.0}, 1.0), 0u);
}

TEST(Transform44, NormalisesQuaternionAndHandlesZero) {
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  const Eigen::Matrix4d T = transform44({1, 2, 3, 2 * q.x(), 2 * q.y(), 2 * q.z(), 2 * q.w()});
  EXPECT_LT((T.block<3, 3>(0, 0) - q.toRotationMatrix()).norm(), 1e-12);
  EXPECT_EQ(T(1, 3), 2.0);
  const Eigen::Matrix4d I = transform44({1, 2, 3, 0, 0, 0, 1e-9});
  EXPECT_LT((I.block<3, 3>(0, 0) - Eigen::Matrix3d::Identity()).norm(), 1e-15);
}

TEST(Ate, IdentityGivesZero) {
  const auto traj = curvedTrajectory(50, 0.125);
  const AteResult r = evaluateAte(fileFrom("gt", traj), fileFrom("est", traj));
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.error_m.count, 50);
  EXPECT_LT(r.error_m.max, 1e-12);
  const RpeResult rpe = evaluateRpe(fileFrom("gt", traj), fileFrom("est", traj));
  ASSERT_TRUE(rpe.ok) << rpe.error;
  EXPECT_LT(rpe.trans_m.max, 1e-12);
  EXPECT_LT(rpe.rot_rad.max, 1e-6);
}

TEST(AteRpe, ConstantRigidOffsetIsInvisible) {
  const auto gt = curvedTrajectory(60, 0.125);
  const Eigen::Isometry3d A = pose(
      {3.0, -1.0, 0.5},
      (Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -0.5, 0.8).normalized())).toRotationMatrix());
  std::vector<Stamped> est;
  for (const auto& s : gt) est.push_back({s.stamp_s, A * s.T_w_c});
  const AteResult ate = evaluateAte(fileFrom("gt", gt), fileFrom("est", est));
  ASSERT_TRUE(ate.ok) << ate.error;
  EXPECT_LT(ate.error_m.rmse, 1e-9);
  // The recovered alignment is the inverse of the offset.
  EXPECT_LT((ate.R_gt_est - A.linear().transpose()).norm(), 1e-9);
  const RpeResult rpe = evaluateRpe(fileFrom("gt", gt), fileFrom("est", est));
  ASSERT_TRUE(rpe.ok) << rpe.error;
  EXPECT_LT(rpe.trans_m.rmse, 1e-9);
  EXPECT_LT(rpe.rot_rad.rmse, 1e-6);
  // Without alignment the offset would show: a 3 m shift is far from zero.
  EXPECT_GT((est[0].T_w_c.translation() - gt[0].T_w_c.translation()).norm(), 1.0);
}

TEST(Ate, SingleDisplacedPoseOnAStraightLine) {
  // n poses on the x axis; pose k is displaced by d along the line. Alignment can only shift
  // (rotations about x leave the points fixed): t = -d/n, so n-1 poses err by d/n and pose k
  // by d (n-1)/n. RMSE = d sqrt(n-1) / n, mean = 2 d (n-1) / n^2.
  const int n = 21, k = 7;
  const double d = 0.1;
  std::vector<Stamped> gt, est;
  for (int i = 0; i < n; ++i) {
    gt.push_back({i * 0.125, pose({0.5 * i, 0, 0}, Eigen::Matrix3d::Identity())});
    est.push_back(
        {i * 0.125, pose({0.5 * i + (i == k ? d : 0.0), 0, 0}, Eigen::Matrix3d::Identity())});
  }
  const AteResult r = evaluateAte(fileFrom("gt", gt), fileFrom("est", est));
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.error_m.count, n);
  EXPECT_NEAR(r.error_m.rmse, d * std::sqrt(n - 1.0) / n, 1e-12);
  EXPECT_NEAR(r.error_m.mean, 2.0 * d * (n - 1.0) / (n * n), 1e-12);
  EXPECT_NEAR(r.error_m.median, d / n, 1e-12);
  EXPECT_NEAR(r.error_m.min, d / n, 1e-12);
  EXPECT_NEAR(r.error_m.max, d * (n - 1.0) / n, 1e-12);
}

TEST(Rpe, ConstantVelocityErrorAndLastPoseQuirk) {
  // GT moves at 0.5 m/s, the estimate at 0.53 m/s: every 1 s pair errs by 0.03 m.
  const int n = 41;  // 5 s at 8 Hz
  const double dt = 0.125, v = 0.5, e = 0.03;
  std::vector<Stamped> gt, est;
  for (int i = 0; i < n; ++i) {
    const double t = i * dt;
    gt.push_back({t, pose({v * t, 0, 0}, rotZ(0.3))});
    est.push_back({t, pose({(v + e) * t, 0, 0}, rotZ(0.3))});
  }
  const RpeResult r = evaluateRpe(fileFrom("gt", gt), fileFrom("est", est));
  ASSERT_TRUE(r.ok) << r.error;
  // Pair (i, i + 8) for i = 0 .. n - 10: the pair ending at the last pose (i = n - 9) and the
  // pairs clamped to the last pose are dropped, as TUM does.
  EXPECT_EQ(r.pairs.size(), static_cast<std::size_t>(n - 9));
  EXPECT_NEAR(r.trans_m.rmse, e, 1e-12);
  EXPECT_NEAR(r.trans_m.median, e, 1e-12);
  EXPECT_LT(r.rot_rad.max, 1e-6);
  EXPECT_DOUBLE_EQ(r.pairs.front().est1_s - r.pairs.front().est0_s, 1.0);
  EXPECT_NEAR(r.gt_max_time_difference_s, 2 * dt, 1e-12);
}

TEST(Rpe, TranslationScaleExposesUnderestimatedMotion) {
  // The estimate moves 0.8 times as far as the ground truth along a curved path, in a world
  // frame of its own (rotated and shifted): the scale is read from relative motions only.
  const std::vector<Stamped> gt = curvedTrajectory(60, 0.1);
  const Eigen::Isometry3d other_world = pose({1, 2, 3}, rotZ(0.7));
  std::vector<Stamped> est, same;
  for (const Stamped& s : gt) {
    Eigen::Isometry3d T = s.T_w_c;
    T.translation() = 0.8 * T.translation();
    est.push_back({s.stamp_s, other_world * T});
    same.push_back({s.stamp_s, other_world * s.T_w_c});
  }
  const RpeResult r = evaluateRpe(fileFrom("gt", gt), fileFrom("est", est));
  ASSERT_TRUE(r.ok) << r.error;
  // Relative translations scale by 0.8 only where the rotation is shared; here it is, so the
  // relative translation in the start frame is exactly 0.8 times the ground truth's.
  EXPECT_NEAR(r.trans_scale, 0.8, 1e-9);
  const RpeResult exact = evaluateRpe(fileFrom("gt", gt), fileFrom("est", same));
  ASSERT_TRUE(exact.ok) << exact.error;
  EXPECT_NEAR(exact.trans_scale, 1.0, 1e-9);
}

TEST(Rpe, RotationDriftOfKnownRate) {
  const double omega_deg_per_s = 2.5;
  std::vector<Stamped> gt, est;
  for (int i = 0; i < 33; ++i) {
    const double t = 10.0 + i * 0.25;
    gt.push_back({t, pose({0.0, 0.0, 0.0}, rotZ(0.1))});
    est.push_back({t, pose({0.0, 0.0, 0.0}, rotZ(0.1 + omega_deg_per_s * kDegToRad * (t - 10.0)))});
  }
  const RpeResult r = evaluateRpe(fileFrom("gt", gt), fileFrom("est", est));
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.pairs.size(), 33u - 5u);
  EXPECT_NEAR(r.rot_rad.rmse / kDegToRad, omega_deg_per_s, 1e-9);
  EXPECT_LT(r.trans_m.max, 1e-12);
}

TEST(Rpe, SkipsZeroQuaternionAndNanRowsAndFarGroundTruth) {
  auto gt = curvedTrajectory(40, 0.125);
  TumFile gt_file = fileFrom("gt", gt);
  TumFile est_file = fileFrom("est", gt);
  est_file.rows[3].values[3] = est_file.rows[3].values[4] = 0.0;
  est_file.rows[3].values[5] = est_file.rows[3].values[6] = 0.0;
  est_file.rows[5].values[0] = std::nan("");
  const RpeResult r = evaluateRpe(gt_file, est_file);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.skipped_rows_est, 2);
  EXPECT_LT(r.trans_m.max, 1e-12);
  // ATE drops only the NaN row: the zero-quaternion row still has a valid position.
  const AteResult a = evaluateAte(gt_file, est_file);
  ASSERT_TRUE(a.ok) << a.error;
  EXPECT_EQ(a.error_m.count, 39);
  EXPECT_EQ(a.skipped_non_finite_est, 1);

  // Ground truth with a 3 s hole: pairs whose ends have no ground truth within
  // 2 * median interval are skipped.
  std::vector<Stamped> holed;
  for (const auto& s : curvedTrajectory(80, 0.125)) {
    if (s.stamp_s - 100.0 < 4.0 || s.stamp_s - 100.0 > 7.0) holed.push_back(s);
  }
  const RpeResult h =
      evaluateRpe(fileFrom("gt", holed), fileFrom("est", curvedTrajectory(80, 0.125)));
  ASSERT_TRUE(h.ok) << h.error;
  EXPECT_GT(h.skipped_gt_time, 0);
  EXPECT_EQ(h.pairs.size() + h.skipped_gt_time, static_cast<std::size_t>(h.candidate_pairs));
}

TEST(Errors, NoOverlapAndTooShort) {
  const auto gt = curvedTrajectory(40, 0.125);
  std::vector<Stamped> later;
  for (const auto& s : gt) later.push_back({s.stamp_s + 1000.0, s.T_w_c});
  const EvalReport r = evaluateTrajectories(fileFrom("gt", gt), fileFrom("est", later));
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.ate.error, "no pose pairs within 0.02 s: are the stamps in the same clock?");
  EXPECT_FALSE(r.rpe.ok);
  const std::string text = formatText(r);
  EXPECT_NE(text.find("ate.error no pose pairs"), std::string::npos) << text;

  // Half a second of estimate: ATE works, RPE has no 1 s pairs.
  const std::vector<Stamped> short_est(gt.begin(), gt.begin() + 4);
  const EvalReport s = evaluateTrajectories(fileFrom("gt", gt), fileFrom("est", short_est));
  EXPECT_TRUE(s.ate.ok);
  EXPECT_FALSE(s.rpe.ok);
  EXPECT_NE(s.rpe.error.find("need at least 2"), std::string::npos) << s.rpe.error;

  const EvalReport empty = evaluateTrajectories(fileFrom("gt", gt), fileFrom("est", {}));
  EXPECT_FALSE(empty.ate.ok);
  EXPECT_FALSE(empty.rpe.ok);
}

TEST(Report, TextJsonAndIntegerStampHint) {
  std::vector<Stamped> traj;
  for (int i = 1; i <= 90; ++i)
    traj.push_back({double(i), pose({0.01 * i, 0, 0}, rotZ(0.001 * i))});
  TumFile f = fileFrom("icl_gt", traj);
  f.all_stamps_integer = true;
  const EvalReport r = evaluateTrajectories(f, f);
  ASSERT_TRUE(r.ok());
  const std::string text = formatText(r);
  EXPECT_NE(text.find("ate.pairs 90\n"), std::string::npos) << text;
  EXPECT_NE(text.find("ate.rmse_m 0.000000\n"), std::string::npos) << text;
  EXPECT_NE(text.find("rpe.trans_rmse_m_per_s 0.000000\n"), std::string::npos) << text;
  EXPECT_NE(text.find("rpe.rot_rmse_deg_per_s 0.000000\n"), std::string::npos) << text;
  EXPECT_NE(text.find("# hint: all stamps of 'icl_gt' are integers"), std::string::npos) << text;
  const std::string json = formatJson(r);
  EXPECT_NE(json.find("\"pairs\": 90"), std::string::npos) << json;
  EXPECT_NE(json.find("\"rot_rmse_deg_per_s\": "), std::string::npos) << json;
  EXPECT_NE(json.find("\"notes\": [\"hint: "), std::string::npos) << json;

  EvalOptions with_fps;
  with_fps.fps = 30.0;
  EXPECT_TRUE(evaluateTrajectories(f, f, with_fps).notes.empty());
}

std::string sharedData() {
  const char* env = std::getenv("PPLVO_SHARED_DATA");
  return env ? env : "../shared/data";
}

TEST(RealData, GroundTruthAgainstItselfIsZero) {
  struct Case {
    std::string path;
    double fps;
    std::size_t expected_rows;
  };
  const std::vector<Case> cases = {
      {sharedData() + "/icl_living_room_kt0_short/groundtruth.txt", 30.0, 1508},
      {sharedData() + "/icl_living_room_kt0_short/groundtruth.txt", 0.0, 1508},
      {sharedData() + "/tum_fr3_sitting_static_short/groundtruth.txt", 0.0, 0}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.path + " fps " + std::to_string(c.fps));
    TumReadOptions ro;
    ro.fps = c.fps;
    const TumReadResult gt = readTumFile(c.path, ro);
    ASSERT_TRUE(gt.ok) << gt.error;
    if (c.expected_rows) {
      EXPECT_EQ(gt.file.rows.size(), c.expected_rows);
    }
    EvalOptions options;
    options.fps = c.fps;
    const EvalReport r = evaluateTrajectories(gt.file, gt.file, options);
    ASSERT_TRUE(r.ok()) << r.ate.error << r.rpe.error;
    EXPECT_EQ(r.ate.error_m.count, static_cast<int>(gt.file.rows.size()));
    EXPECT_LT(r.ate.error_m.max, 1e-9);
    EXPECT_GT(r.rpe.pairs.size(), 100u);
    EXPECT_LT(r.rpe.trans_m.max, 1e-9);
    EXPECT_LT(r.rpe.rot_rad.max / kDegToRad, 1e-5);
    const std::string text = formatText(r);
    EXPECT_NE(text.find("ate.rmse_m 0.000000\n"), std::string::npos) << text;
    EXPECT_NE(text.find("rpe.trans_rmse_m_per_s 0.000000\n"), std::string::npos) << text;
    EXPECT_NE(text.find("rpe.rot_rmse_deg_per_s 0.000000\n"), std::string::npos) << text;
  }
}

}  // namespace
}  // namespace eval
}  // namespace pplvo

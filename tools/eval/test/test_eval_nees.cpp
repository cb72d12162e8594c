// NEES evaluator (pplvo/eval/nees.h), covariance file and pose-log reading.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "pplvo/eval/nees.h"
#include "pplvo/eval/pose_records.h"
#include "pplvo/eval/relative_pose_file.h"
#include "pplvo/logging/event_log.h"
#include "pplvo/msgs/convert_pose.h"

namespace pplvo::eval {
namespace {

Eigen::Isometry3d xiToPose(const Vector6d& xi) {
  const Eigen::Vector3d v = xi.tail<3>();
  const Eigen::Quaterniond q(std::sqrt(1.0 - v.squaredNorm()), v.x(), v.y(), v.z());
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.toRotationMatrix();
  T.translation() = xi.head<3>();
  return T;
}

Eigen::Matrix3d expSo3(const Eigen::Vector3d& w) {
  const double a = w.norm();
  return a > 0 ? Eigen::AngleAxisd(a, w / a).toRotationMatrix() : Eigen::Matrix3d::Identity();
}

/// A smooth camera motion, T_w_c(t): ~0.2 m/s, ~10 deg/s.
Eigen::Isometry3d truePose(double t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0.3 * std::sin(0.7 * t), 0.2 * std::cos(0.5 * t), 0.1 * t);
  T.linear() = expSo3(Eigen::Vector3d(0.3 * std::sin(0.4 * t), 0.2 * t, 0.1 * std::cos(0.3 * t)));
  return T;
}

TumRow tumRow(double stamp, const Eigen::Isometry3d& T) {
  TumRow r;
  r.stamp_s = stamp;
  const Eigen::Quaterniond q(T.linear());
  r.values = {
      T.translation().x(), T.translation().y(), T.translation().z(), q.x(), q.y(), q.z(), q.w()};
  return r;
}

/// A random covariance of xi with realistic scales (m^2 for t, q_xyz ~ half angles).
Matrix6d randomCovariance(std::mt19937& rng, double sigma_t_m, double sigma_q) {
  std::normal_distribution<double> n01;
  Matrix6d A;
  for (int i = 0; i < 36; ++i) A(i) = n01(rng);
  Vector6d d;
  d << Eigen::Vector3d::Constant(sigma_t_m), Eigen::Vector3d::Constant(sigma_q);
  const Matrix6d C =
      d.asDiagonal() * (A * A.transpose() / 6.0 + 0.2 * Matrix6d::Identity()) * d.asDiagonal();
  return 0.5 * (C + C.transpose());  // exactly symmetric (the file keeps the upper triangle)
}

Vector6d drawFrom(std::mt19937& rng, const Matrix6d& C) {
  std::normal_distribution<double> n01;
  Vector6d z;
  for (int k = 0; k < 6; ++k) z(k) = n01(rng);
  return Eigen::LLT<Matrix6d>(C).matrixL() * z;
}

/// A fabricated estimator: relative poses between frames at `fps` whose errors (in xi) are
/// drawn from `scale_drawn` times the covariance it reports.
std::vector<RelativePoseRecord> fabricate(std::mt19937& rng, int n, double fps, double scale_drawn,
                                          double t0 = 0.2) {
  std::vector<RelativePoseRecord> out;
  for (int k = 1; k <= n; ++k) {
    RelativePoseRecord r;
    r.prev_stamp_s = t0 + (k - 1) / fps;
    r.stamp_s = t0 + k / fps;
    r.stamp_text = std::to_string(r.stamp_s);
    r.prev_stamp_text = std::to_string(r.prev_stamp_s);
    r.status = 1;
    const Eigen::Isometry3d T_true = truePose(r.prev_stamp_s).inverse() * truePose(r.stamp_s);
    r.covariance = randomCovariance(rng, 4e-4, 3e-4);
    r.T_prev_curr = xiToPose(poseToXi(T_true) + drawFrom(rng, scale_drawn * r.covariance));
    out.push_back(r);
  }
  return out;
}

TEST(ChiSquare, QuantilesMatchTables) {
  EXPECT_NEAR(chiSquareQuantile(0.95, 6), 12.5916, 1e-4);
  EXPECT_NEAR(chiSquareQuantile(0.95, 3), 7.8147, 1e-4);
  EXPECT_NEAR(chiSquareQuantile(0.95, 1), 3.8415, 1e-4);
  EXPECT_NEAR(chiSquareQuantile(0.025, 6), 1.2373, 1e-4);
  EXPECT_NEAR(chiSquareQuantile(0.975, 6), 14.4494, 1e-4);
  EXPECT_NEAR(chiSquareQuantile(0.5, 600), 599.3335, 1e-3);
  // Closed form for 6 dof: 1 - exp(-x/2) (1 + x/2 + x^2/8).
  for (double x : {0.5, 3.0, 6.0, 20.0}) {
    EXPECT_NEAR(chiSquareCdf(x, 6), 1 - std::exp(-x / 2) * (1 + x / 2 + x * x / 8), 1e-12);
  }
}

TEST(CovarianceFile, RoundTripAndErrors) {
  std::mt19937 rng(3);
  auto records = fabricate(rng, 5, 30.0, 1.0);
  records[2].status = 2;
  std::string text = relativePoseFileHeader();
  for (const auto& r : records) text += formatRelativePoseLine(r);
  std::istringstream in(text);
  const RelativePoseReadResult back = parseRelativePoseFile(in, "mem");
  ASSERT_TRUE(back.ok) << back.error;
  ASSERT_EQ(back.records.size(), records.size());
  for (size_t k = 0; k < records.size(); ++k) {
    EXPECT_EQ(back.records[k].stamp_text, records[k].stamp_text);
    EXPECT_EQ(back.records[k].prev_stamp_text, records[k].prev_stamp_text);
    EXPECT_EQ(back.records[k].status, records[k].status);
    EXPECT_LT((back.records[k].T_prev_curr.matrix() - records[k].T_prev_curr.matrix())
                  .cwiseAbs()
                  .maxCoeff(),
              1e-15);
    EXPECT_EQ(back.records[k].covariance, records[k].covariance);  // 17 digits: exact
  }
  // Frame indices with fps.
  std::istringstream icl(formatRelativePoseLine([] {
    RelativePoseRecord r;
    r.stamp_text = "31";
    r.prev_stamp_text = "30";
    return r;
  }()));
  const auto by_index = parseRelativePoseFile(icl, "icl", 30.0);
  ASSERT_TRUE(by_index.ok);
  EXPECT_DOUBLE_EQ(by_index.records[0].stamp_s, 31.0 / 30.0);
  EXPECT_DOUBLE_EQ(by_index.records[0].prev_stamp_s, 1.0);
  std::istringstream short_line("1 0 1 0 0 0 0 0 0 1\n");
  const auto bad = parseRelativePoseFile(short_line, "bad");
  EXPECT_FALSE(bad.ok);
  EXPECT_NE(bad.error.find("bad:1: expected 31 fields"), std::string::npos) << bad.error;
}

TEST(Nees, FabricatedConsistentEstimatorAveragesSix) {
  std::mt19937 rng(42);
  TumFile gt;
  gt.name = "gt";
  for (int i = 0; i <= 80 * 100; ++i) gt.rows.push_back(tumRow(i * 0.01, truePose(i * 0.01)));
  const auto records = fabricate(rng, 2000, 30.0, 1.0);
  NeesOptions o;
  o.gt = {0.0, 0.0, 0.0};
  const NeesResult r = evaluateNees(gt, records, o);
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_EQ(r.pairs.size(), 2000u);
  std::printf(
      "consistent: mean %.3f (t %.3f, r %.3f), median %.3f, inside 95 %%: %.3f (t %.3f, "
      "r %.3f)\n",
      r.all.mean, r.translation.mean, r.rotation.mean, r.all.median, r.all.share_inside,
      r.translation.share_inside, r.rotation.share_inside);
  // Mean of 2000 chi2(6): std 0.077; blocks chi2(3): 0.055; shares: binomial std 0.005.
  EXPECT_NEAR(r.all.mean, 6.0, 0.35);
  EXPECT_NEAR(r.translation.mean, 3.0, 0.25);
  EXPECT_NEAR(r.rotation.mean, 3.0, 0.25);
  EXPECT_NEAR(r.all.median, chiSquareQuantile(0.5, 6), 0.4);
  EXPECT_NEAR(r.all.share_inside, 0.95, 0.02);
  EXPECT_NEAR(r.translation.share_inside, 0.95, 0.02);
  EXPECT_NEAR(r.rotation.share_inside, 0.95, 0.02);
  EXPECT_GT(r.all.mean, r.mean_interval_lo - 0.3);
  EXPECT_LT(r.all.mean, r.mean_interval_hi + 0.3);
  // The predicted and actual sizes agree.
  EXPECT_NEAR(r.rms_error_t_m / r.rms_sigma_t_m, 1.0, 0.08);
  EXPECT_NEAR(r.rms_error_q / r.rms_sigma_q, 1.0, 0.08);
}

TEST(Nees, OverConfidentEstimatorFails) {
  std::mt19937 rng(43);
  TumFile gt;
  for (int i = 0; i <= 40 * 100; ++i) gt.rows.push_back(tumRow(i * 0.01, truePose(i * 0.01)));
  // Errors twice as large (in std) as the reported covariance says.
  const auto records = fabricate(rng, 1000, 30.0, 4.0);
  NeesOptions o;
  o.gt = {0.0, 0.0, 0.0};
  const NeesResult r = evaluateNees(gt, records, o);
  ASSERT_TRUE(r.ok) << r.error;
  std::printf("over-confident (x2 std): mean %.2f, inside 95 %%: %.3f\n", r.all.mean,
              r.all.share_inside);
  EXPECT_NEAR(r.all.mean, 24.0, 2.0);
  EXPECT_GT(r.all.mean, r.mean_interval_hi * 3);
  EXPECT_LT(r.all.share_inside, 0.5);
  EXPECT_LT(r.translation.share_inside, 0.6);
  // Under-confident (errors half the reported std): far below the interval as well.
  const NeesResult u = evaluateNees(gt, fabricate(rng, 1000, 30.0, 0.25), o);
  EXPECT_NEAR(u.all.mean, 1.5, 0.2);
  EXPECT_LT(u.all.mean, u.mean_interval_lo);
}

TEST(Nees, GroundTruthNoiseAndStampErrorAreAccountedFor) {
  // A ground truth with white pose noise at 100 Hz and frame stamps off by a random error:
  // a consistent estimator must still average 6 when the evaluator is told the noise, and be
  // judged over-confident when the ground truth is taken as exact.
  std::mt19937 rng(7);
  std::normal_distribution<double> n01;
  const double sigma_gt_t = 3e-4, sigma_gt_rot = 0.1 * M_PI / 180, sigma_stamp = 3e-3;
  TumFile gt;
  for (int i = 0; i <= 40 * 100; ++i) {
    Eigen::Isometry3d T = truePose(i * 0.01);
    const Eigen::Vector3d dt(n01(rng), n01(rng), n01(rng));
    const Eigen::Vector3d dw(n01(rng), n01(rng), n01(rng));
    T.translation() += T.linear() * (sigma_gt_t * dt);
    T.linear() = T.linear() * expSo3(sigma_gt_rot * dw);
    gt.rows.push_back(tumRow(i * 0.01, T));
  }
  // Frames on every third ground-truth sample (33.3 Hz, so the noise of the sample itself is
  // what is compared), stamps recorded with an error; the estimate follows the true motion
  // between the true instants.
  std::vector<RelativePoseRecord> records;
  double prev_true = 0.3, prev_recorded = 0.3;
  for (int k = 1; k < 1200; ++k) {
    const double t_true = 0.3 + 0.03 * k;
    RelativePoseRecord r;
    r.prev_stamp_s = prev_recorded;
    r.stamp_s = t_true + sigma_stamp * n01(rng);
    r.status = 1;
    r.covariance = randomCovariance(rng, 2e-4, 1.5e-4);
    const Eigen::Isometry3d T_true = truePose(prev_true).inverse() * truePose(t_true);
    r.T_prev_curr = xiToPose(poseToXi(T_true) + drawFrom(rng, r.covariance));
    records.push_back(r);
    prev_true = t_true;
    prev_recorded = r.stamp_s;
  }
  NeesOptions told;
  told.gt = {sigma_gt_t, sigma_gt_rot, sigma_stamp};
  const NeesResult a = evaluateNees(gt, records, told);
  ASSERT_TRUE(a.ok) << a.error;
  // Consecutive pairs share a stamp (their NEES are correlated): a wider margin than for
  // independent pairs.
  EXPECT_GT(a.all.mean, 5.3);
  EXPECT_LT(a.all.mean, 6.7);
  EXPECT_GT(a.all.share_inside, 0.92);
  // The jitter is recovered from the ground truth itself (third differences, robust std).
  const GtJitter j = estimateGtJitter(gt);
  ASSERT_TRUE(j.ok);
  EXPECT_NEAR(j.sigma_t_m, sigma_gt_t, 0.1 * sigma_gt_t);
  EXPECT_NEAR(j.sigma_rot_rad, sigma_gt_rot, 0.1 * sigma_gt_rot);
  NeesOptions from_data;
  from_data.gt.sigma_stamp_s = sigma_stamp;
  from_data.gt_jitter_from_data = true;
  const NeesResult c = evaluateNees(gt, records, from_data);
  ASSERT_TRUE(c.ok);
  EXPECT_NEAR(c.all.mean, a.all.mean, 0.1 * a.all.mean);
  NeesOptions exact;
  exact.gt = {0.0, 0.0, 0.0};
  const NeesResult b = evaluateNees(gt, records, exact);
  ASSERT_TRUE(b.ok);
  std::printf("noisy ground truth: mean %.3f told, %.3f taken as exact (estimate alone %.1f)\n",
              a.all.mean, b.all.mean, b.mean_est_only);
  EXPECT_GT(b.all.mean, 2.0 * a.all.mean);
  EXPECT_GT(b.mean_est_only, 10.0);
}

/// Ground truth of truePose at 100 Hz over `seconds`.
TumFile denseGroundTruth(double seconds) {
  TumFile gt;
  gt.name = "gt";
  for (int i = 0; i <= seconds * 100; ++i) gt.rows.push_back(tumRow(i * 0.01, truePose(i * 0.01)));
  return gt;
}

/// Pose perturbed on the right (body frame) by a translation and a rotation vector.
Eigen::Isometry3d perturbedBy(const Eigen::Isometry3d& T, const Eigen::Vector3d& dt,
                              const Eigen::Vector3d& dtheta) {
  Eigen::Isometry3d E = Eigen::Isometry3d::Identity();
  E.linear() = expSo3(dtheta);
  E.translation() = dt;
  return T * E;
}

/// A hand-held kind of motion: the rotation oscillates at 0.7-1.5 Hz (up to ~1.4 rad/s).
Eigen::Isometry3d shakyPose(double t) {
  Eigen::Isometry3d T = truePose(t);
  T.linear() = expSo3(Eigen::Vector3d(0.1 * std::sin(2 * M_PI * 1.5 * t),
                                      0.15 * std::sin(2 * M_PI * 1.1 * t + 1),
                                      0.05 * std::sin(2 * M_PI * 0.7 * t)));
  return T;
}

TEST(Nees, GroundTruthClockOffsetIsFoundFromTheRotation) {
  // Frames stamped 13 ms before their images were taken: the estimator (consistent about its
  // own noise) measures the motion between stamp + 13 ms instants. A clock offset changes a
  // relative rotation by the change of the angular rate over the pair times the offset, so
  // the motion must turn unevenly, as a hand-held camera does.
  std::mt19937 rng(11);
  TumFile gt;
  for (int i = 0; i <= 3000; ++i) gt.rows.push_back(tumRow(i * 0.01, shakyPose(i * 0.01)));
  std::vector<RelativePoseRecord> records;
  const double offset = 0.013;
  for (int k = 1; k <= 600; ++k) {
    RelativePoseRecord r;
    r.prev_stamp_s = 1.0 + (k - 1) / 30.0;
    r.stamp_s = 1.0 + k / 30.0;
    r.status = 1;
    r.covariance = randomCovariance(rng, 4e-4, 3e-4);
    const Eigen::Isometry3d T_true =
        shakyPose(r.prev_stamp_s + offset).inverse() * shakyPose(r.stamp_s + offset);
    r.T_prev_curr = xiToPose(poseToXi(T_true) + drawFrom(rng, r.covariance));
    records.push_back(r);
  }
  NeesOptions o;
  o.gt = {0.0, 0.0, 0.0};
  const GtTimeOffsetEstimate est = estimateGtTimeOffset(gt, records, o);
  ASSERT_TRUE(est.ok);
  EXPECT_NEAR(est.offset_s, offset, 0.0015);
  EXPECT_LT(est.rms_rot_rad, 0.8 * est.rms_rot_zero_rad);
  const NeesResult at_zero = evaluateNees(gt, records, o);
  o.gt_time_offset_s = est.offset_s;
  const NeesResult at_offset = evaluateNees(gt, records, o);
  ASSERT_TRUE(at_zero.ok && at_offset.ok);
  std::printf("clock offset %.1f ms found: mean NEES %.2f at 0 ms, %.2f there\n",
              est.offset_s * 1e3, at_zero.all.mean, at_offset.all.mean);
  EXPECT_GT(at_zero.all.mean, 10.0);
  EXPECT_NEAR(at_offset.all.mean, 6.0, 0.8);
  EXPECT_DOUBLE_EQ(at_offset.gt_time_offset_s, est.offset_s);
}

TEST(Nees, FrameErrorFitRecoversThePerFrameSharedError) {
  // Every frame's pose carries its own error (2 mm, 0.06 deg per axis) shared by all its
  // measurements; the estimator reports only its per-pair noise (0.3 mm): over-confident.
  // The fit must find the per-frame error, and with it added the NEES must average 6.
  std::mt19937 rng(5);
  std::normal_distribution<double> n01;
  const double sigma_t = 2e-3, sigma_rot = 0.06 * M_PI / 180;
  const TumFile gt = denseGroundTruth(70);
  auto frameError = [&] {
    return std::make_pair(Eigen::Vector3d(sigma_t * n01(rng), sigma_t * n01(rng), sigma_t * n01(rng)),
                          Eigen::Vector3d(sigma_rot * n01(rng), sigma_rot * n01(rng),
                                          sigma_rot * n01(rng)));
  };
  std::vector<RelativePoseRecord> shared, own_only;
  auto prev_error = frameError();
  for (int k = 1; k <= 2000; ++k) {
    RelativePoseRecord r;
    r.prev_stamp_s = 0.2 + (k - 1) / 30.0;
    r.stamp_s = 0.2 + k / 30.0;
    r.status = 1;
    r.covariance = randomCovariance(rng, 3e-4, 2e-4);
    const auto error = frameError();
    const Eigen::Isometry3d T0 = perturbedBy(truePose(r.prev_stamp_s), prev_error.first,
                                             prev_error.second);
    const Eigen::Isometry3d T1 = perturbedBy(truePose(r.stamp_s), error.first, error.second);
    prev_error = error;
    RelativePoseRecord own = r;
    r.T_prev_curr = xiToPose(poseToXi(T0.inverse() * T1) + drawFrom(rng, r.covariance));
    shared.push_back(r);
    const Eigen::Isometry3d T_true = truePose(r.prev_stamp_s).inverse() * truePose(r.stamp_s);
    own.T_prev_curr = xiToPose(poseToXi(T_true) + drawFrom(rng, own.covariance));
    own_only.push_back(own);
  }
  NeesOptions o;
  o.gt = {0.0, 0.0, 0.0};
  const NeesResult without = evaluateNees(gt, shared, o);
  ASSERT_TRUE(without.ok) << without.error;
  const FrameErrorFit fit = fitFrameError({&without});
  ASSERT_TRUE(fit.ok);
  EXPECT_EQ(fit.pairs, 2000);
  std::printf("per-frame error fitted: %.3f mm, %.4f deg (true 2, 0.06); NEES without %.1f\n",
              fit.sigma_t_m * 1e3, fit.sigma_rot_rad * 180 / M_PI, without.all.mean);
  EXPECT_GT(without.all.mean, 30.0);
  EXPECT_NEAR(fit.sigma_t_m, sigma_t, 0.1 * sigma_t);
  EXPECT_NEAR(fit.sigma_rot_rad, sigma_rot, 0.1 * sigma_rot);
  o.added_frame_sigma_t_m = fit.sigma_t_m;
  o.added_frame_sigma_rot_rad = fit.sigma_rot_rad;
  const NeesResult with = evaluateNees(gt, shared, o);
  EXPECT_NEAR(with.translation.mean, 3.0, 0.05);  // fitted to 3 exactly
  EXPECT_NEAR(with.rotation.mean, 3.0, 0.05);
  EXPECT_NEAR(with.all.mean, 6.0, 0.5);
  EXPECT_NEAR(with.all.share_inside, 0.95, 0.03);
  // A consistent estimator needs no per-frame error: at most a small fraction of the above.
  const NeesResult consistent = evaluateNees(gt, own_only, NeesOptions{{0.0, 0.0, 0.0}});
  const FrameErrorFit none = fitFrameError({&consistent});
  EXPECT_LT(none.sigma_t_m, 0.2 * sigma_t);
  EXPECT_LT(none.sigma_rot_rad, 0.2 * sigma_rot);
  // Pooled with the shared-error run, the fit lies between the two.
  const FrameErrorFit pooled = fitFrameError({&without, &consistent});
  EXPECT_EQ(pooled.pairs, 4000);
  EXPECT_GT(pooled.sigma_t_m, none.sigma_t_m);
  EXPECT_LT(pooled.sigma_t_m, fit.sigma_t_m);
}

TEST(Nees, SkipsStatusesAndStampsOutsideTheGroundTruth) {
  std::mt19937 rng(5);
  TumFile gt;
  for (int i = 0; i <= 205; ++i) gt.rows.push_back(tumRow(i * 0.01, truePose(i * 0.01)));
  auto records = fabricate(rng, 70, 30.0, 1.0);  // 0.2 .. 2.53 s: k >= 56 beyond 2.05 s
  records[3].status = 3;                         // lost
  records[4].status = 2;                         // velocity model
  const NeesResult r = evaluateNees(gt, records);
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.skipped_status, 1);
  EXPECT_EQ(r.skipped_no_gt, 15);
  NeesOptions no_vm;
  no_vm.include_velocity_model = false;
  EXPECT_EQ(evaluateNees(gt, records, no_vm).skipped_status, 2);
}

TEST(PoseRecords, FromFramePosesAndEventLog) {
  std::vector<FramePose> poses(4);
  for (int k = 0; k < 4; ++k) {
    poses[k].seq = k;
    poses[k].stamp = std::to_string(100 + k);
    poses[k].status = k == 0 ? TrackingStatus::kFirstFrame : TrackingStatus::kTracking;
    poses[k].T_prev_curr.translation() = Eigen::Vector3d(0.01 * k, 0, 0);
    poses[k].rel_covariance = (1e-6 * (k + 1)) * Matrix6d::Identity();
    poses[k].rel_covariance(0, 3) = poses[k].rel_covariance(3, 0) = 1e-8;
  }
  const auto direct = relativePoseRecords(poses, 30.0);
  ASSERT_EQ(direct.size(), 3u);
  EXPECT_EQ(direct[0].prev_stamp_text, "100");
  EXPECT_EQ(direct[0].stamp_text, "101");
  EXPECT_DOUBLE_EQ(direct[2].stamp_s, 103.0 / 30.0);
  EXPECT_EQ(direct[1].covariance, poses[2].rel_covariance);

  const std::string path = ::testing::TempDir() + "pplvo_nees_poses.lcmlog";
  {
    logging::EventLogWriter writer(path);
    // Written out of order: the reader orders by seq.
    for (int k : {0, 2, 1, 3}) {
      const pplvo_msgs::pose_t msg = msgs::toMsg(poses[k]);
      std::vector<uint8_t> buf(msg.getEncodedSize());
      msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
      writer.write("PPLVO_POSE", 1000 + k, buf.data(), static_cast<int32_t>(buf.size()));
      writer.write("PPLVO_OTHER", 1000 + k, buf.data(), static_cast<int32_t>(buf.size()));
    }
  }
  ASSERT_TRUE(isLcmEventLog(path));
  const PoseLogReadResult log = readPoseLog(path);
  ASSERT_TRUE(log.ok) << log.error;
  ASSERT_EQ(log.poses.size(), 4u);
  const auto from_log = relativePoseRecords(log.poses, 30.0);
  ASSERT_EQ(from_log.size(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(from_log[k].stamp_text, direct[k].stamp_text);
    EXPECT_EQ(from_log[k].prev_stamp_text, direct[k].prev_stamp_text);
    EXPECT_EQ(from_log[k].covariance, direct[k].covariance);
  }
  std::remove(path.c_str());
}

#ifdef PPLVO_EVAL_BINARY
TEST(NeesProgram, CovarianceFileGivesTheLibraryFigures) {
  std::mt19937 rng(11);
  const std::string dir = ::testing::TempDir();
  const std::string gt_path = dir + "pplvo_nees_gt.txt", est_path = dir + "pplvo_nees_cov.txt",
                    data_path = dir + "pplvo_nees_data.txt", out_path = dir + "pplvo_nees_out.txt";
  TumFile gt;
  {
    std::ofstream g(gt_path);
    for (int i = 0; i <= 1200; ++i) {
      const TumRow r = tumRow(i * 0.01, truePose(i * 0.01));
      gt.rows.push_back(r);
      char buf[256];
      std::snprintf(buf, sizeof buf, "%.2f %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", r.stamp_s,
                    r.values[0], r.values[1], r.values[2], r.values[3], r.values[4], r.values[5],
                    r.values[6]);
      g << buf;
    }
  }
  const auto records = fabricate(rng, 300, 30.0, 1.0);
  {
    std::ofstream e(est_path);
    e << relativePoseFileHeader();
    for (const auto& r : records) e << formatRelativePoseLine(r);
  }
  const std::string cmd = std::string(PPLVO_EVAL_BINARY) + " --nees --exact-gt " + gt_path + " " +
                          est_path + " --nees-data " + data_path + " > " + out_path;
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream out(out_path);
  std::string key;
  double mean = -1;
  int pairs = -1;
  for (std::string line; std::getline(out, line);) {
    std::istringstream ls(line);
    ls >> key;
    if (key == "nees.mean") ls >> mean;
    if (key == "nees.pairs") ls >> pairs;
  }
  // The library on the same inputs (stamps as written: 6 decimals).
  const RelativePoseReadResult written = readRelativePoseFile(est_path);
  ASSERT_TRUE(written.ok) << written.error;
  NeesOptions o;
  o.gt = {0.0, 0.0, 0.0};
  const NeesResult lib = evaluateNees(gt, written.records, o);
  EXPECT_EQ(pairs, 300);
  EXPECT_NEAR(mean, lib.all.mean, 1e-4 * lib.all.mean);
  const NeesDataReadResult data = readNeesData(data_path);
  ASSERT_TRUE(data.ok) << data.error;
  ASSERT_EQ(data.rows.size(), 300u);
  EXPECT_NEAR(data.rows[10].nees, lib.pairs[10].nees, 1e-5 * lib.pairs[10].nees + 1e-9);
}
#endif

}  // namespace
}  // namespace pplvo::eval

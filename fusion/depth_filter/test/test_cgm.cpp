// C-GM (paper eqs. 2-6) on hand-computed 3x3 cases, and the stage-1 sensor model.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>

#include "pplvo/depth_filter/cgm_filter.h"
#include "pplvo/depth_filter/sensor_model.h"

namespace pplvo::depth_filter {
namespace {

/// Constant variance, to make hand computation easy (also exercises the plug-in interface).
class ConstantModel final : public SensorModel {
 public:
  explicit ConstantModel(float var) : var_(var) {}
  float varianceM2(float) const override { return var_; }

 private:
  float var_;
};

cv::Mat grid(std::initializer_list<float> v) {
  cv::Mat m(3, 3, CV_32FC1);
  auto it = v.begin();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.at<float>(r, c) = *it++;
  return m;
}

TEST(SensorModel, PaperEquation1InMetres) {
  QuadraticSensorModel model;
  // sigma = 1.425e-6 z^2 mm with z = 2000 mm -> 5.7 mm.
  EXPECT_NEAR(std::sqrt(model.varianceM2(2.0f)), 5.7e-3, 1e-8);
  cv::Mat d = grid({0, 1, 2, -1, std::numeric_limits<float>::quiet_NaN(), 3, 0, 0, 0});
  DepthWithVariance out = applySensorModel(model, d);
  EXPECT_EQ(out.depth_m.at<float>(1, 0), 0.f);  // negative -> missing
  EXPECT_EQ(out.depth_m.at<float>(1, 1), 0.f);  // NaN -> missing
  EXPECT_EQ(out.var_m2.at<float>(0, 0), 0.f);
  EXPECT_NEAR(out.var_m2.at<float>(1, 2), std::pow(1.425e-3 * 9, 2), 1e-10);
}

TEST(CgmFilter, FullNeighbourhoodMatchesHandComputation) {
  CgmFilter f(CgmFilter::Options(), std::make_shared<ConstantModel>(0.01f));
  DepthWithVariance out = f.apply(grid({1, 2, 1, 2, 3, 2, 1, 2, 1}));
  // S = 16; sum w z = 4*1 + 4*2*2 + 4*3 = 32; sum w z^2 = 4 + 32 + 36 = 72.
  EXPECT_NEAR(out.depth_m.at<float>(1, 1), 2.0, 1e-6);
  EXPECT_NEAR(out.var_m2.at<float>(1, 1), 72.0 / 16 + 0.01 - 4.0, 1e-6);
  // Image corner (0,0): neighbours (0,0) w4, (0,1) w2, (1,0) w2, (1,1) w1; outside = missing.
  const double s = 9, sz = 4 * 1 + 2 * 2 + 2 * 2 + 3, sq = 4 * 1 + 2 * 4 + 2 * 4 + 9;
  EXPECT_NEAR(out.depth_m.at<float>(0, 0), sz / s, 1e-6);
  EXPECT_NEAR(out.var_m2.at<float>(0, 0), sq / s + 0.01 - (sz / s) * (sz / s), 1e-6);
  EXPECT_EQ(out.window_length, 1);
}

TEST(CgmFilter, MissingPixelsLeaveTheNormaliser) {
  CgmFilter f(CgmFilter::Options(), std::make_shared<ConstantModel>(0.01f));
  // Top-left corner (w 1) and right edge (w 2) missing: S = 13.
  DepthWithVariance out = f.apply(grid({0, 2, 1, 2, 3, 0, 1, 2, 1}));
  const double s = 13, sz = 3 * 1 + 3 * 2 * 2 + 4 * 3, sq = 3 * 1 + 3 * 2 * 4 + 4 * 9;
  EXPECT_NEAR(out.depth_m.at<float>(1, 1), sz / s, 1e-6);
  EXPECT_NEAR(out.var_m2.at<float>(1, 1), sq / s + 0.01 - (sz / s) * (sz / s), 1e-6);
  EXPECT_EQ(out.depth_m.at<float>(0, 0), 0.f);  // missing centre stays missing (default)
  EXPECT_EQ(out.var_m2.at<float>(1, 2), 0.f);
}

TEST(CgmFilter, MissingCentreOptionallyFilledFromNeighbours) {
  CgmFilter::Options o;
  o.missing_centre_stays_missing = false;
  CgmFilter f(o, std::make_shared<ConstantModel>(0.01f));
  DepthWithVariance out = f.apply(grid({1, 1, 1, 1, 0, 1, 1, 1, 3}));
  // S = 12: sum w z = 1+2+1+2+2+1+2+3 = 14; sum w z^2 = 1+2+1+2+2+1+2+9 = 20.
  EXPECT_NEAR(out.depth_m.at<float>(1, 1), 14.0 / 12, 1e-6);
  EXPECT_NEAR(out.var_m2.at<float>(1, 1), 20.0 / 12 + 0.01 - (14.0 / 12) * (14.0 / 12), 1e-6);
}

TEST(CgmFilter, FlatPatchKeepsSensorVarianceAndEdgesGetLarge) {
  CgmFilter f;  // paper model
  cv::Mat d(20, 20, CV_32FC1, cv::Scalar(2.0f));
  d.colRange(10, 20).setTo(3.0f);  // a 1 m step
  DepthWithVariance out = f.apply(d);
  const double s2 = std::pow(1.425e-3 * 4, 2);
  EXPECT_NEAR(out.depth_m.at<float>(5, 3), 2.0, 1e-6);
  EXPECT_NEAR(out.var_m2.at<float>(5, 3), s2, 1e-9);
  // At the step: 3/4 at 2 m, 1/4 at 3 m -> spread 0.1875 m^2 dominates.
  EXPECT_NEAR(out.depth_m.at<float>(5, 9), 2.25, 1e-6);
  EXPECT_GT(out.var_m2.at<float>(5, 9), 0.18f);
}

TEST(CgmFilter, BadInputCountedAllZeroAndWrongType) {
  CgmFilter f;
  cv::Mat d = cv::Mat::zeros(4, 5, CV_32FC1);
  DepthWithVariance out = f.apply(d);
  EXPECT_EQ(cv::countNonZero(out.depth_m), 0);
  EXPECT_EQ(f.stats().last_valid_out, 0);
  d.at<float>(1, 1) = std::numeric_limits<float>::quiet_NaN();
  d.at<float>(2, 2) = -1.f;
  d.at<float>(3, 3) = std::numeric_limits<float>::infinity();
  out = f.apply(d);
  EXPECT_EQ(f.stats().invalid_inputs, 3);
  EXPECT_EQ(cv::countNonZero(out.depth_m), 0);
  EXPECT_THROW(f.apply(cv::Mat::zeros(3, 3, CV_16UC1)), std::invalid_argument);
  EXPECT_THROW(f.apply(cv::Mat()), std::invalid_argument);
  // Size change re-sizes the buffers.
  out = f.apply(cv::Mat(7, 9, CV_32FC1, cv::Scalar(1.0f)));
  EXPECT_EQ(out.depth_m.size(), cv::Size(9, 7));
  EXPECT_EQ(f.stats().resizes, 2);
}

}  // namespace
}  // namespace pplvo::depth_filter

namespace pplvo::depth_filter {
namespace {

TEST(CgmFilter, OutputAndCountsDoNotDependOnTheThreadCount) {
  cv::Mat depth(97, 131, CV_32FC1);  // odd sizes: bands of unequal height
  cv::RNG rng(7);
  rng.fill(depth, cv::RNG::UNIFORM, 0.5, 4.0);
  for (int i = 0; i < 800; ++i) depth.at<float>(rng.uniform(0, 97), rng.uniform(0, 131)) = 0.f;
  depth.at<float>(24, 10) = std::numeric_limits<float>::quiet_NaN();  // on a band border
  depth.at<float>(48, 11) = -1.f;
  for (const cv::Size size : {cv::Size(131, 97), cv::Size(5, 3), cv::Size(4, 1)}) {
    const cv::Mat in = depth(cv::Rect(0, 0, size.width, size.height)).clone();
    CgmOptions o;
    o.threads = 1;
    CgmFilter serial(o);
    const DepthWithVariance ref = serial.apply(in);
    for (int threads : {2, 3, 8}) {
      o.threads = threads;
      CgmFilter banded(o);
      const DepthWithVariance out = banded.apply(in);
      EXPECT_EQ(cv::norm(out.depth_m, ref.depth_m, cv::NORM_INF), 0.0) << threads << " " << size;
      EXPECT_EQ(cv::norm(out.var_m2, ref.var_m2, cv::NORM_INF), 0.0) << threads << " " << size;
      EXPECT_EQ(banded.stats().invalid_inputs, serial.stats().invalid_inputs);
      EXPECT_EQ(banded.stats().last_valid_in, serial.stats().last_valid_in);
      EXPECT_EQ(banded.stats().last_valid_out, serial.stats().last_valid_out);
    }
  }
}

}  // namespace
}  // namespace pplvo::depth_filter

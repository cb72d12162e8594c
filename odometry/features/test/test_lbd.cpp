// pplvo's binary LBD (pplvo/features/lbd.h): invariances it must have, that it tells edges
// apart as well as OpenCV's LBD on the same segments, and degenerate inputs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>
#include <opencv2/line_descriptor.hpp>

#include "pplvo/features/lbd.h"
#include "pplvo/features/line_extractor.h"
#include "pplvo/features/lsd.h"
#include "pplvo/fixtures/textured_plane.h"

using namespace pplvo;
using namespace pplvo::features;

namespace {

int hamming(const cv::Mat& a, int i, const cv::Mat& b, int j) {
  return static_cast<int>(cv::norm(a.row(i), b.row(j), cv::NORM_HAMMING));
}

/// The LSD segments of `gray` at least `min_length` long whose LBD region (+-32 px) stays
/// `margin` pixels inside the image.
std::vector<cv::Vec4f> interiorSegments(const cv::Mat& gray, float min_length, float margin) {
  std::vector<cv::Vec4f> out;
  for (const auto& s : detectLineSegments(gray)) {
    if (std::hypot(s[2] - s[0], s[3] - s[1]) < min_length) continue;
    const float lo = 32.f + margin;
    const bool inside = std::min({s[0], s[2]}) >= lo && std::min({s[1], s[3]}) >= lo &&
                        std::max({s[0], s[2]}) <= gray.cols - 1 - lo &&
                        std::max({s[1], s[3]}) <= gray.rows - 1 - lo;
    if (inside) out.push_back(s);
  }
  return out;
}

}  // namespace

TEST(Lbd, ShiftingOrTurningTheImageLeavesTheDescriptor) {
  const cv::Mat gray = pplvo::fixtures::texturedPlaneView();
  const auto segments = interiorSegments(gray, 20.f, 12.f);
  ASSERT_GT(segments.size(), 20u);
  const cv::Mat d = describeLineSegments(gray, segments);
  ASSERT_EQ(d.rows, static_cast<int>(segments.size()));
  ASSERT_EQ(d.cols, kLbdBytes);
  ASSERT_EQ(d.type(), CV_8UC1);

  // An integer shift of image and segments: the same pixels are sampled.
  cv::Mat shifted(gray.size(), gray.type(), cv::Scalar(0));
  gray(cv::Rect(7, 5, gray.cols - 7, gray.rows - 5))
      .copyTo(shifted(cv::Rect(0, 0, gray.cols - 7, gray.rows - 5)));
  std::vector<cv::Vec4f> moved;
  for (const auto& s : segments) moved.emplace_back(s[0] - 7, s[1] - 5, s[2] - 7, s[3] - 5);
  const cv::Mat ds = describeLineSegments(shifted, moved);

  // A quarter turn clockwise: pixel (x, y) goes to (H - 1 - y, x); the gradient turns with it.
  cv::Mat turned;
  cv::rotate(gray, turned, cv::ROTATE_90_CLOCKWISE);
  std::vector<cv::Vec4f> rotated;
  const float h1 = gray.rows - 1.f;
  for (const auto& s : segments) rotated.emplace_back(h1 - s[1], s[0], h1 - s[3], s[2]);
  const cv::Mat dt = describeLineSegments(turned, rotated);

  std::vector<int> turned_bits;
  for (int i = 0; i < d.rows; ++i) {
    EXPECT_EQ(hamming(d, i, ds, i), 0) << "segment " << i << " after a shift";
    turned_bits.push_back(hamming(d, i, dt, i));
  }
  // Sampling positions turn exactly; only positions at x.5 round to the other pixel (and float
  // rounding), which flips a few bits of a few segments.
  std::sort(turned_bits.begin(), turned_bits.end());
  std::printf("bits changed by a quarter turn: median %d, most %d\n",
              turned_bits[turned_bits.size() / 2], turned_bits.back());
  EXPECT_LE(turned_bits[turned_bits.size() / 2], 2);
  EXPECT_LE(turned_bits.back(), 24);
}

TEST(Lbd, GainAndOffsetOfTheImageBarelyChangeIt) {
  const cv::Mat gray = pplvo::fixtures::texturedPlaneView();
  const auto segments = interiorSegments(gray, 20.f, 0.f);
  ASSERT_GT(segments.size(), 20u);
  cv::Mat dimmer;
  gray.convertTo(dimmer, CV_8U, 0.6, 30.0);  // a different exposure
  const cv::Mat a = describeLineSegments(gray, segments),
                b = describeLineSegments(dimmer, segments);
  std::vector<int> distances;
  for (int i = 0; i < a.rows; ++i) distances.push_back(hamming(a, i, b, i));
  std::nth_element(distances.begin(), distances.begin() + distances.size() / 2, distances.end());
  std::printf("bits changed by the exposure: median %d\n", distances[distances.size() / 2]);
  EXPECT_LE(distances[distances.size() / 2], 12) << "median bits changed by the exposure";
}

TEST(Lbd, TellsSegmentsApartLikeOpenCvsLbd) {
  // On the same segments, the nearest other segment's descriptor is as far from each one with
  // pplvo's LBD as with OpenCV's: the median distance to the closest different segment.
  const cv::Mat gray = pplvo::fixtures::texturedPlaneView();
  const auto segments = interiorSegments(gray, 15.f, 0.f);
  ASSERT_GT(segments.size(), 30u);
  const cv::Mat ours = describeLineSegments(gray, segments);

  // OpenCV's LBD of the same segments (one octave, KeyLines as the extractor builds them).
  std::vector<cv::line_descriptor::KeyLine> keylines = toKeyLines(segments, gray.size());
  cv::Mat theirs;
  cv::line_descriptor::BinaryDescriptor::createBinaryDescriptor()->compute(gray, keylines, theirs);
  ASSERT_EQ(theirs.rows, ours.rows);
  auto nearestOther = [](const cv::Mat& d) {
    std::vector<int> nearest;
    for (int i = 0; i < d.rows; ++i) {
      int best = 256;
      for (int j = 0; j < d.rows; ++j)
        if (j != i) best = std::min(best, hamming(d, i, d, j));
      nearest.push_back(best);
    }
    std::nth_element(nearest.begin(), nearest.begin() + nearest.size() / 2, nearest.end());
    return nearest[nearest.size() / 2];
  };
  const int ours_median = nearestOther(ours), theirs_median = nearestOther(theirs);
  std::printf("median distance to the nearest other segment: pplvo %d bits, OpenCV %d bits\n",
              ours_median, theirs_median);
  EXPECT_GE(ours_median, theirs_median - 8);
  EXPECT_GE(ours_median, 25);
}

TEST(Lbd, DegenerateInputs) {
  const cv::Mat gray = pplvo::fixtures::texturedPlaneView();
  EXPECT_EQ(describeLineSegments(gray, {}).rows, 0);
  EXPECT_EQ(describeLineSegments(gray, {}).cols, kLbdBytes);
  // Zero length, not finite, outside the image, beyond int range: all-zero rows, one per
  // segment.
  const std::vector<cv::Vec4f> odd = {{100, 100, 100, 100},
                                      {NAN, 3, 50, 60},
                                      {-5000, -5000, -4000, -4000},
                                      {1e30f, 10, 1e30f, 500},
                                      {10, INFINITY, 20, 30},
                                      {100, 100, 200, 150}};
  const cv::Mat d = describeLineSegments(gray, odd);
  ASSERT_EQ(d.rows, 6);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(cv::countNonZero(d.row(i)), 0) << i;
  EXPECT_GT(cv::countNonZero(d.row(5)), 0);
  // No image: zero descriptors of the right shape.
  const cv::Mat none = describeLineSegments(cv::Mat(), {{0, 0, 10, 10}});
  EXPECT_EQ(none.rows, 1);
  EXPECT_EQ(cv::countNonZero(none), 0);
  EXPECT_THROW(describeLineSegments(cv::Mat(10, 10, CV_8UC3, cv::Scalar::all(0)), odd),
               cv::Exception);
  LbdOptions o;
  o.band_width = 0;
  EXPECT_THROW(describeLineSegments(gray, odd, o), cv::Exception);
  o.band_width = 65;
  EXPECT_THROW(describeLineSegments(gray, odd, o), cv::Exception);
}

// pplvo's LSD (pplvo/features/lsd.h): geometry on drawn edges, equivalence with OpenCV's LSD
// without refinement on textured and real images, and degenerate inputs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "pplvo/features/lbd.h"
#include "pplvo/features/line_extractor.h"
#include "pplvo/features/lsd.h"
#include "shared_sequence.h"
#include "pplvo/fixtures/textured_plane.h"

using namespace pplvo;
using namespace pplvo::features;

namespace {

float length(const cv::Vec4f& s) { return std::hypot(s[2] - s[0], s[3] - s[1]); }

/// Same segment: both endpoints within `tol` pixels, in the same order (LSD orients a
/// segment by its gradient, and LBD describes it in that orientation).
bool sameSegment(const cv::Vec4f& a, const cv::Vec4f& b, float tol) {
  return std::hypot(a[0] - b[0], a[1] - b[1]) < tol && std::hypot(a[2] - b[2], a[3] - b[3]) < tol;
}

/// Fraction of the segments of `a` at least `min_length` long that have the same segment in `b`.
double sharedFraction(const std::vector<cv::Vec4f>& a, const std::vector<cv::Vec4f>& b,
                      float min_length, float tol, int* counted = nullptr) {
  int n = 0, found = 0;
  for (const auto& s : a) {
    if (length(s) < min_length) continue;
    ++n;
    found += std::any_of(b.begin(), b.end(), [&](const cv::Vec4f& t) { return sameSegment(s, t, tol); });
  }
  if (counted) *counted = n;
  return n > 0 ? static_cast<double>(found) / n : 1.0;
}

std::vector<cv::Vec4f> opencvLsd(const cv::Mat& gray) {
  std::vector<cv::Vec4f> segments;
  cv::createLineSegmentDetector(cv::LSD_REFINE_NONE, 1.0)->detect(gray, segments);
  return segments;
}

/// Equivalence on one image: nearly every segment of each detector is found by the other at
/// the same place and orientation.
void expectSameAsOpenCv(const cv::Mat& gray, const std::string& what) {
  const auto ours = detectLineSegments(gray);
  const auto theirs = opencvLsd(gray);
  int counted = 0;
  EXPECT_GE(sharedFraction(theirs, ours, 10.f, 0.5f, &counted), 0.95) << what;
  EXPECT_GE(sharedFraction(ours, theirs, 10.f, 0.5f), 0.95) << what;
  EXPECT_GT(counted, 10) << what << ": too few segments for the comparison to mean much";
  EXPECT_NEAR(static_cast<double>(ours.size()), static_cast<double>(theirs.size()),
              0.05 * theirs.size() + 2)
      << what;
}

}  // namespace

TEST(Lsd, RectangleGivesItsFourSidesOrientedByTheGradient) {
  // A bright rectangle with corners at pixel centres (100, 80) .. (299, 219): its edges lie
  // half a pixel outside, at x = 99.5, 299.5 and y = 79.5, 219.5.
  cv::Mat img(300, 400, CV_8UC1, cv::Scalar(40));
  img(cv::Rect(100, 80, 200, 140)).setTo(200);
  const auto segments = detectLineSegments(img);
  ASSERT_EQ(segments.size(), 4u);
  int vertical = 0, horizontal = 0;
  for (const auto& s : segments) {
    const cv::Point2f a(s[0], s[1]), b(s[2], s[3]);
    if (std::abs(a.x - b.x) < 1.f) {
      ++vertical;
      EXPECT_TRUE(std::abs(a.x - 99.5f) < 0.1f || std::abs(a.x - 299.5f) < 0.1f) << a.x;
      EXPECT_NEAR(std::abs(b.y - a.y), 140.f, 3.f);
      // LSD's orientation (level lines): walking from a to b on the screen, the brighter side
      // is on the left.
      const bool left_edge = a.x < 200.f;
      EXPECT_EQ(left_edge, b.y > a.y) << "left edge runs down, right edge runs up";
    } else {
      ++horizontal;
      EXPECT_TRUE(std::abs(a.y - 79.5f) < 0.1f || std::abs(a.y - 219.5f) < 0.1f) << a.y;
      EXPECT_NEAR(std::abs(b.x - a.x), 200.f, 3.f);
      const bool top_edge = a.y < 150.f;
      EXPECT_EQ(top_edge, b.x < a.x) << "top edge runs left, bottom edge runs right";
    }
  }
  EXPECT_EQ(vertical, 2);
  EXPECT_EQ(horizontal, 2);
}

TEST(Lsd, SlantedEdgeFollowsItsAngle) {
  // A half-plane bounded by a line through (320, 240) at 30 degrees, anti-aliased by
  // supersampling: one long segment along it.
  const double angle = 30.0 * CV_PI / 180.0, nx = -std::sin(angle), ny = std::cos(angle);
  cv::Mat big(480 * 4, 640 * 4, CV_8UC1);
  for (int y = 0; y < big.rows; ++y) {
    for (int x = 0; x < big.cols; ++x) {
      const double u = (x + 0.5) / 4.0 - 0.5 - 320, v = (y + 0.5) / 4.0 - 0.5 - 240;
      big.at<uint8_t>(y, x) = u * nx + v * ny > 0 ? 190 : 60;
    }
  }
  cv::Mat img;
  cv::resize(big, img, cv::Size(640, 480), 0, 0, cv::INTER_AREA);
  const auto segments = detectLineSegments(img);
  ASSERT_FALSE(segments.empty());
  const auto longest = *std::max_element(segments.begin(), segments.end(),
                                         [](const auto& a, const auto& b) { return length(a) < length(b); });
  EXPECT_GT(length(longest), 400.f);
  double seg_angle = std::atan2(longest[3] - longest[1], longest[2] - longest[0]);
  if (seg_angle < 0) seg_angle += CV_PI;
  EXPECT_NEAR(seg_angle * 180.0 / CV_PI, 30.0, 0.2);
  // Both endpoints on the edge line.
  for (int k = 0; k < 4; k += 2) {
    EXPECT_NEAR((longest[k] - 320) * nx + (longest[k + 1] - 240) * ny, 0.0, 0.3);
  }
}

TEST(Lsd, FindsTheSegmentsOfOpenCvsLsdOnATexturedScene) {
  // The feature tests' textured plane, seen at an angle, at full and reduced resolution.
  const cv::Mat gray = pplvo::fixtures::texturedPlaneView();
  ASSERT_FALSE(gray.empty());
  expectSameAsOpenCv(gray, "textured plane, VGA");
  cv::Mat small;
  cv::resize(gray, small, cv::Size(), 0.4, 0.4, cv::INTER_AREA);
  expectSameAsOpenCv(small, "textured plane, x0.4");
}

TEST(Lsd, FindsTheSegmentsOfOpenCvsLsdOnSharedFrames) {
  int sequences = 0;
  for (const char* name : {"icl_living_room_kt0_short", "tum_fr3_sitting_static_short"}) {
    const auto seq = testdata::loadSharedSequence(name);
    if (!seq) continue;
    ++sequences;
    for (size_t k = 0; k < seq->frames.size(); k += seq->frames.size() / 3) {
      const cv::Mat gray = testdata::loadGray(seq->frames[k]);
      ASSERT_FALSE(gray.empty());
      cv::Mat small;  // the frontend's default detection scale
      cv::resize(gray, small, cv::Size(), 0.4, 0.4, cv::INTER_AREA);
      expectSameAsOpenCv(small, std::string(name) + " frame " + std::to_string(k));
    }
  }
  if (sequences == 0) GTEST_SKIP() << "shared data not found in " << testdata::sharedDataDir();
}

TEST(Lsd, DegenerateImages) {
  EXPECT_TRUE(detectLineSegments(cv::Mat()).empty());
  EXPECT_TRUE(detectLineSegments(cv::Mat(1, 1, CV_8UC1, cv::Scalar(9))).empty());
  EXPECT_TRUE(detectLineSegments(cv::Mat(1, 500, CV_8UC1, cv::Scalar(9))).empty());
  EXPECT_TRUE(detectLineSegments(cv::Mat(2, 2, CV_8UC1, cv::Scalar(9))).empty());
  EXPECT_TRUE(detectLineSegments(cv::Mat(240, 320, CV_8UC1, cv::Scalar(128))).empty());
  // Noise below the gradient threshold (q / sin(tau) ~ 5.2 grey levels) gives nothing.
  cv::Mat faint(240, 320, CV_8UC1);
  cv::randu(faint, cv::Scalar(100), cv::Scalar(103));
  EXPECT_TRUE(detectLineSegments(faint).empty());
  // A checkerboard of single pixels: strong gradients but no aligned region.
  cv::Mat checker(64, 64, CV_8UC1);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) checker.at<uint8_t>(y, x) = ((x + y) % 2) ? 255 : 0;
  for (const auto& s : detectLineSegments(checker)) EXPECT_LT(length(s), 10.f);
  // A non-contiguous view (a ROI) works like its copy.
  cv::Mat img(300, 400, CV_8UC1, cv::Scalar(40));
  img(cv::Rect(100, 80, 200, 140)).setTo(200);
  const cv::Mat roi = img(cv::Rect(50, 40, 300, 220));
  const auto a = detectLineSegments(roi), b = detectLineSegments(roi.clone());
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_TRUE(sameSegment(a[i], b[i], 1e-6f));
}

TEST(Lsd, RejectsOtherImageTypesAndBadOptions) {
  EXPECT_THROW(detectLineSegments(cv::Mat(10, 10, CV_8UC3, cv::Scalar::all(0))), cv::Exception);
  EXPECT_THROW(detectLineSegments(cv::Mat(10, 10, CV_16UC1, cv::Scalar(0))), cv::Exception);
  const cv::Mat img(10, 10, CV_8UC1, cv::Scalar(0));
  LsdOptions o;
  o.angle_tolerance_deg = 0;
  EXPECT_THROW(detectLineSegments(img, o), cv::Exception);
  o.angle_tolerance_deg = 180;
  EXPECT_THROW(detectLineSegments(img, o), cv::Exception);
  o = LsdOptions{};
  o.gradient_bins = 0;
  EXPECT_THROW(detectLineSegments(img, o), cv::Exception);
}

TEST(LineExtractor, OpenCvsLsdAndLbdRemainAvailable) {
  // use_opencv, lsd_refine and lbd_octaves select OpenCV's LSD and LBD; on a rectangle every
  // combination gives its four sides with a descriptor each, and the sides agree.
  cv::Mat img(480, 640, CV_8UC1, cv::Scalar(50));
  img(cv::Rect(200, 150, 240, 180)).setTo(200);
  const LineExtraction ours = LineExtractor().extract(img, pplvo::fixtures::kinectVgaCamera());
  ASSERT_EQ(ours.lines.size(), 4u);
  for (const bool use_opencv : {false, true}) {
    for (const int refine : {cv::LSD_REFINE_NONE, cv::LSD_REFINE_STD}) {
      for (const int octaves : {1, 2}) {
        LineDetectorVariant v;
        v.use_opencv = use_opencv;
        v.lsd_refine = refine;
        v.lbd_octaves = octaves;
        const LineExtraction r =
            LineExtractor({}, v).extract(img, pplvo::fixtures::kinectVgaCamera());
        const std::string what = "opencv " + std::to_string(use_opencv) + " refine " +
                                 std::to_string(refine) + " octaves " + std::to_string(octaves);
        EXPECT_TRUE(r.stats.error.empty()) << what << ": " << r.stats.error;
        ASSERT_EQ(r.lines.size(), 4u) << what;
        EXPECT_EQ(r.descriptors.rows, 4) << what;
        EXPECT_EQ(r.descriptors.cols, kLbdBytes) << what;
        for (const auto& l : r.lines) {
          const bool found = std::any_of(ours.lines.begin(), ours.lines.end(), [&](const LineFeature& m) {
            return (l.px1 - m.px1).norm() < 1.5 && (l.px2 - m.px2).norm() < 1.5;
          });
          EXPECT_TRUE(found) << what;
        }
      }
    }
  }
}

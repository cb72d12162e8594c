#include "pplvo/features/line_extractor.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace pplvo::features {

namespace ld = cv::line_descriptor;

Eigen::Vector3d lineEquation(const Eigen::Vector2d& p1, const Eigen::Vector2d& p2) {
  const Eigen::Vector3d l = Eigen::Vector3d(p1.x(), p1.y(), 1.0).cross(
      Eigen::Vector3d(p2.x(), p2.y(), 1.0));
  const double n = std::hypot(l.x(), l.y());
  if (!(n > 0.0) || !std::isfinite(n)) return Eigen::Vector3d::Zero();
  return l / n;
}

LineExtractor::LineExtractor(const LineExtractorOptions& options,
                             const LineDetectorVariant& variant)
    : options_(options), variant_(variant) {
  // pplvo's LSD and LBD unless OpenCV's are asked for or needed: LSD's refinements and LBD
  // over several octaves are OpenCV's only.
  if (variant_.use_opencv || variant_.lsd_refine != cv::LSD_REFINE_NONE)
    opencv_lsd_ = cv::createLineSegmentDetector(variant_.lsd_refine, 1.0);
  if (variant_.use_opencv || variant_.lbd_octaves > 1) {
    ld::BinaryDescriptor::Params params;
    params.widthOfBand_ = options_.lbd_band_width;
    params.numOfOctave_ = std::max(1, variant_.lbd_octaves);
    opencv_lbd_ = ld::BinaryDescriptor::createBinaryDescriptor(params);
  }
}

std::vector<ld::KeyLine> toKeyLines(const std::vector<cv::Vec4f>& segments, cv::Size image) {
  const float max_side = static_cast<float>(std::max(image.width, image.height));
  std::vector<ld::KeyLine> keylines;
  keylines.reserve(segments.size());
  for (const auto& s : segments) {
    ld::KeyLine kl;
    kl.startPointX = kl.sPointInOctaveX = s[0];
    kl.startPointY = kl.sPointInOctaveY = s[1];
    kl.endPointX = kl.ePointInOctaveX = s[2];
    kl.endPointY = kl.ePointInOctaveY = s[3];
    kl.lineLength = std::hypot(s[2] - s[0], s[3] - s[1]);
    kl.angle = std::atan2(s[3] - s[1], s[2] - s[0]);
    kl.octave = 0;
    kl.class_id = static_cast<int>(keylines.size());
    kl.numOfPixels = static_cast<int>(std::ceil(kl.lineLength));
    kl.response = max_side > 0 ? kl.lineLength / max_side : 0.f;
    kl.size = std::abs((s[2] - s[0]) * (s[3] - s[1]));
    kl.pt = cv::Point2f(0.5f * (s[0] + s[2]), 0.5f * (s[1] + s[3]));
    keylines.push_back(kl);
  }
  return keylines;
}

cv::Mat LineExtractor::describeWithOpenCv(const cv::Mat& image,
                                          const std::vector<cv::Vec4f>& segments) const {
  std::vector<ld::KeyLine> keylines = toKeyLines(segments, image.size());
  cv::Mat computed;
  opencv_lbd_->compute(image, keylines, computed);
  if (computed.rows != static_cast<int>(keylines.size())) return {};
  // Rows in the order of `segments` (compute() reports each row's class_id).
  cv::Mat descriptors(computed.rows, computed.cols, computed.type());
  std::vector<char> seen(segments.size(), 0);
  for (int k = 0; k < computed.rows; ++k) {
    const int id = keylines[k].class_id;
    if (id < 0 || id >= static_cast<int>(segments.size()) || seen[id]) return {};
    seen[id] = 1;
    computed.row(k).copyTo(descriptors.row(id));
  }
  return descriptors;
}

LineExtraction LineExtractor::extract(const cv::Mat& image, const PinholeCamera& camera) const {
  LineExtraction result;
  if (image.empty() || image.depth() != CV_8U || image.cols < options_.min_image_side_px ||
      image.rows < options_.min_image_side_px || options_.max_lines <= 0) {
    if (!image.empty() && image.depth() != CV_8U) result.stats.error = "image is not 8-bit";
    return result;
  }
  cv::Mat gray;
  if (image.channels() == 1) gray = image;
  else if (image.channels() == 3) cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  else if (image.channels() == 4) cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
  else {
    result.stats.error = "unsupported number of channels";
    return result;
  }
  try {
    const double scale = std::clamp(options_.detection_scale, 0.05, 1.0);
    cv::Mat small = gray;
    if (scale < 1.0) {
      cv::resize(gray, small, cv::Size(), scale, scale, cv::INTER_AREA);
      if (small.cols < 8 || small.rows < 8) return result;
    }
    std::vector<cv::Vec4f> segments;
    if (opencv_lsd_)
      opencv_lsd_->detect(small, segments);
    else
      segments = detectLineSegments(small);
    // LSD returns pixel-centre coordinates of `small`; map to full resolution (pixel centres
    // (x + 0.5) / scale - 0.5).
    const float s_inv = static_cast<float>(1.0 / scale);
    const float off = 0.5f * s_inv - 0.5f;
    const float wmax = gray.cols - 1.f, hmax = gray.rows - 1.f;
    for (auto& sg : segments) {
      for (int k = 0; k < 4; ++k) sg[k] = sg[k] * s_inv + off;
      sg[0] = std::clamp(sg[0], 0.f, wmax);
      sg[2] = std::clamp(sg[2], 0.f, wmax);
      sg[1] = std::clamp(sg[1], 0.f, hmax);
      sg[3] = std::clamp(sg[3], 0.f, hmax);
    }
    result.stats.detected = static_cast<int>(segments.size());
    // Length filter, then keep the longest.
    std::vector<std::pair<float, int>> by_length;
    by_length.reserve(segments.size());
    const double min_len = std::max(1.0, options_.min_length_px);
    for (int i = 0; i < static_cast<int>(segments.size()); ++i) {
      const auto& s = segments[i];
      const float len = std::hypot(s[2] - s[0], s[3] - s[1]);
      if (std::isfinite(len) && len >= min_len) by_length.emplace_back(len, i);
    }
    std::stable_sort(by_length.begin(), by_length.end(),
                     [](const auto& a, const auto& b) { return a.first > b.first; });
    if (static_cast<int>(by_length.size()) > options_.max_lines)
      by_length.resize(options_.max_lines);
    if (by_length.empty()) return result;

    // The kept segments in the coordinates of the image LBD runs on.
    const cv::Mat& desc_img = variant_.describe_full_resolution ? gray : small;
    const float ds = static_cast<float>(desc_img.cols) / static_cast<float>(gray.cols);
    const float dd = ds == 1.f ? 0.f : 0.5f * ds - 0.5f;  // full-res centre -> desc_img
    const float w1 = desc_img.cols - 1.f, h1 = desc_img.rows - 1.f;
    std::vector<cv::Vec4f> described;
    described.reserve(by_length.size());
    for (const auto& [len, i] : by_length) {
      const auto& s = segments[i];
      described.emplace_back(
          std::clamp(s[0] * ds + dd, 0.f, w1), std::clamp(s[1] * ds + dd, 0.f, h1),
          std::clamp(s[2] * ds + dd, 0.f, w1), std::clamp(s[3] * ds + dd, 0.f, h1));
    }
    const cv::Mat descriptors = opencv_lbd_ ? describeWithOpenCv(desc_img, described)
                                            : describeLineSegments(desc_img, described,
                                                                   {options_.lbd_band_width});
    if (descriptors.rows != static_cast<int>(described.size())) {
      result.stats.error = "LBD descriptor count disagrees with segments";
      return result;
    }
    const bool undistort = camera.valid() && camera.hasDistortion();
    result.lines.reserve(by_length.size());
    for (const auto& [len, i] : by_length) {
      const auto& s = segments[i];  // full resolution
      LineFeature f;
      const Eigen::Vector2d p1(s[0], s[1]), p2(s[2], s[3]);
      f.px1 = undistort ? camera.undistortPixel(p1) : p1;
      f.px2 = undistort ? camera.undistortPixel(p2) : p2;
      f.eq = lineEquation(f.px1, f.px2);
      result.lines.push_back(f);
    }
    result.descriptors = descriptors;
    result.stats.kept = static_cast<int>(result.lines.size());
  } catch (const cv::Exception& e) {
    result = LineExtraction{};
    result.stats.error = e.what();
  }
  return result;
}

LineExtractionStats LineExtractor::extractInto(const cv::Mat& image, const PinholeCamera& camera,
                                               FrameFeatures& frame) const {
  LineExtraction r = extract(image, camera);
  frame.lines = std::move(r.lines);
  frame.line_descriptors = r.descriptors;
  return r.stats;
}

}  // namespace pplvo::features

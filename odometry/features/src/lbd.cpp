#include "pplvo/features/lbd.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include <opencv2/imgproc.hpp>

namespace pplvo::features {

namespace {

/// The band pairs of the 32 bytes: all pairs ordered by the bands' distance, then by the
/// first band; the four farthest apart are left out.
std::array<std::pair<int, int>, kLbdBytes> bandPairs() {
  std::array<std::pair<int, int>, kLbdBytes> pairs{};
  int n = 0;
  for (int gap = 1; gap < kLbdBands && n < kLbdBytes; ++gap) {
    for (int i = 0; i + gap < kLbdBands && n < kLbdBytes; ++i) pairs[n++] = {i, i + gap};
  }
  return pairs;
}

/// Scales `count` values taken every 8th element from `v` (starting at `first`) to unit norm.
void normalise(float* v, int first, int count) {
  double sq = 0;
  for (int k = 0; k < count; ++k) {
    const float x = v[(k / 4) * 8 + first + k % 4];
    sq += static_cast<double>(x) * x;
  }
  if (!(sq > 0)) return;
  const float inv = static_cast<float>(1.0 / std::sqrt(sq));
  for (int k = 0; k < count; ++k) v[(k / 4) * 8 + first + k % 4] *= inv;
}

}  // namespace

cv::Mat describeLineSegments(const cv::Mat& gray, const std::vector<cv::Vec4f>& segments,
                             const LbdOptions& options) {
  CV_Assert(gray.empty() || gray.type() == CV_8UC1);
  CV_Assert(options.band_width >= 1 && options.band_width <= 64);
  cv::Mat descriptors(static_cast<int>(segments.size()), kLbdBytes, CV_8UC1, cv::Scalar(0));
  if (segments.empty() || gray.empty()) return descriptors;

  cv::Mat gx, gy;  // 3x3 Sobel, CV_16S
  cv::spatialGradient(gray, gx, gy, 3, cv::BORDER_REPLICATE);
  const int16_t* gx_data = gx.ptr<int16_t>();
  const int16_t* gy_data = gy.ptr<int16_t>();
  const size_t gx_step = gx.step1(), gy_step = gy.step1();
  const unsigned cols = static_cast<unsigned>(gray.cols), height = static_cast<unsigned>(gray.rows);

  const int w = options.band_width, rows = kLbdBands * w;
  const double half = 0.5 * (rows - 1);
  // Global weight of each row (sigma = half the region's height) and the local weight of row k
  // for band j (sigma = w around the band's centre row); Gaussian constants cancel in the
  // normalisation.
  std::vector<float> global(rows), local(static_cast<size_t>(kLbdBands) * rows, 0.f);
  for (int r = 0; r < rows; ++r) {
    const double o = r - half;
    global[r] = static_cast<float>(std::exp(-o * o / (2 * half * half)));
  }
  for (int j = 0; j < kLbdBands; ++j) {
    const double centre = j * w + 0.5 * (w - 1);
    for (int r = std::max(0, (j - 1) * w); r < std::min(rows, (j + 2) * w); ++r) {
      const double d = r - centre;
      local[static_cast<size_t>(j) * rows + r] =
          static_cast<float>(std::exp(-d * d / (2.0 * w * w)));
    }
  }
  const auto pairs = bandPairs();

  std::vector<std::array<float, 4>> row_sums(rows);
  for (size_t s = 0; s < segments.size(); ++s) {
    const cv::Vec4f& seg = segments[s];
    // Far outside any image (or NaN): nothing to sample, and the pixel arithmetic below needs
    // coordinates well inside int range. Such segments keep an all-zero descriptor.
    constexpr float kMaxCoordinate = 1e5f;
    if (!(std::abs(seg[0]) < kMaxCoordinate && std::abs(seg[1]) < kMaxCoordinate &&
          std::abs(seg[2]) < kMaxCoordinate && std::abs(seg[3]) < kMaxCoordinate))
      continue;
    const float dx = seg[2] - seg[0], dy = seg[3] - seg[1];
    const float length = std::hypot(dx, dy);
    if (!(length > 0.f)) continue;
    const float ux = dx / length, uy = dy / length;           // along the segment
    const float nx = -uy, ny = ux;                            // across it
    const int samples = static_cast<int>(length) + 1;
    const float step = samples > 1 ? length / (samples - 1) : 0.f;

    // Per row of the support region: sums of the positive and negative parts of the gradient
    // across and along the line, sampled at the nearest pixel every pixel of length.
    const float sx = step * ux, sy = step * uy;
    for (int r = 0; r < rows; ++r) {
      const float o = static_cast<float>(r - half);
      const float x0 = seg[0] + o * nx, y0 = seg[1] + o * ny;
      // Positive and negative parts from the sums of the values and of their magnitudes:
      // branch-free (the signs are as good as random, and mispredicted branches dominated).
      float across_sum = 0, across_abs = 0, along_sum = 0, along_abs = 0;
      auto add = [&](int x, int y) {
        const float gxv = gx_data[y * gx_step + x], gyv = gy_data[y * gy_step + x];
        const float across = gxv * nx + gyv * ny, along = gxv * ux + gyv * uy;
        across_sum += across;
        across_abs += std::fabs(across);
        along_sum += along;
        along_abs += std::fabs(along);
      };
      // Nearest pixel by truncation of x + 0.5 + kBias (truncation rounds down only values
      // >= 0, which the bias makes of every position less than kBias px outside the image;
      // positions further out truncate to pixels outside it too). Pixels outside the image
      // contribute nothing.
      constexpr int kBias = 1024;
      const float bx = x0 + 0.5f + kBias, by = y0 + 0.5f + kBias;
      float tf = 0.f;
      for (int t = 0; t < samples; ++t, tf += 1.f) {
        const int x = static_cast<int>(bx + tf * sx) - kBias;
        const int y = static_cast<int>(by + tf * sy) - kBias;
        if (static_cast<unsigned>(x) < cols && static_cast<unsigned>(y) < height) add(x, y);
      }
      const float half_weight = 0.5f * global[r];
      row_sums[r] = {half_weight * (across_abs + across_sum),
                     half_weight * (across_abs - across_sum), half_weight * (along_abs + along_sum),
                     half_weight * (along_abs - along_sum)};
    }

    // Band descriptors: mean and standard deviation of the locally weighted rows of the band
    // and its neighbours.
    std::array<float, kLbdBands * 8> v{};
    for (int j = 0; j < kLbdBands; ++j) {
      const int r0 = std::max(0, (j - 1) * w), r1 = std::min(rows, (j + 2) * w);
      double sum[4] = {0, 0, 0, 0}, sq[4] = {0, 0, 0, 0};
      for (int r = r0; r < r1; ++r) {
        const double lw = local[static_cast<size_t>(j) * rows + r];
        for (int c = 0; c < 4; ++c) {
          const double x = lw * row_sums[r][c];
          sum[c] += x;
          sq[c] += x * x;
        }
      }
      const double n = r1 - r0;
      for (int c = 0; c < 4; ++c) {
        const double mean = sum[c] / n;
        v[j * 8 + c] = static_cast<float>(mean);
        v[j * 8 + 4 + c] = static_cast<float>(std::sqrt(std::max(0.0, sq[c] / n - mean * mean)));
      }
    }
    // Means and deviations have different magnitudes: normalise each part, clip large
    // components (non-linear illumination) and normalise the whole.
    normalise(v.data(), 0, kLbdBands * 4);
    normalise(v.data(), 4, kLbdBands * 4);
    double sq = 0;
    for (float& x : v) {
      x = std::min(x, 0.4f);
      sq += static_cast<double>(x) * x;
    }
    if (sq > 0) {
      const float inv = static_cast<float>(1.0 / std::sqrt(sq));
      for (float& x : v) x *= inv;
    }

    uint8_t* out = descriptors.ptr<uint8_t>(static_cast<int>(s));
    for (int b = 0; b < kLbdBytes; ++b) {
      const float* first = &v[pairs[b].first * 8];
      const float* second = &v[pairs[b].second * 8];
      uint8_t byte = 0;
      for (int k = 0; k < 8; ++k) byte |= static_cast<uint8_t>((first[k] > second[k]) << k);
      out[b] = byte;
    }
  }
  return descriptors;
}

}  // namespace pplvo::features

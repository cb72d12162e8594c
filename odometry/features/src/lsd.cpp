#include "pplvo/features/lsd.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace pplvo::features {

namespace {

enum PixelState : uint8_t { kUndefined = 0, kFree = 1, kUsed = 2 };

/// Level-line field of the image: the 2x2 gradient at (x, y) (centred at (x + 0.5, y + 0.5))
/// as its norm and the unit vector of the level line, (cos, sin) of atan2(gx, -gy). The last
/// row and column have no 2x2 neighbourhood and stay undefined, as do pixels whose norm is not
/// above `threshold`.
struct LevelLines {
  int width = 0, height = 0;
  std::vector<float> norm, dir_x, dir_y;
  std::vector<uint8_t> state;
  float max_norm = 0.f;
};

void computeLevelLines(const cv::Mat& gray, double threshold, LevelLines* f) {
  const int w = gray.cols, h = gray.rows;
  const size_t n = static_cast<size_t>(w) * h;
  f->width = w;
  f->height = h;
  f->norm.assign(n, 0.f);
  f->dir_x.assign(n, 0.f);
  f->dir_y.assign(n, 0.f);
  f->state.assign(n, kUndefined);
  f->max_norm = 0.f;
  // norm > threshold  <=>  gx^2 + gy^2 > 4 threshold^2 (norm = sqrt(gx^2 + gy^2) / 2).
  const double min_squared = 4.0 * threshold * threshold;
  for (int y = 0; y + 1 < h; ++y) {
    const uint8_t* row = gray.ptr<uint8_t>(y);
    const uint8_t* next = gray.ptr<uint8_t>(y + 1);
    const size_t base = static_cast<size_t>(y) * w;
    for (int x = 0; x + 1 < w; ++x) {
      const int diagonal = next[x + 1] - row[x];     // D - A
      const int antidiagonal = row[x + 1] - next[x];  // B - C
      const int gx = diagonal + antidiagonal, gy = diagonal - antidiagonal;
      const int squared = gx * gx + gy * gy;
      const float magnitude = std::sqrt(static_cast<float>(squared));
      f->norm[base + x] = 0.5f * magnitude;
      if (squared <= min_squared) continue;
      f->dir_x[base + x] = -static_cast<float>(gy) / magnitude;
      f->dir_y[base + x] = static_cast<float>(gx) / magnitude;
      f->state[base + x] = kFree;
      f->max_norm = std::max(f->max_norm, 0.5f * magnitude);
    }
  }
}

/// Defined pixels in decreasing order of gradient norm, quantised into `bins` bins (LSD's
/// pseudo-ordering: linear time; raster order within a bin).
std::vector<int> seedOrder(const LevelLines& f, int bins) {
  const size_t n = f.state.size();
  const float coef = f.max_norm > 0.f ? static_cast<float>(bins - 1) / f.max_norm : 0.f;
  std::vector<int> bin_of(n, 0);
  std::vector<int> start(static_cast<size_t>(bins) + 1, 0);
  for (size_t i = 0; i < n; ++i) {
    if (f.state[i] != kFree) continue;
    const int b = std::clamp(static_cast<int>(f.norm[i] * coef), 0, bins - 1);
    bin_of[i] = bins - 1 - b;  // strongest first
    ++start[bin_of[i] + 1];
  }
  for (int b = 0; b < bins; ++b) start[b + 1] += start[b];
  std::vector<int> order(static_cast<size_t>(start[bins]));
  for (size_t i = 0; i < n; ++i) {
    if (f.state[i] == kFree) order[start[bin_of[i]]++] = static_cast<int>(i);
  }
  return order;
}

/// Grows the region of `seed` over free 8-neighbours aligned with the region's running mean
/// direction (within the angle whose cosine is `min_cos`), marking them used. Returns the
/// region's unit mean direction.
void growRegion(LevelLines& f, int seed, float min_cos, std::vector<int>* region, float* mean_x,
                float* mean_y) {
  const int w = f.width, h = f.height;
  region->clear();
  region->push_back(seed);
  f.state[seed] = kUsed;
  float sum_x = f.dir_x[seed], sum_y = f.dir_y[seed];
  float ux = sum_x, uy = sum_y;
  for (size_t k = 0; k < region->size(); ++k) {
    const int p = (*region)[k];
    const int px = p % w, py = p / w;
    const int x0 = std::max(px - 1, 0), x1 = std::min(px + 1, w - 1);
    const int y0 = std::max(py - 1, 0), y1 = std::min(py + 1, h - 1);
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const int q = y * w + x;
        if (f.state[q] != kFree || f.dir_x[q] * ux + f.dir_y[q] * uy < min_cos) continue;
        f.state[q] = kUsed;
        region->push_back(q);
        sum_x += f.dir_x[q];
        sum_y += f.dir_y[q];
        const float inv = 1.f / std::sqrt(sum_x * sum_x + sum_y * sum_y);
        ux = sum_x * inv;
        uy = sum_y * inv;
      }
    }
  }
  *mean_x = ux;
  *mean_y = uy;
}

/// The segment of a region: through the gradient-weighted centroid along the principal axis of
/// the weighted inertia, oriented like the region's level lines (gradient on the same side as
/// LSD's), from the region's smallest to its largest coordinate along that axis.
cv::Vec4f regionSegment(const LevelLines& f, const std::vector<int>& region, float mean_x,
                        float mean_y, float min_cos) {
  const int w = f.width;
  double cx = 0, cy = 0, weight = 0;
  for (int p : region) {
    const double m = f.norm[p];
    cx += (p % w) * m;
    cy += (p / w) * m;
    weight += m;
  }
  cx /= weight;
  cy /= weight;
  double ixx = 0, iyy = 0, ixy = 0;
  for (int p : region) {
    const double m = f.norm[p], dx = p % w - cx, dy = p / w - cy;
    ixx += dy * dy * m;
    iyy += dx * dx * m;
    ixy -= dx * dy * m;
  }
  // Eigenvector of the smallest eigenvalue of [[ixx, ixy], [ixy, iyy]]: the axis direction.
  const double lambda = 0.5 * (ixx + iyy - std::sqrt((ixx - iyy) * (ixx - iyy) + 4 * ixy * ixy));
  const double theta = std::fabs(ixx) > std::fabs(iyy) ? std::atan2(lambda - ixx, ixy)
                                                      : std::atan2(ixy, lambda - iyy);
  double ax = std::cos(theta), ay = std::sin(theta);
  if (ax * mean_x + ay * mean_y < min_cos) {
    ax = -ax;
    ay = -ay;
  }
  double lo = 0, hi = 0;
  for (int p : region) {
    const double t = (p % w - cx) * ax + (p / w - cy) * ay;
    lo = std::min(lo, t);
    hi = std::max(hi, t);
  }
  // + 0.5: the gradient of (x, y) sits between pixels x, x + 1 and y, y + 1.
  return {static_cast<float>(cx + lo * ax + 0.5), static_cast<float>(cy + lo * ay + 0.5),
          static_cast<float>(cx + hi * ax + 0.5), static_cast<float>(cy + hi * ay + 0.5)};
}

}  // namespace

std::vector<cv::Vec4f> detectLineSegments(const cv::Mat& gray, const LsdOptions& options) {
  CV_Assert(gray.empty() || gray.type() == CV_8UC1);
  CV_Assert(options.gradient_quantization >= 0.0 && options.angle_tolerance_deg > 0.0 &&
            options.angle_tolerance_deg < 180.0 && options.gradient_bins > 0);
  std::vector<cv::Vec4f> segments;
  if (gray.cols < 2 || gray.rows < 2) return segments;

  const double tau = options.angle_tolerance_deg * CV_PI / 180.0;
  const float min_cos = static_cast<float>(std::cos(tau));
  LevelLines field;
  computeLevelLines(gray, options.gradient_quantization / std::sin(tau), &field);

  // Fewer pixels than this cannot be a meaningful segment at any width (LSD's bound, with
  // N_tests = (W H)^(5/2) 11 and p = tau / pi).
  const double log_tests =
      2.5 * (std::log10(static_cast<double>(gray.cols)) + std::log10(static_cast<double>(gray.rows))) +
      std::log10(11.0);
  const size_t min_region =
      static_cast<size_t>(-log_tests / std::log10(options.angle_tolerance_deg / 180.0));

  std::vector<int> region;
  region.reserve(1024);
  for (const int seed : seedOrder(field, options.gradient_bins)) {
    if (field.state[seed] != kFree) continue;
    float mean_x = 0, mean_y = 0;
    growRegion(field, seed, min_cos, &region, &mean_x, &mean_y);
    if (region.size() < min_region) continue;  // its pixels stay used, as in LSD
    segments.push_back(regionSegment(field, region, mean_x, mean_y, min_cos));
  }
  return segments;
}

}  // namespace pplvo::features

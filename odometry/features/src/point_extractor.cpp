#include "pplvo/features/point_extractor.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/imgproc.hpp>

#include "pplvo/core/enum_names.h"

namespace pplvo::features {

namespace {
constexpr EnumName<PointDetector> kPointDetectorNames[] = {{PointDetector::kOrb, "orb"},
                                                           {PointDetector::kAkaze, "akaze"},
                                                           {PointDetector::kSift, "sift"},
                                                           {PointDetector::kBrisk, "brisk"}};
}  // namespace

bool parsePointDetector(const std::string& name, PointDetector* out) {
  return parseEnum(kPointDetectorNames, name, out, EnumCase::kIgnore);
}

const char* pointDetectorName(PointDetector d) { return enumName(kPointDetectorNames, d); }

namespace {

int candidateCount(const PointExtractorOptions& o) {
  const double f = o.grid_bucketing ? std::max(1.0, o.oversample) : 1.0;
  return std::max(1, static_cast<int>(std::lround(f * std::max(1, o.max_points))));
}

cv::Mat toGray(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat gray;
  if (image.channels() == 3)
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  else if (image.channels() == 4)
    cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
  return gray;
}

}  // namespace

PointExtractor::PointExtractor(const PointExtractorOptions& options) : options_(options) {
  const int n = candidateCount(options_);
  switch (options_.detector) {
    case PointDetector::kOrb:
      detector_ = cv::ORB::create(n, static_cast<float>(options_.orb_scale_factor),
                                  options_.orb_levels, options_.orb_edge_threshold_px, 0, 2,
                                  cv::ORB::HARRIS_SCORE, 31, options_.orb_fast_threshold);
      break;
    case PointDetector::kAkaze:
      detector_ = cv::AKAZE::create(cv::AKAZE::DESCRIPTOR_MLDB, 0, 3,
                                    static_cast<float>(options_.akaze_threshold));
      break;
    case PointDetector::kSift:
      detector_ = cv::SIFT::create(n, 3, options_.sift_contrast_threshold);
      break;
    case PointDetector::kBrisk:
      detector_ = cv::BRISK::create(options_.brisk_threshold);
      break;
  }
}

int PointExtractor::descriptorNorm() const {
  return options_.detector == PointDetector::kSift ? cv::NORM_L2 : cv::NORM_HAMMING;
}

namespace {

/// Occupancy of kept points on a grid of cells of side r: is any kept point within r of p?
class SeparationIndex {
 public:
  SeparationIndex(int width, int height, double r)
      : r_(r),
        cols_(r > 0 ? static_cast<int>(width / r) + 1 : 0),
        rows_(r > 0 ? static_cast<int>(height / r) + 1 : 0),
        cells_(static_cast<size_t>(cols_) * rows_) {}
  bool free(const cv::Point2f& p) const {
    if (r_ <= 0) return true;
    const int cx = cellX(p.x), cy = cellY(p.y);
    for (int y = std::max(0, cy - 1); y <= std::min(rows_ - 1, cy + 1); ++y) {
      for (int x = std::max(0, cx - 1); x <= std::min(cols_ - 1, cx + 1); ++x) {
        for (const auto& q : cells_[y * cols_ + x]) {
          const float dx = q.x - p.x, dy = q.y - p.y;
          if (dx * dx + dy * dy < r_ * r_) return false;
        }
      }
    }
    return true;
  }
  void add(const cv::Point2f& p) {
    if (r_ > 0) cells_[cellY(p.y) * cols_ + cellX(p.x)].push_back(p);
  }

 private:
  int cellX(float x) const { return std::clamp(static_cast<int>(x / r_), 0, cols_ - 1); }
  int cellY(float y) const { return std::clamp(static_cast<int>(y / r_), 0, rows_ - 1); }
  double r_;
  int cols_, rows_;
  std::vector<std::vector<cv::Point2f>> cells_;
};

}  // namespace

std::vector<int> selectSpread(const std::vector<cv::KeyPoint>& keypoints, int width, int height,
                              int max_keep, int grid_cols, int grid_rows,
                              double min_separation_px) {
  std::vector<int> order(keypoints.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return keypoints[a].response > keypoints[b].response; });
  if (max_keep <= 0) return {};
  SeparationIndex sep(std::max(1, width), std::max(1, height), min_separation_px);
  if (min_separation_px > 0) {
    std::vector<int> separated;
    separated.reserve(order.size());
    for (int idx : order) {
      if (!sep.free(keypoints[idx].pt)) continue;
      sep.add(keypoints[idx].pt);
      separated.push_back(idx);
    }
    order.swap(separated);
  }
  if (static_cast<int>(order.size()) <= max_keep) return order;
  grid_cols = std::max(1, grid_cols);
  grid_rows = std::max(1, grid_rows);
  const int cells = grid_cols * grid_rows;
  const int quota = (max_keep + cells - 1) / cells;
  std::vector<int> per_cell(cells, 0);
  std::vector<char> taken(keypoints.size(), 0);
  std::vector<int> out;
  out.reserve(max_keep);
  for (int idx : order) {
    const auto& kp = keypoints[idx];
    const int cx =
        std::clamp(static_cast<int>(kp.pt.x * grid_cols / std::max(1, width)), 0, grid_cols - 1);
    const int cy =
        std::clamp(static_cast<int>(kp.pt.y * grid_rows / std::max(1, height)), 0, grid_rows - 1);
    int& count = per_cell[cy * grid_cols + cx];
    if (count < quota) {
      ++count;
      taken[idx] = 1;
      out.push_back(idx);
      if (static_cast<int>(out.size()) == max_keep) return out;
    }
  }
  for (int idx : order) {
    if (taken[idx]) continue;
    out.push_back(idx);
    if (static_cast<int>(out.size()) == max_keep) break;
  }
  return out;
}

namespace {

/// Smallest-eigenvalue corner responses of the structure tensor over (2w+1)^2 windows (central
/// differences), for every centre of the (2r+1)^2 grid around (u0, v0); -1 where a window is too
/// close to the border. Each gradient is half an integer difference, so the tensor sums are
/// exact integers / 4: summed-area tables of the integer products give exactly the values of
/// summing the windows pixel by pixel in double, at a fraction of the cost.
void cornerResponses(const cv::Mat& gray, int u0, int v0, int r, int w, std::vector<double>* resp) {
  const int n = 2 * r + 1;
  const int p = n + 2 * w;  // patch side: every window pixel of every centre
  const int px0 = u0 - r - w, py0 = v0 - r - w;
  // Summed-area tables (row and column 0 are zero) of dx^2, dx dy, dy^2.
  const int s = p + 1;
  std::vector<int64_t> sat(static_cast<size_t>(3 * s * s), 0);
  int64_t* sxx = sat.data();
  int64_t* sxy = sxx + s * s;
  int64_t* syy = sxy + s * s;
  for (int y = 0; y < p; ++y) {
    const int iy = py0 + y;
    const bool row_ok = iy >= 1 && iy + 1 < gray.rows;
    int64_t rxx = 0, rxy = 0, ryy = 0;
    for (int x = 0; x < p; ++x) {
      const int ix = px0 + x;
      if (row_ok && ix >= 1 && ix + 1 < gray.cols) {
        // Pixels without both neighbours only serve windows rejected below.
        const int dx = gray.ptr<uint8_t>(iy)[ix + 1] - gray.ptr<uint8_t>(iy)[ix - 1];
        const int dy = gray.ptr<uint8_t>(iy + 1)[ix] - gray.ptr<uint8_t>(iy - 1)[ix];
        rxx += dx * dx;
        rxy += dx * dy;
        ryy += dy * dy;
      }
      const int k = (y + 1) * s + x + 1, up = y * s + x + 1;
      sxx[k] = sxx[up] + rxx;
      sxy[k] = sxy[up] + rxy;
      syy[k] = syy[up] + ryy;
    }
  }
  auto box = [&](const int64_t* t, int x0, int y0) {  // window with top-left patch pixel (x0, y0)
    const int x1 = x0 + 2 * w + 1, y1 = y0 + 2 * w + 1;
    return t[y1 * s + x1] - t[y0 * s + x1] - t[y1 * s + x0] + t[y0 * s + x0];
  };
  resp->assign(static_cast<size_t>(n) * n, -1.0);
  for (int dv = -r; dv <= r; ++dv) {
    for (int du = -r; du <= r; ++du) {
      const int u = u0 + du, v = v0 + dv;
      if (u - w - 1 < 0 || v - w - 1 < 0 || u + w + 1 >= gray.cols || v + w + 1 >= gray.rows)
        continue;
      const int x0 = du + r, y0 = dv + r;  // window's top-left in patch coordinates
      const double a = 0.25 * static_cast<double>(box(sxx, x0, y0));
      const double b = 0.25 * static_cast<double>(box(sxy, x0, y0));
      const double c = 0.25 * static_cast<double>(box(syy, x0, y0));
      (*resp)[static_cast<size_t>(dv + r) * n + du + r] =
          0.5 * (a + c - std::sqrt((a - c) * (a - c) + 4 * b * b));
    }
  }
}

/// Peak of the corner response near `pt`, at sub-pixel precision: the best of the pixels
/// within `radius` of the detection, then a separable quadratic fit through its neighbours.
/// Returns `pt` unchanged when the fit is degenerate (no strict maximum, image border).
cv::Point2f refineCorner(const cv::Mat& gray, const cv::Point2f& pt, int radius, int w) {
  const int u0 = static_cast<int>(std::lround(pt.x)), v0 = static_cast<int>(std::lround(pt.y));
  const int r = radius + 1;  // responses one pixel beyond the search area for the fit
  const int n = 2 * r + 1;
  std::vector<double> resp;
  cornerResponses(gray, u0, v0, r, w, &resp);
  auto at = [&](int du, int dv) { return resp[(dv + r) * n + du + r]; };
  int bu = 0, bv = 0;
  double best = -1;
  for (int dv = -radius; dv <= radius; ++dv) {
    for (int du = -radius; du <= radius; ++du) {
      if (at(du, dv) > best) {
        best = at(du, dv);
        bu = du;
        bv = dv;
      }
    }
  }
  if (best <= 0) return pt;
  const double l = at(bu - 1, bv), rr = at(bu + 1, bv), t = at(bu, bv - 1), d = at(bu, bv + 1);
  if (l < 0 || rr < 0 || t < 0 || d < 0) return pt;
  const double cx = l - 2 * best + rr, cy = t - 2 * best + d;
  if (!(cx < 0 && cy < 0)) return pt;  // not a strict maximum
  const double ox = std::clamp(0.5 * (l - rr) / cx, -0.5, 0.5);
  const double oy = std::clamp(0.5 * (t - d) / cy, -0.5, 0.5);
  return {static_cast<float>(u0 + bu + ox), static_cast<float>(v0 + bv + oy)};
}

}  // namespace

PointExtraction PointExtractor::extract(const cv::Mat& image, const PinholeCamera& camera) const {
  PointExtraction result;
  if (image.empty() || image.depth() != CV_8U || image.cols < options_.min_image_side_px ||
      image.rows < options_.min_image_side_px || options_.max_points <= 0) {
    if (!image.empty() && image.depth() != CV_8U) result.stats.error = "image is not 8-bit";
    return result;
  }
  const cv::Mat gray = toGray(image);
  if (gray.empty()) {
    result.stats.error = "unsupported number of channels";
    return result;
  }
  try {
    std::vector<cv::KeyPoint> candidates;
    detector_->detect(gray, candidates);
    result.stats.candidates = static_cast<int>(candidates.size());
    std::vector<cv::KeyPoint> selected;
    if (options_.grid_bucketing) {
      const auto idx =
          selectSpread(candidates, gray.cols, gray.rows, options_.max_points, options_.grid_cols,
                       options_.grid_rows, options_.min_separation_px);
      selected.reserve(idx.size());
      for (int i : idx) selected.push_back(candidates[i]);
    } else {
      selected = std::move(candidates);
      cv::KeyPointsFilter::retainBest(selected, options_.max_points);
      if (static_cast<int>(selected.size()) > options_.max_points)
        selected.resize(options_.max_points);
    }
    if (selected.empty()) return result;
    // compute() may drop keypoints too close to the border; it updates `selected`.
    detector_->compute(gray, selected, result.descriptors);
    if (result.descriptors.rows != static_cast<int>(selected.size())) {
      result.stats.error = "descriptor count disagrees with keypoints";
      result.descriptors.release();
      return result;
    }
    const bool undistort = camera.valid() && camera.hasDistortion();
    result.points.reserve(selected.size());
    for (auto& kp : selected) {
      // FAST corners only: SIFT, AKAZE and BRISK interpolate their own extrema.
      if (options_.subpixel_refinement && options_.detector == PointDetector::kOrb) {
        // Search as far as the detection's own rounding reaches: half a pixel of its level.
        const double level_px = std::pow(options_.orb_scale_factor, std::max(0, kp.octave));
        const int radius = std::max(1, static_cast<int>(std::ceil(0.5 * level_px - 1e-9)));
        const int window =
            options_.subpixel_window_scales_with_octave
                ? std::max(1, static_cast<int>(std::lround(options_.subpixel_window_px * level_px)))
                : options_.subpixel_window_px;
        kp.pt = refineCorner(gray, kp.pt, radius, window);
      }
      PointFeature f;
      const Eigen::Vector2d raw(kp.pt.x, kp.pt.y);
      f.px = undistort ? camera.undistortPixel(raw) : raw;
      f.response = kp.response;
      f.size_px = kp.size;
      f.angle_deg = kp.angle;
      f.octave = kp.octave;
      result.points.push_back(f);
    }
    result.keypoints = std::move(selected);
    result.stats.kept = static_cast<int>(result.points.size());
  } catch (const cv::Exception& e) {
    result = PointExtraction{};
    result.stats.error = e.what();
  }
  return result;
}

PointExtractionStats PointExtractor::extractInto(const cv::Mat& image, const PinholeCamera& camera,
                                                 FrameFeatures& frame) const {
  PointExtraction r = extract(image, camera);
  frame.points = std::move(r.points);
  frame.point_descriptors = r.descriptors;
  return r.stats;
}

}  // namespace pplvo::features

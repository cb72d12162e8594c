#include "pplvo/viewer/render.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>

#include "pplvo/viewer/ticks.h"

namespace pplvo {
namespace viewer {
namespace {

const cv::Scalar kPanelBg(32, 32, 32);
const cv::Scalar kTextColour(235, 235, 235);
const cv::Scalar kDimText(160, 160, 160);
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr int kTitleHeight = 24;

cv::Mat blankPanel(cv::Size size) { return cv::Mat(size, CV_8UC3, kPanelBg); }

void putLabel(cv::Mat& img, const std::string& text, cv::Point org, double scale = 0.45,
              cv::Scalar colour = kTextColour, int thickness = 1) {
  cv::putText(img, text, org, kFont, scale, colour, thickness, cv::LINE_AA);
}

void drawTitle(cv::Mat& panel, const std::string& title) {
  cv::rectangle(panel, cv::Rect(0, 0, panel.cols, kTitleHeight), cv::Scalar(55, 55, 55),
                cv::FILLED);
  putLabel(panel, title, cv::Point(6, 17), 0.5);
}

/// Largest rectangle of aspect `src` fitting in `area`, centred.
cv::Rect fitRect(cv::Size src, cv::Rect area) {
  if (src.width <= 0 || src.height <= 0 || area.width <= 0 || area.height <= 0) return {};
  const double s = std::min(static_cast<double>(area.width) / src.width,
                            static_cast<double>(area.height) / src.height);
  const int w = std::max(1, static_cast<int>(std::floor(src.width * s)));
  const int h = std::max(1, static_cast<int>(std::floor(src.height * s)));
  return cv::Rect(area.x + (area.width - w) / 2, area.y + (area.height - h) / 2, w, h);
}

void noData(cv::Mat& panel, const std::string& what = "no data") {
  int base = 0;
  const cv::Size ts = cv::getTextSize(what, kFont, 0.6, 1, &base);
  putLabel(panel, what, cv::Point((panel.cols - ts.width) / 2, panel.rows / 2), 0.6, kDimText);
}

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

cv::Mat toBgr(const cv::Mat& img) {
  if (img.empty()) return img;
  cv::Mat out;
  if (img.type() == CV_8UC3) return img;
  if (img.type() == CV_8UC1) {
    cv::cvtColor(img, out, cv::COLOR_GRAY2BGR);
    return out;
  }
  if (img.type() == CV_8UC4) {
    cv::cvtColor(img, out, cv::COLOR_BGRA2BGR);
    return out;
  }
  return {};
}

}  // namespace

ValueRange chooseRange(const cv::Mat& value_m, const ScalarPanelOptions& options) {
  ValueRange r;
  std::vector<float> valid;
  if (!value_m.empty() && value_m.type() == CV_32FC1) {
    valid.reserve(static_cast<size_t>(value_m.total()));
    for (int y = 0; y < value_m.rows; ++y) {
      const float* row = value_m.ptr<float>(y);
      for (int x = 0; x < value_m.cols; ++x) {
        if (std::isfinite(row[x]) && row[x] > 0.f) valid.push_back(row[x]);
      }
    }
  }
  r.n_valid = static_cast<int>(valid.size());
  if (options.min_value_m < options.max_value_m) {
    r.min_m = options.min_value_m;
    r.max_m = options.max_value_m;
    return r;
  }
  if (valid.empty()) return r;
  auto at = [&](double q) {
    const size_t k =
        std::min(valid.size() - 1, static_cast<size_t>(std::max(0.0, q) * (valid.size() - 1)));
    std::nth_element(valid.begin(), valid.begin() + static_cast<long>(k), valid.end());
    return static_cast<double>(valid[k]);
  };
  r.min_m = at(options.percentile_low);
  r.max_m = at(options.percentile_high);
  if (!(r.max_m > r.min_m)) r.max_m = r.min_m + std::max(1e-3, 0.1 * std::abs(r.min_m));
  return r;
}

cv::Mat colorizeScalar(const cv::Mat& value_m, const ValueRange& range,
                       const ScalarPanelOptions& options) {
  CV_Assert(value_m.type() == CV_32FC1);
  cv::Mat grey(value_m.size(), CV_8UC1);
  cv::Mat missing(value_m.size(), CV_8UC1, cv::Scalar(0));
  const double span = range.max_m - range.min_m;
  for (int y = 0; y < value_m.rows; ++y) {
    const float* v = value_m.ptr<float>(y);
    uint8_t* g = grey.ptr<uint8_t>(y);
    uint8_t* m = missing.ptr<uint8_t>(y);
    for (int x = 0; x < value_m.cols; ++x) {
      if (!std::isfinite(v[x]) || v[x] <= 0.f) {
        g[x] = 0;
        m[x] = 255;
        continue;
      }
      const double t = std::clamp((v[x] - range.min_m) / span, 0.0, 1.0);
      g[x] = static_cast<uint8_t>(std::lround(t * 255.0));
    }
  }
  cv::Mat colour;
  cv::applyColorMap(grey, colour, options.colormap);
  colour.setTo(options.missing_bgr, missing);
  return colour;
}

FusionOnlyDepth fusionOnlyPixels(const cv::Mat& fused_depth_m, const cv::Mat& cgm_depth_m) {
  FusionOnlyDepth r;
  if (fused_depth_m.type() != CV_32FC1 || cgm_depth_m.type() != CV_32FC1 ||
      fused_depth_m.empty() || cgm_depth_m.empty()) {
    r.error = "fused and C-GM depth must be non-empty CV_32FC1 maps";
    return r;
  }
  if (fused_depth_m.size() != cgm_depth_m.size()) {
    r.error = "fused depth " + std::to_string(fused_depth_m.cols) + "x" +
              std::to_string(fused_depth_m.rows) + " and C-GM depth " +
              std::to_string(cgm_depth_m.cols) + "x" + std::to_string(cgm_depth_m.rows) +
              " sizes differ";
    return r;
  }
  auto valid = [](float v) { return std::isfinite(v) && v > 0.f; };
  r.mask = cv::Mat(fused_depth_m.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < fused_depth_m.rows; ++y) {
    const float* f = fused_depth_m.ptr<float>(y);
    const float* c = cgm_depth_m.ptr<float>(y);
    uint8_t* m = r.mask.ptr<uint8_t>(y);
    for (int x = 0; x < fused_depth_m.cols; ++x) {
      const bool fv = valid(f[x]), cv_ = valid(c[x]);
      r.n_fused_valid += fv ? 1 : 0;
      r.n_cgm_valid += cv_ ? 1 : 0;
      if (fv && !cv_) {
        m[x] = 255;
        ++r.n_fusion_only;
      }
    }
  }
  return r;
}

void tintPixels(cv::Mat& bgr, const cv::Mat& mask, const cv::Scalar& tint_bgr, double alpha) {
  if (bgr.type() != CV_8UC3 || mask.type() != CV_8UC1 || mask.size() != bgr.size()) return;
  const double a = std::clamp(alpha, 0.0, 1.0);
  for (int y = 0; y < bgr.rows; ++y) {
    cv::Vec3b* p = bgr.ptr<cv::Vec3b>(y);
    const uint8_t* m = mask.ptr<uint8_t>(y);
    for (int x = 0; x < bgr.cols; ++x) {
      if (!m[x]) continue;
      for (int k = 0; k < 3; ++k) {
        p[x][k] = cv::saturate_cast<uint8_t>((1.0 - a) * p[x][k] + a * tint_bgr[k]);
      }
    }
  }
}

cv::Mat sqrtVariance(const cv::Mat& var_m2) {
  if (var_m2.empty()) return {};
  CV_Assert(var_m2.type() == CV_32FC1);
  cv::Mat out(var_m2.size(), CV_32FC1);
  for (int y = 0; y < var_m2.rows; ++y) {
    const float* v = var_m2.ptr<float>(y);
    float* o = out.ptr<float>(y);
    for (int x = 0; x < var_m2.cols; ++x) {
      o[x] = (std::isfinite(v[x]) && v[x] > 0.f) ? std::sqrt(v[x]) : 0.f;
    }
  }
  return out;
}

cv::Mat renderScalarPanel(const cv::Mat& value_m, const std::string& title, cv::Size size,
                          const ScalarPanelOptions& options, const std::string& unit,
                          const cv::Mat& highlight, const std::string& highlight_legend) {
  cv::Mat panel = blankPanel(size);
  drawTitle(panel, title);
  if (value_m.empty() || value_m.type() != CV_32FC1) {
    noData(panel);
    return panel;
  }
  const ValueRange range = chooseRange(value_m, options);
  if (range.n_valid == 0) {
    noData(panel, "no valid pixels");
    return panel;
  }
  const int bar_w = 16, label_w = 62, margin = 6;
  const cv::Rect image_area(margin, kTitleHeight + margin,
                            size.width - bar_w - label_w - 3 * margin,
                            size.height - kTitleHeight - 2 * margin);
  const cv::Rect dst = fitRect(value_m.size(), image_area);
  if (dst.area() > 0) {
    cv::Mat colour = colorizeScalar(value_m, range, options);
    if (!highlight.empty()) {
      tintPixels(colour, highlight, options.highlight_bgr, options.highlight_alpha);
    }
    cv::Mat scaled;
    cv::resize(colour, scaled, dst.size(), 0, 0, cv::INTER_NEAREST);
    scaled.copyTo(panel(dst));
  }
  // Colour bar: top = max, bottom = min, same height as the image.
  const int bar_x = image_area.x + image_area.width + margin;
  const int bar_top = dst.area() > 0 ? dst.y : image_area.y;
  const int bar_h = dst.area() > 0 ? dst.height : image_area.height;
  if (bar_h > 2) {
    cv::Mat ramp(bar_h, 1, CV_8UC1);
    for (int i = 0; i < bar_h; ++i) {
      ramp.at<uint8_t>(i) =
          static_cast<uint8_t>(std::lround(255.0 * (bar_h - 1 - i) / (bar_h - 1)));
    }
    cv::Mat ramp_colour;
    cv::applyColorMap(ramp, ramp_colour, options.colormap);
    cv::Mat bar;
    cv::resize(ramp_colour, bar, cv::Size(bar_w, bar_h), 0, 0, cv::INTER_NEAREST);
    bar.copyTo(panel(cv::Rect(bar_x, bar_top, bar_w, bar_h)));
    cv::rectangle(panel, cv::Rect(bar_x, bar_top, bar_w, bar_h), kTextColour, 1);
    const std::vector<double> ticks = niceTicks(range.min_m, range.max_m, 6);
    const double span = range.max_m - range.min_m;
    const int decimals = tickDecimals(ticks);
    for (double t : ticks) {
      const int y = bar_top + static_cast<int>(std::lround((range.max_m - t) / span * (bar_h - 1)));
      cv::line(panel, cv::Point(bar_x + bar_w, y), cv::Point(bar_x + bar_w + 4, y), kTextColour);
      putLabel(panel, formatTick(t, decimals), cv::Point(bar_x + bar_w + 6, y + 4), 0.38);
    }
    putLabel(panel, "[" + unit + "]",
             cv::Point(bar_x - 2, bar_top + bar_h + 4 < size.height - 2 ? bar_top + bar_h + 14
                                                                        : size.height - 4),
             0.38, kDimText);
  }
  putLabel(panel, fmt("valid %.0f%%", 100.0 * range.n_valid / double(value_m.total())),
           cv::Point(size.width - 95, 17), 0.4, kDimText);
  if (!highlight.empty() && !highlight_legend.empty()) {
    const cv::Point org(margin, size.height - 5);
    cv::rectangle(panel, cv::Rect(org.x, org.y - 9, 10, 10), options.highlight_bgr, cv::FILLED);
    putLabel(panel, highlight_legend, cv::Point(org.x + 14, org.y), 0.38);
  }
  return panel;
}

cv::Rect featureImageRect(cv::Size image_size, cv::Size panel_size) {
  return fitRect(image_size, cv::Rect(0, kTitleHeight, panel_size.width,
                                      panel_size.height - kTitleHeight - 40));
}

cv::Vec3b planeColour(int label) {
  if (label <= 0) return cv::Vec3b(0, 0, 0);
  // Golden-ratio hue steps give neighbouring labels well separated colours.
  const double hue = std::fmod(label * 0.618033988749895, 1.0) * 180.0;
  cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(hue, 200, 255)), bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  return bgr.at<cv::Vec3b>(0, 0);
}

cv::Mat renderFeaturePanel(const cv::Mat& bgr_in, const FrameFeatures* features,
                           const FramePose* pose, const std::string& title, cv::Size size,
                           const FeatureOverlayOptions& options) {
  cv::Mat panel = blankPanel(size);
  drawTitle(panel, title);
  const cv::Mat bgr = toBgr(bgr_in);
  if (bgr.empty()) {
    noData(panel);
    return panel;
  }
  cv::Mat img = bgr.clone();
  if (features != nullptr) {
    // Planes: tint each labelled pixel with its plane's colour.
    const cv::Mat& labels = features->plane_labels;
    if (!labels.empty() && labels.type() == CV_8UC1 && labels.size() == img.size()) {
      const double a = std::clamp(options.plane_alpha, 0.0, 1.0);
      cv::Vec3b lut[256];
      for (int k = 0; k < 256; ++k) lut[k] = planeColour(k);
      for (int y = 0; y < img.rows; ++y) {
        const uint8_t* l = labels.ptr<uint8_t>(y);
        cv::Vec3b* p = img.ptr<cv::Vec3b>(y);
        for (int x = 0; x < img.cols; ++x) {
          if (l[x] == 0) continue;
          const cv::Vec3b& c = lut[l[x]];
          for (int k = 0; k < 3; ++k) {
            p[x][k] = static_cast<uint8_t>((1 - a) * p[x][k] + a * c[k] + 0.5);
          }
        }
      }
      // Plane ids at their pixel centroids.
      for (const PlaneFeature& pl : features->planes) {
        if (pl.label <= 0 || pl.label > 255) continue;
        const cv::Moments m = cv::moments(labels == pl.label, true);
        if (m.m00 <= 0) continue;
        const cv::Point c(static_cast<int>(m.m10 / m.m00), static_cast<int>(m.m01 / m.m00));
        const cv::Vec3b pc = planeColour(pl.label);
        putLabel(img, "P" + std::to_string(pl.label), c, 0.5, cv::Scalar(0, 0, 0), 3);
        putLabel(img, "P" + std::to_string(pl.label), c, 0.5, cv::Scalar(pc[0], pc[1], pc[2]), 1);
      }
    }
    for (const LineFeature& l : features->lines) {
      const cv::Point p1(static_cast<int>(std::lround(l.px1.x())),
                         static_cast<int>(std::lround(l.px1.y())));
      const cv::Point p2(static_cast<int>(std::lround(l.px2.x())),
                         static_cast<int>(std::lround(l.px2.y())));
      if (l.has_3d) {
        cv::line(img, p1, p2, cv::Scalar(255, 255, 0), options.line_thickness_px + 1, cv::LINE_AA);
      } else {
        cv::line(img, p1, p2, cv::Scalar(0, 140, 255), options.line_thickness_px, cv::LINE_AA);
      }
    }
    for (const PointFeature& p : features->points) {
      const cv::Point c(static_cast<int>(std::lround(p.px.x())),
                        static_cast<int>(std::lround(p.px.y())));
      if (p.has_3d) {
        cv::circle(img, c, options.point_radius_px, cv::Scalar(0, 255, 0), cv::FILLED, cv::LINE_AA);
        cv::circle(img, c, options.point_radius_px, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
      } else {
        cv::circle(img, c, options.point_radius_px, cv::Scalar(0, 0, 255), 2, cv::LINE_AA);
      }
    }
  }
  const cv::Rect dst = featureImageRect(img.size(), size);
  if (dst.area() > 0) {
    cv::Mat scaled;
    cv::resize(img, scaled, dst.size(), 0, 0, cv::INTER_AREA);
    scaled.copyTo(panel(dst));
  }
  // Legend and counts under the image.
  const int y0 = size.height - 26;
  if (features != nullptr) {
    int n3p = 0, n3l = 0;
    for (const auto& p : features->points) n3p += p.has_3d ? 1 : 0;
    for (const auto& l : features->lines) n3l += l.has_3d ? 1 : 0;
    char buf[160];
    std::snprintf(buf, sizeof buf, "pts %zu (3D %d)  lines %zu (3D %d)  planes %zu",
                  features->points.size(), n3p, features->lines.size(), n3l,
                  features->planes.size());
    putLabel(panel, buf, cv::Point(6, y0), 0.42);
  } else {
    putLabel(panel, "no features", cv::Point(6, y0), 0.42, kDimText);
  }
  if (pose != nullptr) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "matched (seq %lld): pts %d  lines %d  planes %d",
                  static_cast<long long>(pose->seq), pose->n_point_matches, pose->n_line_matches,
                  pose->n_plane_matches);
    putLabel(panel, buf, cv::Point(6, y0 + 18), 0.42, cv::Scalar(120, 255, 120));
  }
  return panel;
}

ViewAxes topDownAxes() {
  ViewAxes a;
  a.horizontal = 0;
  a.vertical = 2;
  a.horizontal_name = "x [m]";
  a.vertical_name = "z [m]";
  return a;
}

ViewAxes sideAxes() {
  ViewAxes a;
  a.horizontal = 2;
  a.vertical = 1;
  a.vertical_sign = -1.0;
  a.horizontal_name = "z [m]";
  a.vertical_name = "-y [m]";
  return a;
}

cv::Mat renderTrajectoryPanel(const Positions& est, const Positions& gt, const ViewAxes& axes,
                              const std::string& title, cv::Size size) {
  cv::Mat panel = blankPanel(size);
  drawTitle(panel, title);
  if (est.empty() && gt.empty()) {
    noData(panel, "no poses yet");
    return panel;
  }
  auto hv = [&](const Eigen::Vector3d& p) {
    return Eigen::Vector2d(axes.horizontal_sign * p[axes.horizontal],
                           axes.vertical_sign * p[axes.vertical]);
  };
  Eigen::Vector2d lo(1e300, 1e300), hi(-1e300, -1e300);
  for (const Positions* list : {&est, &gt}) {
    for (const auto& p : *list) {
      if (!p.allFinite()) continue;
      lo = lo.cwiseMin(hv(p));
      hi = hi.cwiseMax(hv(p));
    }
  }
  if (!(lo.x() <= hi.x())) {
    noData(panel, "no finite poses");
    return panel;
  }
  const cv::Rect plot(52, kTitleHeight + 10, size.width - 52 - 14,
                      size.height - kTitleHeight - 10 - 44);
  // Equal scale: grow the smaller extent around its centre; at least 0.2 m shown.
  Eigen::Vector2d centre = 0.5 * (lo + hi);
  double span_h = std::max(hi.x() - lo.x(), 0.2) * 1.1;
  double span_v = std::max(hi.y() - lo.y(), 0.2) * 1.1;
  const double aspect = static_cast<double>(plot.width) / plot.height;
  if (span_h / span_v < aspect) {
    span_h = span_v * aspect;
  } else {
    span_v = span_h / aspect;
  }
  const double h0 = centre.x() - span_h / 2, h1 = centre.x() + span_h / 2;
  const double v0 = centre.y() - span_v / 2, v1 = centre.y() + span_v / 2;
  auto toPx = [&](const Eigen::Vector2d& q) {
    return cv::Point2d(plot.x + (q.x() - h0) / (h1 - h0) * plot.width,
                       plot.y + plot.height - (q.y() - v0) / (v1 - v0) * plot.height);
  };
  const cv::Scalar grid(60, 60, 60);
  const std::vector<double> th = niceTicks(h0, h1, 6), tv = niceTicks(v0, v1, 6);
  const int dh = tickDecimals(th), dv = tickDecimals(tv);
  for (double t : th) {
    const int x = static_cast<int>(std::lround(toPx({t, v0}).x));
    cv::line(panel, cv::Point(x, plot.y), cv::Point(x, plot.y + plot.height), grid);
    putLabel(panel, formatTick(t, dh), cv::Point(x - 12, plot.y + plot.height + 15), 0.38,
             kDimText);
  }
  for (double t : tv) {
    const int y = static_cast<int>(std::lround(toPx({h0, t}).y));
    cv::line(panel, cv::Point(plot.x, y), cv::Point(plot.x + plot.width, y), grid);
    putLabel(panel, formatTick(t, dv), cv::Point(4, y + 4), 0.38, kDimText);
  }
  cv::rectangle(panel, plot, cv::Scalar(110, 110, 110), 1);
  putLabel(panel, axes.horizontal_name, cv::Point(plot.x + plot.width / 2 - 15, size.height - 12),
           0.42, kDimText);
  putLabel(panel, axes.vertical_name,
           cv::Point(4, plot.y - 2 > kTitleHeight + 8 ? plot.y - 2 : kTitleHeight + 10), 0.38,
           kDimText);
  auto drawPath = [&](const Positions& list, cv::Scalar colour, int thickness) {
    std::vector<cv::Point> pts;
    pts.reserve(list.size());
    for (const auto& p : list) {
      if (!p.allFinite()) continue;
      const cv::Point2d q = toPx(hv(p));
      pts.emplace_back(static_cast<int>(std::lround(q.x)), static_cast<int>(std::lround(q.y)));
    }
    if (pts.size() >= 2) {
      cv::polylines(panel, pts, false, colour, thickness, cv::LINE_AA);
    }
    return pts;
  };
  drawPath(gt, cv::Scalar(80, 200, 80), 2);
  const std::vector<cv::Point> e = drawPath(est, cv::Scalar(0, 220, 255), 2);
  if (!e.empty()) {
    cv::circle(panel, e.front(), 4, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
    cv::circle(panel, e.back(), 5, cv::Scalar(0, 0, 255), cv::FILLED, cv::LINE_AA);
  }
  // Legend.
  int lx = plot.x + 8;
  const int ly = plot.y + 14;
  cv::line(panel, cv::Point(lx, ly - 4), cv::Point(lx + 20, ly - 4), cv::Scalar(0, 220, 255), 2);
  putLabel(panel, "estimate", cv::Point(lx + 24, ly), 0.4);
  if (!gt.empty()) {
    lx += 100;
    cv::line(panel, cv::Point(lx, ly - 4), cv::Point(lx + 20, ly - 4), cv::Scalar(80, 200, 80), 2);
    putLabel(panel, "ground truth", cv::Point(lx + 24, ly), 0.4);
  }
  return panel;
}

cv::Mat renderStatusPanel(const StatusPanelData& d, cv::Size size) {
  cv::Mat panel = blankPanel(size);
  drawTitle(panel, "status");
  int y = kTitleHeight + 20;
  const int dy = 18;
  auto line = [&](const std::string& s, cv::Scalar c = kTextColour, int x = 8) {
    if (y < size.height - 4) putLabel(panel, s, cv::Point(x, y), 0.45, c);
    y += dy;
  };
  char buf[256];
  if (d.pose) {
    const FramePose& p = *d.pose;
    const bool good = p.status == TrackingStatus::kTracking ||
                      p.status == TrackingStatus::kFirstFrame ||
                      p.status == TrackingStatus::kReinitialised;
    std::snprintf(buf, sizeof buf, "pose seq %lld  stamp %s  status %s",
                  static_cast<long long>(p.seq), p.stamp.c_str(), toString(p.status));
    line(buf, good ? cv::Scalar(120, 255, 120) : cv::Scalar(80, 80, 255));
    const Eigen::Vector3d t = p.T_w_c.translation();
    std::snprintf(buf, sizeof buf, "t_w_c [m] %.3f %.3f %.3f   iterations %d  cost %.3g", t.x(),
                  t.y(), t.z(), p.iterations, p.final_cost);
    line(buf);
    std::snprintf(buf, sizeof buf, "matches: points %d  lines %d  planes %d   max var(t) %.2e m^2",
                  p.n_point_matches, p.n_line_matches, p.n_plane_matches,
                  p.max_translation_variance_m2);
    line(buf);
  } else {
    line("no pose yet", kDimText);
  }
  std::snprintf(buf, sizeof buf, "features: points %d (3D %d)  lines %d (3D %d)  planes %d",
                d.n_points, d.n_points_3d, d.n_lines, d.n_lines_3d, d.n_planes);
  line(buf);
  std::snprintf(buf, sizeof buf, "depth window length %d   pose window %zu", d.window_length,
                d.pose ? d.pose->window.size() : size_t{0});
  line(buf);
  if (d.fusion_only_px) {
    std::snprintf(buf, sizeof buf, "depth only through fusion: %d px (%.1f%% of fused; magenta, "
                  "key f)", *d.fusion_only_px, 100.0 * d.fusion_only_share);
    line(buf, cv::Scalar(255, 120, 255));
  }
  std::snprintf(buf, sizeof buf, "viewer: frames %lld  drawn %lld  dropped %lld  %.1f fps %s",
                static_cast<long long>(d.frames_received), static_cast<long long>(d.frames_drawn),
                static_cast<long long>(d.frames_dropped), d.draw_fps,
                d.stream_state.empty() ? "" : ("  stream " + d.stream_state).c_str());
  line(buf, d.frames_dropped > 0 ? cv::Scalar(0, 200, 255) : kTextColour);
  y += 4;
  for (const NodeStatusView& n : d.nodes) {
    std::snprintf(buf, sizeof buf, "%s: seq %lld in %lld out %lld drop %lld skip %lld err %lld",
                  n.node.c_str(), static_cast<long long>(n.last_seq),
                  static_cast<long long>(n.frames_in), static_cast<long long>(n.frames_out),
                  static_cast<long long>(n.frames_dropped),
                  static_cast<long long>(n.frames_skipped), static_cast<long long>(n.errors));
    line(buf, cv::Scalar(255, 210, 150));
    std::string stages;
    for (const StageTimingView& s : n.stages) {
      std::snprintf(buf, sizeof buf, "%s %.1f/%.1f/%.1f  ", s.name.c_str(), s.last_ms, s.mean_ms,
                    s.max_ms);
      if (stages.size() + std::char_traits<char>::length(buf) > 80) {
        line("  " + stages);
        stages.clear();
      }
      stages += buf;
    }
    if (!stages.empty()) line("  " + stages);
    if (!n.last_warning.empty())
      line("  ! " + n.last_warning.substr(0, 90), cv::Scalar(80, 80, 255));
  }
  if (!d.nodes.empty()) line("(stage timings: last/mean/max ms)", kDimText);
  return panel;
}

cv::Mat composeGrid(const std::vector<cv::Mat>& panels, int cols, cv::Size cell) {
  CV_Assert(cols > 0 && cell.width > 0 && cell.height > 0);
  const int rows = std::max(1, static_cast<int>((panels.size() + cols - 1) / cols));
  cv::Mat canvas(rows * cell.height, cols * cell.width, CV_8UC3, cv::Scalar(20, 20, 20));
  for (size_t i = 0; i < panels.size(); ++i) {
    const cv::Rect r(static_cast<int>(i % cols) * cell.width,
                     static_cast<int>(i / cols) * cell.height, cell.width, cell.height);
    cv::Mat p = toBgr(panels[i]);
    if (p.empty()) continue;
    if (p.size() != cell) cv::resize(p, p, cell, 0, 0, cv::INTER_AREA);
    p.copyTo(canvas(r));
  }
  return canvas;
}

std::vector<cv::Rect> canvasLayout(const CanvasOptions& o) {
  const int w = o.cell.width, h = o.cell.height;
  return {cv::Rect(0, 0, w, h),        cv::Rect(w, 0, w, h), cv::Rect(2 * w, 0, w, h),
          cv::Rect(3 * w, 0, w, h),    cv::Rect(0, h, w, h), cv::Rect(w, h, w, h),
          cv::Rect(2 * w, h, 2 * w, h)};
}

cv::Mat renderCanvas(const ViewerFrameData& d, const CanvasOptions& o) {
  const std::vector<cv::Rect> cells = canvasLayout(o);
  cv::Mat canvas(2 * o.cell.height, 4 * o.cell.width, CV_8UC3, cv::Scalar(20, 20, 20));
  auto put = [&](const cv::Mat& panel, int i) {
    panel.copyTo(canvas(cells[static_cast<size_t>(i)]));
    cv::rectangle(canvas, cells[static_cast<size_t>(i)], cv::Scalar(20, 20, 20), 1);
  };
  // Colour with features: the frame the features belong to when known, else the newest.
  const RgbdFrame* colour_frame =
      d.feature_frame ? &*d.feature_frame : (d.frame ? &*d.frame : nullptr);
  const FrameFeatures* feats = (d.features && d.feature_frame) ? &*d.features : nullptr;
  const FramePose* pose = d.status.pose ? &*d.status.pose : nullptr;
  std::string title = "colour + features";
  if (colour_frame) title += " (seq " + std::to_string(colour_frame->seq) + ")";
  put(renderFeaturePanel(colour_frame ? colour_frame->bgr : cv::Mat(), feats, pose, title, o.cell,
                         o.overlay),
      0);
  std::string raw_title = "raw depth";
  if (d.frame) raw_title += " (seq " + std::to_string(d.frame->seq) + ")";
  put(renderScalarPanel(d.frame ? d.frame->depth_m : cv::Mat(), raw_title, o.cell, o.depth), 1);
  std::string fused_title = d.fused_title;
  if (d.fused_depth)
    fused_title += " (window " + std::to_string(d.fused_depth->window_length) + ")";
  // Depth only through fusion: tinted when known (same-frame C-GM map received) and wanted.
  const bool tint = o.show_fusion_only && d.fused_depth && !d.fusion_only_mask.empty() &&
                    d.fusion_only_mask.size() == d.fused_depth->depth_m.size();
  put(renderScalarPanel(d.fused_depth ? d.fused_depth->depth_m : cv::Mat(), fused_title, o.cell,
                        o.depth, "m", tint ? d.fusion_only_mask : cv::Mat(),
                        "depth only through fusion"),
      2);
  put(renderScalarPanel(d.fused_depth ? sqrtVariance(d.fused_depth->var_m2) : cv::Mat(),
                        "depth uncertainty sigma", o.cell, o.sigma),
      3);
  put(renderTrajectoryPanel(d.trajectory, d.ground_truth, topDownAxes(), "trajectory: top-down",
                            o.cell),
      4);
  put(renderTrajectoryPanel(d.trajectory, d.ground_truth, sideAxes(), "trajectory: side", o.cell),
      5);
  put(renderStatusPanel(d.status, cells[6].size()), 6);
  return canvas;
}

}  // namespace viewer
}  // namespace pplvo

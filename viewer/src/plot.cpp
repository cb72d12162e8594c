#include "pplvo/viewer/plot.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "pplvo/eval/nees.h"
#include "pplvo/eval/rpe.h"
#include "pplvo/viewer/ticks.h"

namespace pplvo {
namespace viewer {
namespace {

/// Rows sorted by stamp, the last line of a duplicated stamp winning (TUM dict semantics),
/// non-finite rows dropped.
std::vector<eval::TumRow> cleanRows(const eval::TumFile& f) {
  std::map<double, eval::TumRow> by_stamp;
  for (const eval::TumRow& r : f.rows) {
    bool finite = std::isfinite(r.stamp_s);
    for (double v : r.values) finite = finite && std::isfinite(v);
    if (finite) by_stamp[r.stamp_s] = r;
  }
  std::vector<eval::TumRow> out;
  out.reserve(by_stamp.size());
  for (auto& kv : by_stamp) out.push_back(kv.second);
  return out;
}

Eigen::Vector3d position(const eval::TumRow& r) {
  return Eigen::Vector3d(r.values[0], r.values[1], r.values[2]);
}

std::string baseName(const std::string& path) {
  const size_t s = path.find_last_of('/');
  return s == std::string::npos ? path : path.substr(s + 1);
}

// ----- a tiny drawing backend shared by PNG (OpenCV) and SVG output -----

struct Rgb {
  int r, g, b;
};
enum class Anchor { kStart, kMiddle, kEnd };

class Painter {
 public:
  virtual ~Painter() = default;
  virtual void line(cv::Point2d a, cv::Point2d b, Rgb c, double width) = 0;
  virtual void polyline(const std::vector<cv::Point2d>& pts, Rgb c, double width) = 0;
  virtual void rect(cv::Rect2d r, Rgb c, double width) = 0;
  /// `size_px`: text height in pixels; `vertical`: rotated 90 degrees counter-clockwise.
  virtual void text(cv::Point2d p, const std::string& s, Rgb c, double size_px, Anchor a,
                    bool vertical = false) = 0;
  /// Approximate width of `s` in pixels at `size_px`.
  virtual double textWidth(const std::string& s, double size_px) const = 0;
};

class MatPainter : public Painter {
 public:
  explicit MatPainter(cv::Size size) : img_(size, CV_8UC3, cv::Scalar(255, 255, 255)) {}
  const cv::Mat& image() const { return img_; }
  void line(cv::Point2d a, cv::Point2d b, Rgb c, double w) override {
    cv::line(img_, a, b, bgr(c), thick(w), cv::LINE_AA);
  }
  void polyline(const std::vector<cv::Point2d>& pts, Rgb c, double w) override {
    std::vector<cv::Point> p;
    p.reserve(pts.size());
    for (const auto& q : pts) p.emplace_back(cvRound(q.x), cvRound(q.y));
    cv::polylines(img_, p, false, bgr(c), thick(w), cv::LINE_AA);
  }
  void rect(cv::Rect2d r, Rgb c, double w) override {
    cv::rectangle(img_, cv::Rect(cvRound(r.x), cvRound(r.y), cvRound(r.width), cvRound(r.height)),
                  bgr(c), thick(w));
  }
  double textWidth(const std::string& s, double size_px) const override {
    int base = 0;
    return cv::getTextSize(s, cv::FONT_HERSHEY_SIMPLEX, size_px / 22.0, 1, &base).width;
  }
  void text(cv::Point2d p, const std::string& s, Rgb c, double size_px, Anchor a,
            bool vertical) override {
    const double scale = size_px / 22.0;
    int base = 0;
    const cv::Size ts = cv::getTextSize(s, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &base);
    const double shift =
        a == Anchor::kStart ? 0 : (a == Anchor::kMiddle ? ts.width / 2.0 : ts.width);
    if (!vertical) {
      cv::putText(img_, s, cv::Point(cvRound(p.x - shift), cvRound(p.y)), cv::FONT_HERSHEY_SIMPLEX,
                  scale, bgr(c), 1, cv::LINE_AA);
      return;
    }
    cv::Mat t(ts.height + base + 2, ts.width + 2, CV_8UC3, cv::Scalar(255, 255, 255));
    cv::putText(t, s, cv::Point(1, ts.height + 1), cv::FONT_HERSHEY_SIMPLEX, scale, bgr(c), 1,
                cv::LINE_AA);
    cv::Mat r;
    cv::rotate(t, r, cv::ROTATE_90_COUNTERCLOCKWISE);
    // p is the baseline point; after rotation the text runs upwards centred on p.y.
    cv::Rect dst(cvRound(p.x - r.cols), cvRound(p.y - shift), r.cols, r.rows);
    if (a == Anchor::kMiddle) dst.y = cvRound(p.y - r.rows / 2.0);
    dst &= cv::Rect(0, 0, img_.cols, img_.rows);
    if (dst.area() > 0) r(cv::Rect(0, 0, dst.width, dst.height)).copyTo(img_(dst));
  }

 private:
  static cv::Scalar bgr(Rgb c) { return cv::Scalar(c.b, c.g, c.r); }
  static int thick(double w) { return std::max(1, static_cast<int>(std::lround(w))); }
  cv::Mat img_;
};

std::string xmlEscape(const std::string& s) {
  std::string o;
  for (char ch : s) {
    switch (ch) {
      case '&':
        o += "&amp;";
        break;
      case '<':
        o += "&lt;";
        break;
      case '>':
        o += "&gt;";
        break;
      case '"':
        o += "&quot;";
        break;
      case '\'':
        o += "&apos;";
        break;
      default:
        // Control characters are not allowed in XML 1.0.
        if (static_cast<unsigned char>(ch) >= 0x20 || ch == '\t') o += ch;
    }
  }
  return o;
}

class SvgPainter : public Painter {
 public:
  explicit SvgPainter(cv::Size size) : size_(size) {}
  std::string document() const {
    std::ostringstream o;
    o << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << size_.width << "\" height=\""
      << size_.height << "\" viewBox=\"0 0 " << size_.width << ' ' << size_.height << "\">\n"
      << "<rect x=\"0\" y=\"0\" width=\"" << size_.width << "\" height=\"" << size_.height
      << "\" fill=\"white\"/>\n"
      << body_.str() << "</svg>\n";
    return o.str();
  }
  void line(cv::Point2d a, cv::Point2d b, Rgb c, double w) override {
    body_ << "<line x1=\"" << n(a.x) << "\" y1=\"" << n(a.y) << "\" x2=\"" << n(b.x) << "\" y2=\""
          << n(b.y) << "\" stroke=\"" << col(c) << "\" stroke-width=\"" << n(w) << "\"/>\n";
  }
  void polyline(const std::vector<cv::Point2d>& pts, Rgb c, double w) override {
    body_ << "<polyline fill=\"none\" stroke=\"" << col(c) << "\" stroke-width=\"" << n(w)
          << "\" stroke-linejoin=\"round\" points=\"";
    for (size_t i = 0; i < pts.size(); ++i) {
      body_ << (i ? " " : "") << n(pts[i].x) << ',' << n(pts[i].y);
    }
    body_ << "\"/>\n";
  }
  void rect(cv::Rect2d r, Rgb c, double w) override {
    body_ << "<rect x=\"" << n(r.x) << "\" y=\"" << n(r.y) << "\" width=\"" << n(r.width)
          << "\" height=\"" << n(r.height) << "\" fill=\"none\" stroke=\"" << col(c)
          << "\" stroke-width=\"" << n(w) << "\"/>\n";
  }
  double textWidth(const std::string& s, double size_px) const override {
    return 0.6 * size_px * static_cast<double>(s.size());  // sans-serif average, generous
  }
  void text(cv::Point2d p, const std::string& s, Rgb c, double size_px, Anchor a,
            bool vertical) override {
    const char* anchor = a == Anchor::kStart ? "start" : (a == Anchor::kMiddle ? "middle" : "end");
    body_ << "<text x=\"" << n(p.x) << "\" y=\"" << n(p.y) << "\" font-family=\"sans-serif\" "
          << "font-size=\"" << n(size_px) << "\" fill=\"" << col(c) << "\" text-anchor=\"" << anchor
          << "\"";
    if (vertical) body_ << " transform=\"rotate(-90 " << n(p.x) << ' ' << n(p.y) << ")\"";
    body_ << '>' << xmlEscape(s) << "</text>\n";
  }

 private:
  static std::string n(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2f", v);
    return buf;
  }
  static std::string col(Rgb c) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "#%02x%02x%02x", c.r, c.g, c.b);
    return buf;
  }
  cv::Size size_;
  std::ostringstream body_;
};

// ----- figure layout -----

const Rgb kGtColour{0, 0, 0};
const Rgb kAxisColour{60, 60, 60};
const Rgb kGridColour{225, 225, 225};
/// Matplotlib's tab10 without black-ish entries.
const Rgb kRunColours[] = {{31, 119, 180},  {255, 127, 14}, {44, 160, 44},   {214, 39, 40},
                           {148, 103, 189}, {140, 86, 75},  {227, 119, 194}, {127, 127, 127},
                           {188, 189, 34},  {23, 190, 207}};
Rgb runColour(size_t i) { return kRunColours[i % (sizeof kRunColours / sizeof kRunColours[0])]; }

struct Series {
  std::vector<double> x, y;
  Rgb colour;
  double width;
};

struct Range {
  double lo = 1e300, hi = -1e300;
  void add(double v) {
    if (std::isfinite(v)) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  bool valid() const { return lo <= hi; }
  void pad(double frac, double min_span) {
    if (!valid()) {
      lo = 0;
      hi = 1;
    }
    double span = hi - lo;
    if (span < min_span) {
      const double c = 0.5 * (lo + hi);
      lo = c - min_span / 2;
      hi = c + min_span / 2;
      span = min_span;
    }
    lo -= frac * span;
    hi += frac * span;
  }
};

/// Axes with a grid, ticks and labels; one polyline per series with >= 2 points.
void drawAxes(Painter& p, cv::Rect2d box, const std::vector<Series>& series, Range xr, Range yr,
              const std::string& xlabel, const std::string& ylabel, const std::string& title,
              bool equal_scale, double min_span_y = 0.05) {
  xr.pad(0.03, 1e-3);
  yr.pad(0.05, min_span_y);
  if (equal_scale) {
    const double sx = (xr.hi - xr.lo) / box.width, sy = (yr.hi - yr.lo) / box.height;
    if (sx > sy) {
      const double c = 0.5 * (yr.lo + yr.hi), h = sx * box.height / 2;
      yr.lo = c - h;
      yr.hi = c + h;
    } else {
      const double c = 0.5 * (xr.lo + xr.hi), h = sy * box.width / 2;
      xr.lo = c - h;
      xr.hi = c + h;
    }
  }
  auto X = [&](double v) { return box.x + (v - xr.lo) / (xr.hi - xr.lo) * box.width; };
  auto Y = [&](double v) {
    return box.y + box.height - (v - yr.lo) / (yr.hi - yr.lo) * box.height;
  };
  const std::vector<double> tx = niceTicks(xr.lo, xr.hi, equal_scale ? 7 : 8);
  const std::vector<double> ty = niceTicks(yr.lo, yr.hi, equal_scale ? 7 : 4);
  const int dx = tickDecimals(tx), dy = tickDecimals(ty);
  for (double t : tx) {
    p.line({X(t), box.y}, {X(t), box.y + box.height}, kGridColour, 1);
    p.line({X(t), box.y + box.height}, {X(t), box.y + box.height + 5}, kAxisColour, 1);
    p.text({X(t), box.y + box.height + 18}, formatTick(t, dx), kAxisColour, 12, Anchor::kMiddle);
  }
  for (double t : ty) {
    p.line({box.x, Y(t)}, {box.x + box.width, Y(t)}, kGridColour, 1);
    p.line({box.x - 5, Y(t)}, {box.x, Y(t)}, kAxisColour, 1);
    p.text({box.x - 8, Y(t) + 4}, formatTick(t, dy), kAxisColour, 12, Anchor::kEnd);
  }
  for (const Series& s : series) {
    std::vector<cv::Point2d> pts;
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (std::isfinite(s.x[i]) && std::isfinite(s.y[i])) pts.emplace_back(X(s.x[i]), Y(s.y[i]));
    }
    if (pts.size() >= 2) p.polyline(pts, s.colour, s.width);
  }
  p.rect(box, kAxisColour, 1);
  if (!xlabel.empty()) {
    p.text({box.x + box.width / 2, box.y + box.height + 38}, xlabel, kAxisColour, 13,
           Anchor::kMiddle);
  }
  if (!ylabel.empty()) {
    p.text({box.x - 58, box.y + box.height / 2}, ylabel, kAxisColour, 13, Anchor::kMiddle, true);
  }
  if (!title.empty()) p.text({box.x, box.y - 6}, title, kAxisColour, 14, Anchor::kStart);
}

const char* kAxisNames[] = {"x", "y", "z"};

void drawFigure(Painter& p, const PlotData& d, cv::Size size, const std::string& title) {
  const double W = size.width, H = size.height;
  const double top = 86, bottom = 50;
  const std::string heading =
      title.empty() ? "trajectories against ground truth (ATE-aligned)" : title;
  double heading_px = 18;
  while (heading_px > 9 && p.textWidth(heading, heading_px) > W - 20) heading_px -= 1;
  p.text({W / 2, 24}, heading, kAxisColour, heading_px, Anchor::kMiddle);
  // Legend row.
  double lx = 70;
  auto legend = [&](const std::string& label, Rgb c) {
    p.line({lx, 50}, {lx + 28, 50}, c, 3);
    p.text({lx + 34, 55}, label, kAxisColour, 13, Anchor::kStart);
    lx += 34 + p.textWidth(label, 13) + 24;
  };
  legend("ground truth", kGtColour);
  for (size_t i = 0; i < d.runs.size(); ++i) {
    char buf[64];
    std::snprintf(buf, sizeof buf, " (ATE %.3f m)", d.runs[i].ate_rmse_m);
    legend(d.runs[i].label + buf, runColour(i));
  }
  // Top view.
  const cv::Rect2d topbox(80, top, W * 0.42, H - top - bottom - 20);
  {
    std::vector<Series> s;
    Range xr, yr;
    Series g{{}, {}, kGtColour, 2};
    for (const auto& q : d.gt_m) {
      g.x.push_back(q[d.top_h]);
      g.y.push_back(q[d.top_v]);
      xr.add(q[d.top_h]);
      yr.add(q[d.top_v]);
    }
    s.push_back(g);
    for (size_t i = 0; i < d.runs.size(); ++i) {
      Series e{{}, {}, runColour(i), 1.5};
      for (const auto& q : d.runs[i].p_aligned_m) {
        e.x.push_back(q[d.top_h]);
        e.y.push_back(q[d.top_v]);
        xr.add(q[d.top_h]);
        yr.add(q[d.top_v]);
      }
      s.push_back(e);
    }
    drawAxes(p, topbox, s, xr, yr, std::string(kAxisNames[d.top_h]) + " [m]",
             std::string(kAxisNames[d.top_v]) + " [m]", "top view (ground-truth frame)", true);
  }
  // Per-axis and error over time.
  const double rx = topbox.x + topbox.width + 125, rw = W - rx - 25;
  const double gap = 38, rh = (H - top - bottom - 3 * gap) / 4;
  Range tr;
  for (double t : d.gt_t_s) tr.add(t);
  for (const auto& r : d.runs) {
    for (double t : r.t_s) tr.add(t);
  }
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<Series> s;
    Range yr;
    Series g{d.gt_t_s, {}, kGtColour, 2};
    for (const auto& q : d.gt_m) {
      g.y.push_back(q[axis]);
      yr.add(q[axis]);
    }
    s.push_back(g);
    for (size_t i = 0; i < d.runs.size(); ++i) {
      Series e{d.runs[i].t_s, {}, runColour(i), 1.5};
      for (const auto& q : d.runs[i].p_aligned_m) {
        e.y.push_back(q[axis]);
        yr.add(q[axis]);
      }
      s.push_back(e);
    }
    const cv::Rect2d box(rx, top + axis * (rh + gap), rw, rh);
    drawAxes(p, box, s, tr, yr, "", std::string(kAxisNames[axis]) + " [m]", "", false);
  }
  {
    std::vector<Series> s;
    Range yr;
    yr.add(0.0);
    for (size_t i = 0; i < d.runs.size(); ++i) {
      s.push_back(Series{d.runs[i].err_t_s, d.runs[i].err_m, runColour(i), 1.5});
      for (double e : d.runs[i].err_m) yr.add(e);
    }
    const cv::Rect2d box(rx, top + 3 * (rh + gap), rw, rh);
    drawAxes(p, box, s, tr, yr, "time [s]", "error [m]", "", false, 1e-3);
  }
  p.text({rx, top - 6}, "position over time and translational error (ATE pairs)", kAxisColour, 14,
         Anchor::kStart);
}

const Rgb kBoundColour{214, 39, 40};
const Rgb kBandColour{255, 127, 14};

void drawNeesFigure(Painter& p, const NeesPlotData& d, cv::Size size, const std::string& title) {
  const double W = size.width, H = size.height;
  const double top = 80, bottom = 50, gap = 46;
  const std::string heading =
      title.empty() ? "NEES of the relative-pose covariance (" + d.label + ")" : title;
  double heading_px = 18;
  while (heading_px > 9 && p.textWidth(heading, heading_px) > W - 20) heading_px -= 1;
  p.text({W / 2, 24}, heading, kAxisColour, heading_px, Anchor::kMiddle);
  double lx = 90;
  auto legend = [&](const std::string& label, Rgb c) {
    p.line({lx, 50}, {lx + 28, 50}, c, 2);
    p.text({lx + 34, 55}, label, kAxisColour, 13, Anchor::kStart);
    lx += 34 + p.textWidth(label, 13) + 24;
  };
  char buf[96];
  legend("NEES per frame pair", runColour(0));
  legend("dof (consistent mean)", kGtColour);
  std::snprintf(buf, sizeof buf, "%.0f %% upper bound", 100 * d.confidence);
  legend(buf, kBoundColour);
  std::snprintf(buf, sizeof buf, "two-sided %.0f %% band", 100 * d.confidence);
  legend(buf, kBandColour);
  Range tr;
  for (double t : d.t_s) tr.add(t);
  const double bx = 100, bw = W - bx - 30, bh = (H - top - bottom - 2 * gap) / 3;
  const std::vector<double>* values[] = {&d.nees, &d.nees_t, &d.nees_r};
  const double dofs[] = {6, 3, 3};
  const char* names[] = {"6 dof", "translation (3 dof)", "rotation (3 dof)"};
  for (int k = 0; k < 3; ++k) {
    const std::vector<double>& v = *values[k];
    const double dof = dofs[k];
    const double upper = eval::chiSquareQuantile(d.confidence, dof);
    const double lo = eval::chiSquareQuantile(0.5 * (1 - d.confidence), dof);
    const double hi = eval::chiSquareQuantile(0.5 * (1 + d.confidence), dof);
    Series s{{}, {}, runColour(0), 1.2};
    Range yr;
    double sum = 0;
    int inside = 0;
    for (size_t i = 0; i < v.size() && i < d.t_s.size(); ++i) {
      const double y = std::log10(std::max(v[i], 1e-6));
      s.x.push_back(d.t_s[i]);
      s.y.push_back(y);
      yr.add(y);
      sum += v[i];
      if (v[i] <= upper) ++inside;
    }
    std::vector<Series> series{s};
    auto hline = [&](double value, Rgb c, double w) {
      const double y = std::log10(value);
      yr.add(y);
      series.push_back(Series{{tr.lo, tr.hi}, {y, y}, c, w});
    };
    hline(dof, kGtColour, 1.5);
    hline(upper, kBoundColour, 1.5);
    hline(lo, kBandColour, 1);
    hline(hi, kBandColour, 1);
    const double n = static_cast<double>(std::max<size_t>(1, v.size()));
    std::snprintf(buf, sizeof buf, "%s: mean %.3g (ideal %.0f), %.1f %% below %.2f", names[k],
                  sum / n, dof, 100.0 * inside / n, upper);
    const cv::Rect2d box(bx, top + k * (bh + gap), bw, bh);
    drawAxes(p, box, series, tr, yr, k == 2 ? "time [s]" : "", "log10 NEES", buf, false, 1.0);
  }
}

}  // namespace

PlotPrepareResult preparePlot(const eval::TumFile& gt, const std::vector<eval::TumFile>& est,
                              const std::vector<std::string>& labels,
                              const eval::AteOptions& options, double gt_margin_s) {
  PlotPrepareResult res;
  const std::vector<eval::TumRow> gt_rows = cleanRows(gt);
  if (gt_rows.size() < 2) {
    res.error = "ground truth " + gt.name + " has fewer than 2 valid poses";
    return res;
  }
  PlotData& d = res.data;
  // Only the part of the ground truth the estimates cover (plus a margin) is plotted.
  double est_lo = 1e300, est_hi = -1e300;
  for (const eval::TumFile& e : est) {
    for (const eval::TumRow& r : cleanRows(e)) {
      est_lo = std::min(est_lo, r.stamp_s);
      est_hi = std::max(est_hi, r.stamp_s);
    }
  }
  std::vector<eval::TumRow> shown;
  for (const eval::TumRow& r : gt_rows) {
    if (gt_margin_s < 0 || est_lo > est_hi ||
        (r.stamp_s >= est_lo - gt_margin_s && r.stamp_s <= est_hi + gt_margin_s)) {
      shown.push_back(r);
    }
  }
  if (shown.size() < 2) shown = gt_rows;  // no overlap: ATE below reports it
  d.t0_s = shown.front().stamp_s;
  Eigen::Vector3d lo = position(shown.front()), hi = lo;
  for (const eval::TumRow& r : shown) {
    d.gt_t_s.push_back(r.stamp_s - d.t0_s);
    d.gt_m.push_back(position(r));
    lo = lo.cwiseMin(position(r));
    hi = hi.cwiseMax(position(r));
  }
  const Eigen::Vector3d spread = hi - lo;
  int least = 0;
  for (int k = 1; k < 3; ++k) {
    if (spread[k] < spread[least]) least = k;
  }
  d.top_h = least == 0 ? 1 : 0;
  d.top_v = least == 2 ? 1 : 2;
  for (size_t i = 0; i < est.size(); ++i) {
    const eval::AteResult ate = eval::evaluateAte(gt, est[i], options);
    if (!ate.ok) {
      res.error = "ATE of " + est[i].name + " failed: " + ate.error;
      return res;
    }
    PlotRun run;
    run.label = i < labels.size() && !labels[i].empty() ? labels[i] : baseName(est[i].name);
    for (const eval::TumRow& r : cleanRows(est[i])) {
      run.t_s.push_back(r.stamp_s - d.t0_s);
      run.p_aligned_m.push_back(ate.R_gt_est * position(r) + ate.t_gt_est);
    }
    for (const eval::AtePair& pr : ate.pairs) {
      run.err_t_s.push_back(pr.gt_stamp_s - d.t0_s);
      run.err_m.push_back(pr.error_m);
    }
    run.ate_rmse_m = ate.error_m.rmse;
    run.n_pairs = static_cast<int>(ate.pairs.size());
    d.runs.push_back(std::move(run));
  }
  res.ok = true;
  return res;
}

cv::Mat renderPlotImage(const PlotData& data, cv::Size size, const std::string& title) {
  MatPainter p(size);
  drawFigure(p, data, size, title);
  return p.image();
}

std::string renderPlotSvg(const PlotData& data, cv::Size size, const std::string& title) {
  SvgPainter p(size);
  drawFigure(p, data, size, title);
  return p.document();
}

cv::Mat renderNeesPlotImage(const NeesPlotData& data, cv::Size size, const std::string& title) {
  MatPainter p(size);
  drawNeesFigure(p, data, size, title);
  return p.image();
}

std::string renderNeesPlotSvg(const NeesPlotData& data, cv::Size size, const std::string& title) {
  SvgPainter p(size);
  drawNeesFigure(p, data, size, title);
  return p.document();
}

GroundTruthView alignGroundTruth(const eval::TumFile& gt, const StampedPoses& est, GtAlignment mode,
                                 const eval::AssociationOptions& assoc) {
  GroundTruthView v;
  const std::vector<eval::TumRow> gt_rows = cleanRows(gt);
  if (gt_rows.empty() || est.empty()) return v;
  Pose3 T_w_gt = Pose3::Identity();  // maps ground-truth world points into the estimate's world
  if (mode == GtAlignment::kFirstPose) {
    std::vector<double> est_s, gt_s;
    for (const auto& e : est) est_s.push_back(e.first);
    for (const auto& r : gt_rows) gt_s.push_back(r.stamp_s);
    const std::vector<eval::StampMatch> m = eval::associateStamps(est_s, gt_s, assoc);
    if (m.empty()) return v;
    v.n_pairs = static_cast<int>(m.size());
    const eval::StampMatch& first = m.front();  // sorted by estimate stamp
    const auto e_it = std::find_if(est.begin(), est.end(),
                                   [&](const auto& e) { return e.first == first.first_s; });
    const auto g_it = std::find_if(gt_rows.begin(), gt_rows.end(),
                                   [&](const auto& r) { return r.stamp_s == first.second_s; });
    if (e_it == est.end() || g_it == gt_rows.end()) return v;
    Pose3 T_gt_c = Pose3::Identity();
    T_gt_c.matrix() = eval::transform44(g_it->values);
    T_w_gt = e_it->second * T_gt_c.inverse();
  } else {
    eval::TumFile est_file;
    est_file.name = "live estimate";
    for (const auto& e : est) {
      eval::TumRow r;
      const Eigen::Vector3d t = e.second.translation();
      const Eigen::Quaterniond q(e.second.rotation());
      r.stamp_s = e.first;
      r.values = {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()};
      est_file.rows.push_back(r);
    }
    eval::AteOptions o;
    o.association = assoc;
    const eval::AteResult ate = eval::evaluateAte(gt, est_file, o);
    if (!ate.ok) return v;
    v.n_pairs = static_cast<int>(ate.pairs.size());
    // p_gt = R p_w + t  =>  p_w = R^T (p_gt - t)
    T_w_gt.linear() = ate.R_gt_est.transpose();
    T_w_gt.translation() = -ate.R_gt_est.transpose() * ate.t_gt_est;
  }
  for (const eval::TumRow& r : gt_rows) v.gt_in_world_m.push_back(T_w_gt * position(r));
  v.aligned = true;
  return v;
}

}  // namespace viewer
}  // namespace pplvo

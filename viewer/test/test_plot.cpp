// pplvo-plot and the plot library: ATE-aligned series, PNG size, SVG structure.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <sstream>
#include <string>

#include "pplvo/viewer/plot.h"

namespace pplvo {
namespace viewer {
namespace {

struct Pose7 {
  double t;
  Eigen::Vector3d p;
  Eigen::Quaterniond q;
};

std::vector<Pose7> groundTruth() {
  std::vector<Pose7> out;
  for (int i = 0; i < 120; ++i) {
    const double t = 100.0 + i / 30.0, a = 0.05 * i;
    out.push_back(
        {t,
         Eigen::Vector3d(1.0 * std::sin(a), 0.6 * (1 - std::cos(a)), 1.2 + 0.05 * std::sin(3 * a)),
         Eigen::Quaterniond(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()))});
  }
  return out;
}

/// The ground truth seen from another world frame, plus position noise of sigma_m.
std::vector<Pose7> estimate(double sigma_m, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, sigma_m);
  const Eigen::Quaterniond q_e_g(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, 1, 0.3).normalized()));
  const Eigen::Vector3d t_e_g(0.4, -1.0, 2.0);
  std::vector<Pose7> out;
  for (const Pose7& g : groundTruth()) {
    out.push_back(
        {g.t, q_e_g * g.p + t_e_g + Eigen::Vector3d(n(rng), n(rng), n(rng)), q_e_g * g.q});
  }
  return out;
}

std::string tumText(const std::vector<Pose7>& poses) {
  std::ostringstream o;
  o.precision(10);
  o << "# stamp tx ty tz qx qy qz qw\n";
  for (const Pose7& p : poses) {
    o << p.t << ' ' << p.p.x() << ' ' << p.p.y() << ' ' << p.p.z() << ' ' << p.q.x() << ' '
      << p.q.y() << ' ' << p.q.z() << ' ' << p.q.w() << '\n';
  }
  return o.str();
}

eval::TumFile parse(const std::string& text, const std::string& name) {
  std::istringstream in(text);
  eval::TumReadResult r = eval::parseTumFile(in, name);
  EXPECT_TRUE(r.ok) << r.error;
  return r.file;
}

std::string tempDir() {
  char tmpl[] = "/tmp/pplvo_plot_test_XXXXXX";
  const char* d = mkdtemp(tmpl);
  EXPECT_NE(d, nullptr);
  return d ? d : "/tmp";
}

void writeFile(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

TEST(ViewerPlot, PrepareAlignsRunsOntoGroundTruth) {
  const eval::TumFile gt = parse(tumText(groundTruth()), "gt");
  const eval::TumFile exact = parse(tumText(estimate(0.0, 1)), "exact");
  const eval::TumFile noisy = parse(tumText(estimate(0.01, 2)), "runs/noisy.txt");
  const PlotPrepareResult r = preparePlot(gt, {exact, noisy}, {"exact"});
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_EQ(r.data.runs.size(), 2u);
  EXPECT_EQ(r.data.runs[0].label, "exact");
  EXPECT_EQ(r.data.runs[1].label, "noisy.txt");
  EXPECT_EQ(r.data.runs[0].n_pairs, 120);
  EXPECT_LT(r.data.runs[0].ate_rmse_m, 1e-6);
  // sqrt(3) * 0.01 expected; alignment absorbs a little.
  EXPECT_GT(r.data.runs[1].ate_rmse_m, 0.010);
  EXPECT_LT(r.data.runs[1].ate_rmse_m, 0.025);
  for (size_t i = 0; i < r.data.gt_m.size(); ++i) {
    EXPECT_LT((r.data.runs[0].p_aligned_m[i] - r.data.gt_m[i]).norm(), 1e-6);
  }
  EXPECT_DOUBLE_EQ(r.data.gt_t_s.front(), 0.0);
  // The ground truth spreads least along z: top view is x-y.
  EXPECT_EQ(r.data.top_h, 0);
  EXPECT_EQ(r.data.top_v, 1);
  // A shorter run: the ground truth is cropped to its span +- 1 s (30 Hz: 60 + 30 rows).
  std::vector<Pose7> part = estimate(0.0, 1);
  part.resize(60);
  const PlotPrepareResult cropped = preparePlot(gt, {parse(tumText(part), "part")}, {});
  ASSERT_TRUE(cropped.ok);
  EXPECT_EQ(cropped.data.gt_m.size(), 90u);
  EXPECT_EQ(preparePlot(gt, {parse(tumText(part), "part")}, {}, {}, -1.0).data.gt_m.size(), 120u);
  // A run that cannot be associated is an error naming it.
  eval::TumFile far = parse("1 0 0 0 0 0 0 1\n2 0 0 0 0 0 0 1\n", "far");
  const PlotPrepareResult bad = preparePlot(gt, {far}, {});
  EXPECT_FALSE(bad.ok);
  EXPECT_NE(bad.error.find("far"), std::string::npos);
}

TEST(ViewerPlot, ImageSizeAndSvgPolylineCount) {
  const eval::TumFile gt = parse(tumText(groundTruth()), "gt");
  const PlotPrepareResult r = preparePlot(
      gt, {parse(tumText(estimate(0.01, 3)), "a"), parse(tumText(estimate(0.03, 4)), "b")}, {});
  ASSERT_TRUE(r.ok);
  const cv::Mat img = renderPlotImage(r.data, cv::Size(1200, 800), "t");
  EXPECT_EQ(img.size(), cv::Size(1200, 800));
  cv::Scalar mean, sd;
  cv::meanStdDev(img, mean, sd);
  EXPECT_GT(sd[0], 10.0);
  const std::string svg = renderPlotSvg(r.data, cv::Size(1200, 800), "a < b & c");
  size_t count = 0;
  for (size_t p = svg.find("<polyline"); p != std::string::npos; p = svg.find("<polyline", p + 1)) {
    ++count;
  }
  EXPECT_EQ(count, 4u + 5u * 2u);  // gt + runs in top/x/y/z, runs only in the error axes
  EXPECT_NE(svg.find("a &lt; b &amp; c"), std::string::npos);
}

std::string run(const std::string& cmd, int& status) {
  std::string out;
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) {
    status = -1;
    return out;
  }
  char buf[512];
  while (fgets(buf, sizeof buf, p)) out += buf;
  status = pclose(p);
  return out;
}

TEST(ViewerPlot, ProgramWritesPngAndParsableSvg) {
  const std::string dir = tempDir();
  writeFile(dir + "/gt.txt", tumText(groundTruth()));
  writeFile(dir + "/a.txt", tumText(estimate(0.01, 5)));
  writeFile(dir + "/b.txt", tumText(estimate(0.02, 6)));
  writeFile(dir + "/c.txt", tumText(estimate(0.04, 7)));
  int status = 0;
  std::string out = run(std::string(PPLVO_PLOT_BINARY) + " " + dir + "/gt.txt " + dir + "/a.txt " +
                            dir + "/b.txt " + dir +
                            "/c.txt --labels full,no-lines,no-planes --output " + dir + "/p.png",
                        status);
  ASSERT_EQ(status, 0) << out;
  EXPECT_NE(out.find("no-planes: ATE rmse"), std::string::npos) << out;
  const cv::Mat png = cv::imread(dir + "/p.png");
  EXPECT_EQ(png.size(), cv::Size(1400, 900));
  out = run(std::string(PPLVO_PLOT_BINARY) + " " + dir + "/gt.txt " + dir + "/a.txt " + dir +
                "/b.txt " + dir + "/c.txt --size 1000x700 --output " + dir + "/p.svg",
            status);
  ASSERT_EQ(status, 0) << out;
  // Parse as XML with Python's standard library and count the polylines.
  out = run("/usr/bin/python3 -c \"import xml.etree.ElementTree as E; r=E.parse('" + dir +
                "/p.svg').getroot(); print(r.get('width'), r.get('height'), "
                "len(r.findall('{http://www.w3.org/2000/svg}polyline')))\"",
            status);
  ASSERT_EQ(status, 0) << out;
  EXPECT_EQ(out, "1000 700 19\n");  // 4 + 5 x 3 runs
  // Errors: missing file, bad extension, too many labels.
  out = run(std::string(PPLVO_PLOT_BINARY) + " " + dir + "/gt.txt " + dir +
                "/missing.txt --output " + dir + "/x.png",
            status);
  EXPECT_NE(status, 0);
  EXPECT_NE(out.find("missing.txt"), std::string::npos) << out;
  out = run(std::string(PPLVO_PLOT_BINARY) + " " + dir + "/gt.txt " + dir + "/a.txt --output " +
                dir + "/x.jpg",
            status);
  EXPECT_NE(status, 0);
  out = run(std::string(PPLVO_PLOT_BINARY) + " " + dir + "/gt.txt " + dir +
                "/a.txt --labels a,b --output " + dir + "/x.png",
            status);
  EXPECT_NE(status, 0);
  std::system(("rm -rf " + dir).c_str());
}

TEST(ViewerPlot, NeesFigureAndProgramMode) {
  // Library: per axes one NEES polyline and four horizontal lines (dof, upper bound, band).
  NeesPlotData d;
  d.label = "run";
  std::mt19937 rng(9);
  std::chi_squared_distribution<double> c6(6.0), c3(3.0);
  for (int i = 0; i < 200; ++i) {
    d.t_s.push_back(i / 30.0);
    d.nees.push_back(c6(rng));
    d.nees_t.push_back(c3(rng));
    d.nees_r.push_back(c3(rng));
  }
  const std::string svg = renderNeesPlotSvg(d, cv::Size(1000, 700), "");
  size_t count = 0;
  for (size_t p = svg.find("<polyline"); p != std::string::npos; p = svg.find("<polyline", p + 1)) {
    ++count;
  }
  EXPECT_EQ(count, 3u * 5u);
  EXPECT_NE(svg.find("6 dof: mean"), std::string::npos);
  EXPECT_NE(svg.find("below 12.59"), std::string::npos);
  EXPECT_NE(svg.find("below 7.81"), std::string::npos);
  const cv::Mat img = renderNeesPlotImage(d, cv::Size(1000, 700), "nees");
  EXPECT_EQ(img.size(), cv::Size(1000, 700));

  // Program: NEES data as pplvo-eval --nees-data writes it.
  const std::string dir = tempDir();
  std::ostringstream data;
  data << "# pplvo-eval --nees per-pair data\n";
  for (size_t i = 0; i < d.t_s.size(); ++i) {
    data << 10 + d.t_s[i] << ' ' << 10 + d.t_s[i] - 1 / 30.0 << " 1 " << d.nees[i] << ' '
         << d.nees_t[i] << ' ' << d.nees_r[i] << " 0 0 0 0 0 0 0 1 1 1 1 1 1\n";
  }
  writeFile(dir + "/nees.txt", data.str());
  int status = 0;
  std::string out = run(
      std::string(PPLVO_PLOT_BINARY) + " --nees " + dir + "/nees.txt --output " + dir + "/nees.png",
      status);
  ASSERT_EQ(status, 0) << out;
  EXPECT_NE(out.find("200 pairs plotted"), std::string::npos) << out;
  EXPECT_EQ(cv::imread(dir + "/nees.png").size(), cv::Size(1400, 900));
  writeFile(dir + "/bad.txt", "1 2 3\n");
  out = run(
      std::string(PPLVO_PLOT_BINARY) + " --nees " + dir + "/bad.txt --output " + dir + "/bad.png",
      status);
  EXPECT_NE(status, 0);
  EXPECT_NE(out.find("bad.txt:1"), std::string::npos) << out;
  std::system(("rm -rf " + dir).c_str());
}

TEST(ViewerPlot, LiveGroundTruthAlignmentModes) {
  const eval::TumFile gt = parse(tumText(groundTruth()), "gt");
  // The estimate's world is the first camera frame: T_w_c = T_gt_c0^-1 T_gt_c.
  const std::vector<Pose7> g = groundTruth();
  auto T = [](const Pose7& p) { return makePose(p.p, p.q); };
  StampedPoses est;
  for (int i = 0; i < 40; ++i) est.emplace_back(g[i].t, T(g[0]).inverse() * T(g[i]));
  for (GtAlignment mode : {GtAlignment::kFirstPose, GtAlignment::kAte}) {
    const GroundTruthView v = alignGroundTruth(gt, est, mode);
    ASSERT_TRUE(v.aligned);
    ASSERT_EQ(v.gt_in_world_m.size(), g.size());
    for (int i = 0; i < 40; ++i) {
      EXPECT_LT((v.gt_in_world_m[i] - est[i].second.translation()).norm(), 1e-6);
    }
  }
  StampedPoses unrelated = {{5.0, Pose3::Identity()}};
  EXPECT_FALSE(alignGroundTruth(gt, unrelated, GtAlignment::kFirstPose).aligned);
}

}  // namespace
}  // namespace viewer
}  // namespace pplvo

// pplvo-plot GT EST... --output FILE.png|svg [--labels a,b] [--fps F] [--title T]
// [--size WxH]: trajectories against ground truth, aligned with pplvo_eval's ATE alignment.
// pplvo-plot --nees NEES_DATA --output FILE.png|svg [--title T] [--size WxH]: NEES over time
// with the chi-square bounds (NEES_DATA from pplvo-eval --nees --nees-data).
#include <cstdio>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "pplvo/eval/nees.h"
#include "pplvo/eval/tum_file.h"
#include "pplvo/viewer/plot.h"

namespace {
void usage() {
  std::fprintf(stderr,
               "usage: pplvo-plot GT EST [EST...] --output FILE.png|FILE.svg\n"
               "       [--labels a,b,...] [--fps F] [--title TEXT] [--size WxH]\n"
               "  --fps F: stamps are frame indices at F Hz (ICL-NUIM)\n"
               "usage: pplvo-plot --nees NEES_DATA --output FILE.png|FILE.svg [--title TEXT]\n"
               "       [--size WxH]   (NEES_DATA: pplvo-eval --nees ... --nees-data FILE)\n");
}
bool endsWith(const std::string& s, const std::string& e) {
  return s.size() >= e.size() && s.compare(s.size() - e.size(), e.size(), e) == 0;
}
int plotNees(const std::string& path, const std::string& output, const std::string& title,
             cv::Size size) {
  const bool svg = endsWith(output, ".svg");
  if (output.empty() || (!svg && !endsWith(output, ".png"))) {
    std::fprintf(stderr, "pplvo-plot: --output must end in .png or .svg\n");
    return 2;
  }
  const pplvo::eval::NeesDataReadResult r = pplvo::eval::readNeesData(path);
  if (!r.ok) {
    std::fprintf(stderr, "pplvo-plot: %s\n", r.error.c_str());
    return 1;
  }
  if (r.rows.empty()) {
    std::fprintf(stderr, "pplvo-plot: %s has no NEES pairs\n", path.c_str());
    return 1;
  }
  pplvo::viewer::NeesPlotData d;
  const size_t slash = path.find_last_of('/');
  d.label = slash == std::string::npos ? path : path.substr(slash + 1);
  for (const auto& row : r.rows) {
    d.t_s.push_back(row.stamp_s - r.rows.front().stamp_s);
    d.nees.push_back(row.nees);
    d.nees_t.push_back(row.nees_t);
    d.nees_r.push_back(row.nees_r);
  }
  bool written = false;
  if (svg) {
    std::ofstream out(output);
    out << pplvo::viewer::renderNeesPlotSvg(d, size, title);
    written = static_cast<bool>(out);
  } else {
    written = cv::imwrite(output, pplvo::viewer::renderNeesPlotImage(d, size, title));
  }
  if (!written) {
    std::fprintf(stderr, "pplvo-plot: cannot write %s\n", output.c_str());
    return 1;
  }
  std::printf("%s: %zu pairs plotted\n", d.label.c_str(), d.t_s.size());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> files, labels;
  std::string output, title, nees_path;
  double fps = 0.0;
  cv::Size size(1400, 900);
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "pplvo-plot: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--output" || a == "-o")
      output = next();
    else if (a == "--nees")
      nees_path = next();
    else if (a == "--labels") {
      std::stringstream ss(next());
      std::string l;
      while (std::getline(ss, l, ',')) labels.push_back(l);
    } else if (a == "--fps")
      fps = std::atof(next().c_str());
    else if (a == "--title")
      title = next();
    else if (a == "--size") {
      if (std::sscanf(next().c_str(), "%dx%d", &size.width, &size.height) != 2 ||
          size.width < 400 || size.height < 300) {
        std::fprintf(stderr, "pplvo-plot: --size WxH, at least 400x300\n");
        return 2;
      }
    } else if (a == "-h" || a == "--help") {
      usage();
      return 0;
    } else if (a.size() > 1 && a[0] == '-') {
      std::fprintf(stderr, "pplvo-plot: unknown option %s\n", a.c_str());
      usage();
      return 2;
    } else
      files.push_back(a);
  }
  if (!nees_path.empty()) return plotNees(nees_path, output, title, size);
  if (files.size() < 2 || output.empty()) {
    usage();
    return 2;
  }
  const bool svg = endsWith(output, ".svg");
  if (!svg && !endsWith(output, ".png")) {
    std::fprintf(stderr, "pplvo-plot: --output must end in .png or .svg\n");
    return 2;
  }
  if (labels.size() > files.size() - 1) {
    std::fprintf(stderr, "pplvo-plot: %zu labels for %zu estimates\n", labels.size(),
                 files.size() - 1);
    return 2;
  }
  pplvo::eval::TumReadOptions ro;
  ro.fps = fps;
  std::vector<pplvo::eval::TumFile> tum;
  for (const std::string& f : files) {
    pplvo::eval::TumReadResult r = pplvo::eval::readTumFile(f, ro);
    if (!r.ok) {
      std::fprintf(stderr, "pplvo-plot: %s\n", r.error.c_str());
      return 1;
    }
    tum.push_back(std::move(r.file));
  }
  const std::vector<pplvo::eval::TumFile> est(tum.begin() + 1, tum.end());
  const pplvo::viewer::PlotPrepareResult prep = pplvo::viewer::preparePlot(tum[0], est, labels);
  if (!prep.ok) {
    std::fprintf(stderr, "pplvo-plot: %s\n", prep.error.c_str());
    return 1;
  }
  bool written = false;
  if (svg) {
    std::ofstream out(output);
    out << pplvo::viewer::renderPlotSvg(prep.data, size, title);
    written = static_cast<bool>(out);
  } else {
    written = cv::imwrite(output, pplvo::viewer::renderPlotImage(prep.data, size, title));
  }
  if (!written) {
    std::fprintf(stderr, "pplvo-plot: cannot write %s\n", output.c_str());
    return 1;
  }
  for (const auto& r : prep.data.runs) {
    std::printf("%s: ATE rmse %.4f m over %d pairs\n", r.label.c_str(), r.ate_rmse_m, r.n_pairs);
  }
  return 0;
}

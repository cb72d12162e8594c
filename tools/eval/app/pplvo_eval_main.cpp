// pplvo-eval GT EST [--fps F] [--max-difference 0.02] [--delta 1] [--plot-data FILE] [--json]
// ATE and RPE (1 s fixed delta) exactly as the TUM RGB-D benchmark scripts define them.
// Exit status: 0 when both figures were computed, 2 on any error (usage, unreadable file,
// too few pose pairs). See docs/evaluation.md.
#include <cmath>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "pplvo/eval/report.h"
#include "pplvo/eval/tum_file.h"

namespace {

constexpr int kExitError = 2;

const char* kUsage =
    "usage: pplvo-eval GT EST [--fps F] [--max-difference S] [--delta S] [--plot-data FILE] "
    "[--json]\n"
    "  GT, EST            TUM trajectories 'stamp tx ty tz qx qy qz qw' (camera to world)\n"
    "  --fps F            stamps are frame indices: divide them by F (ICL-NUIM: 30)\n"
    "  --max-difference S ATE association tolerance in seconds (default 0.02)\n"
    "  --delta S          RPE fixed delta in seconds (default 1)\n"
    "  --plot-data FILE   write per-pair ATE and RPE errors to FILE\n"
    "  --json             print one JSON object instead of 'key value' lines\n";

bool parsePositive(const std::string& text, double* value) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(v) || v <= 0.0) return false;
  *value = v;
  return true;
}

int run(int argc, char** argv) {
  std::vector<std::string> positional;
  pplvo::eval::EvalOptions options;
  std::string plot_path;
  bool json = false;
  for (int k = 1; k < argc; ++k) {
    const std::string arg = argv[k];
    auto needValue = [&](double* target) {
      if (k + 1 >= argc) {
        std::cerr << "pplvo-eval: " << arg << " needs a value\n" << kUsage;
        return false;
      }
      const std::string v = argv[++k];
      if (!parsePositive(v, target)) {
        std::cerr << "pplvo-eval: " << arg << " needs a positive number, got '" << v << "'\n";
        return false;
      }
      return true;
    };
    if (arg == "-h" || arg == "--help") {
      std::cout << kUsage;
      return 0;
    } else if (arg == "--fps") {
      if (!needValue(&options.fps)) return kExitError;
    } else if (arg == "--max-difference") {
      if (!needValue(&options.ate.association.max_difference_s)) return kExitError;
    } else if (arg == "--delta") {
      if (!needValue(&options.rpe.delta_s)) return kExitError;
    } else if (arg == "--plot-data") {
      if (k + 1 >= argc) {
        std::cerr << "pplvo-eval: --plot-data needs a file name\n";
        return kExitError;
      }
      plot_path = argv[++k];
    } else if (arg == "--json") {
      json = true;
    } else if (arg.size() > 1 && arg[0] == '-') {
      std::cerr << "pplvo-eval: unknown option '" << arg << "'\n" << kUsage;
      return kExitError;
    } else {
      positional.push_back(arg);
    }
  }
  if (positional.size() != 2) {
    std::cerr << "pplvo-eval: expected two files (GT EST), got " << positional.size() << "\n"
              << kUsage;
    return kExitError;
  }
  pplvo::eval::TumReadOptions read_options;
  read_options.fps = options.fps;
  const auto gt = pplvo::eval::readTumFile(positional[0], read_options);
  if (!gt.ok) {
    std::cerr << "pplvo-eval: ground truth: " << gt.error << '\n';
    return kExitError;
  }
  const auto est = pplvo::eval::readTumFile(positional[1], read_options);
  if (!est.ok) {
    std::cerr << "pplvo-eval: estimate: " << est.error << '\n';
    return kExitError;
  }
  const pplvo::eval::EvalReport report =
      pplvo::eval::evaluateTrajectories(gt.file, est.file, options);
  std::cout << (json ? pplvo::eval::formatJson(report) : pplvo::eval::formatText(report));
  std::cout.flush();
  if (!report.ate.ok) std::cerr << "pplvo-eval: ATE: " << report.ate.error << '\n';
  if (!report.rpe.ok) std::cerr << "pplvo-eval: RPE: " << report.rpe.error << '\n';
  if (!plot_path.empty()) {
    std::ofstream plot(plot_path);
    plot << pplvo::eval::formatPlotData(report);
    plot.flush();
    if (!plot) {
      std::cerr << "pplvo-eval: cannot write plot data to '" << plot_path << "'\n";
      return kExitError;
    }
  }
  return report.ok() ? 0 : kExitError;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "pplvo-eval: internal error: " << e.what() << '\n';
  } catch (...) {
    std::cerr << "pplvo-eval: internal error\n";
  }
  return kExitError;
}

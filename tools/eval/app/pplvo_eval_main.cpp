// pplvo-eval GT EST [--fps F] [--max-difference 0.02] [--delta 1] [--plot-data FILE] [--json]
// ATE and RPE (1 s fixed delta) exactly as the TUM RGB-D benchmark scripts define them.
// pplvo-eval --nees GT COV|LOG [--fps F] [--gt-sigma-t-m S] [--gt-sigma-rot-deg S]
// [--stamp-sigma-s S] [--exact-gt] [--gt-offset-ms MS|auto] [--frame-sigma-t-m S]
// [--frame-sigma-rot-deg S] [--nees-data FILE] [--json]: consistency of the published
// relative-pose covariances (NEES).
// pplvo-eval --fit-frame-error GT1 EST1 [GT2 EST2 ...] [same options]: the per-frame shared
// error that makes them consistent (docs/estimator.md).
// Exit status: 0 when both figures were computed, 2 on any error (usage, unreadable file,
// too few pose pairs). See docs/evaluation.md.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "pplvo/eval/nees.h"
#include "pplvo/eval/pose_records.h"
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
    "  --json             print one JSON object instead of 'key value' lines\n"
    "usage: pplvo-eval --nees GT EST [--fps F] [ground-truth noise options] [--nees-data FILE]\n"
    "                  [--json]\n"
    "  EST                a covariance file (pplvo-run --covariance) or an LCM event log\n"
    "                     (pplvo-run --log, pplvo-logger) whose PPLVO_POSE messages are read\n"
    "  --gt-sigma-t-m S   white noise of each ground-truth position, per axis (m; default:\n"
    "                     estimated from the ground truth's third differences)\n"
    "  --gt-sigma-rot-deg S  of each ground-truth orientation, per axis (deg; same default)\n"
    "  --stamp-sigma-s S  error of each frame stamp (default 0.002 s)\n"
    "  --exact-gt         all three 0 (ICL-NUIM, synthetic sequences)\n"
    "  --no-velocity-model  leave frames posed by the velocity model out\n"
    "  --gt-offset-ms MS  read the ground truth at each stamp + MS (a clock offset; default 0);\n"
    "                     'auto': the offset in [-50, 50] ms minimising the rotation error\n"
    "  --frame-sigma-t-m S, --frame-sigma-rot-deg S\n"
    "                     add a per-frame pose error of this std per axis to each pair (2 Q)\n"
    "  --nees-data FILE   per-pair NEES for pplvo-plot --nees\n"
    "usage: pplvo-eval --fit-frame-error GT1 EST1 [GT2 EST2 ...] [the --nees options]\n"
    "  the per-frame shared error (std per axis) that brings the mean translation and\n"
    "  rotation NEES of all pairs to 3 each; EST from runs with\n"
    "  odometry.tracker.frame_error_sigma_t_m=0 and ..._rot_deg=0\n";

bool parseNonNegative(const std::string& text, double* value) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(v) || v < 0.0) return false;
  *value = v;
  return true;
}

/// Which ground-truth noise figures are estimated from the ground truth itself.
struct GtNoiseSource {
  bool sigma_t_from_data = true, sigma_rot_from_data = true;
};

/// One sequence of a NEES evaluation: its ground truth, the estimate's records and the
/// options completed for it (ground-truth noise from the data, clock offset).
struct NeesInput {
  pplvo::eval::TumFile gt;
  std::vector<pplvo::eval::RelativePoseRecord> records;
  pplvo::eval::NeesOptions options;
};

/// Reads GT and EST and completes `options` (printing what it estimated); false on an error
/// (printed).
bool readNeesInput(const std::string& gt_path, const std::string& est_path,
                   pplvo::eval::NeesOptions options, const GtNoiseSource& source, double fps,
                   bool auto_offset, NeesInput* input) {
  pplvo::eval::TumReadOptions read_options;
  read_options.fps = fps;
  const auto gt = pplvo::eval::readTumFile(gt_path, read_options);
  if (!gt.ok) {
    std::cerr << "pplvo-eval: ground truth: " << gt.error << '\n';
    return false;
  }
  if (source.sigma_t_from_data || source.sigma_rot_from_data) {
    const pplvo::eval::GtJitter j = pplvo::eval::estimateGtJitter(gt.file);
    if (!j.ok) {
      std::cerr << "pplvo-eval: too few ground-truth samples to estimate their noise: give "
                   "--gt-sigma-t-m and --gt-sigma-rot-deg\n";
      return false;
    }
    if (source.sigma_t_from_data) options.gt.sigma_t_m = j.sigma_t_m;
    if (source.sigma_rot_from_data) options.gt.sigma_rot_rad = j.sigma_rot_rad;
    std::cout << "# ground-truth white noise estimated from its samples (third differences): "
              << j.sigma_t_m * 1e3 << " mm, " << j.sigma_rot_rad * 180 / M_PI
              << " deg per axis (RMS over axes)\n";
  }
  std::vector<pplvo::eval::RelativePoseRecord> records;
  if (pplvo::eval::isLcmEventLog(est_path)) {
    const pplvo::eval::PoseLogReadResult log = pplvo::eval::readPoseLog(est_path);
    if (!log.ok) {
      std::cerr << "pplvo-eval: " << log.error << '\n';
      return false;
    }
    if (log.truncated) std::cout << "# " << est_path << " ends with an incomplete event\n";
    if (log.invalid_messages > 0) {
      std::cout << "# " << log.invalid_messages << " invalid pose messages skipped\n";
    }
    std::cout << "# " << log.poses.size() << " poses read from the event log\n";
    // Internal consistency without ground truth: 2 * final cost / (residual rows - 6) is the
    // reduced chi-square of the whitened residuals (about 1 when the per-measurement noise
    // model is right; Tukey weights lower it, the planes' alpha too).
    std::vector<double> reduced, matches;
    for (const pplvo::FramePose& p : log.poses) {
      if (p.status != pplvo::TrackingStatus::kTracking) continue;
      const int rows = 2 * (p.n_point_matches + p.n_line_matches) + 3 * p.n_plane_matches;
      if (rows <= 6) continue;
      reduced.push_back(2.0 * p.final_cost / (rows - 6));
      matches.push_back(p.n_point_matches + p.n_line_matches + p.n_plane_matches);
    }
    if (!reduced.empty()) {
      std::sort(reduced.begin(), reduced.end());
      std::sort(matches.begin(), matches.end());
      std::cout << "residuals.reduced_chi2_median " << reduced[reduced.size() / 2] << "\n"
                << "residuals.matches_median " << matches[matches.size() / 2] << "\n";
    }
    records = pplvo::eval::relativePoseRecords(log.poses, fps);
  } else {
    const auto file = pplvo::eval::readRelativePoseFile(est_path, fps);
    if (!file.ok) {
      std::cerr << "pplvo-eval: estimate: " << file.error << '\n';
      return false;
    }
    records = file.records;
  }
  if (auto_offset) {
    const pplvo::eval::GtTimeOffsetEstimate offset =
        pplvo::eval::estimateGtTimeOffset(gt.file, records, options);
    if (!offset.ok) {
      std::cerr << "pplvo-eval: --gt-offset-ms auto: the pairs could not be evaluated at every "
                   "offset in [-50, 50] ms (too short a ground truth?)\n";
      return false;
    }
    options.gt_time_offset_s = offset.offset_s;
    std::cout << "# ground-truth clock offset estimated: " << offset.offset_s * 1e3
              << " ms (RMS rotation error per axis " << offset.rms_rot_zero_rad * 180 / M_PI
              << " deg at 0 ms, " << offset.rms_rot_rad * 180 / M_PI << " deg there)\n";
  }
  input->gt = gt.file;
  input->records = std::move(records);
  input->options = options;
  return true;
}

int runNees(const std::string& gt_path, const std::string& est_path,
            const pplvo::eval::NeesOptions& options, const GtNoiseSource& source, double fps,
            bool auto_offset, const std::string& data_path, bool json) {
  NeesInput input;
  if (!readNeesInput(gt_path, est_path, options, source, fps, auto_offset, &input)) {
    return kExitError;
  }
  const pplvo::eval::NeesResult r =
      pplvo::eval::evaluateNees(input.gt, input.records, input.options);
  std::cout << "# nees: gt '" << gt_path << "' est '" << est_path << "'\n";
  std::cout << (json ? pplvo::eval::formatNeesJson(r) : pplvo::eval::formatNeesText(r));
  std::cout.flush();
  if (!r.ok) {
    std::cerr << "pplvo-eval: NEES: " << r.error << '\n';
    return kExitError;
  }
  if (!data_path.empty()) {
    std::ofstream out(data_path);
    out << pplvo::eval::formatNeesData(r);
    out.flush();
    if (!out) {
      std::cerr << "pplvo-eval: cannot write NEES data to '" << data_path << "'\n";
      return kExitError;
    }
  }
  return 0;
}

/// --fit-frame-error: the pooled fit over every (GT, EST) pair, then each sequence's own fit
/// and its NEES under the pooled one (how much the figure depends on the sequence).
int runFitFrameError(const std::vector<std::string>& paths,
                     const pplvo::eval::NeesOptions& options, const GtNoiseSource& source,
                     double fps, bool auto_offset) {
  std::vector<NeesInput> inputs(paths.size() / 2);
  std::vector<pplvo::eval::NeesResult> results;
  for (size_t i = 0; i < inputs.size(); ++i) {
    pplvo::eval::NeesOptions o = options;
    o.added_frame_sigma_t_m = o.added_frame_sigma_rot_rad = 0.0;  // fit what is missing
    if (!readNeesInput(paths[2 * i], paths[2 * i + 1], o, source, fps, auto_offset,
                       &inputs[i])) {
      return kExitError;
    }
    results.push_back(
        pplvo::eval::evaluateNees(inputs[i].gt, inputs[i].records, inputs[i].options));
    if (!results.back().ok) {
      std::cerr << "pplvo-eval: " << paths[2 * i + 1] << ": " << results.back().error << '\n';
      return kExitError;
    }
  }
  std::vector<const pplvo::eval::NeesResult*> all;
  for (const auto& r : results) all.push_back(&r);
  const pplvo::eval::FrameErrorFit pooled = pplvo::eval::fitFrameError(all);
  auto deg = [](double rad) { return rad * 180 / M_PI; };
  std::cout << "frame_error.pairs " << pooled.pairs << "\n"
            << "frame_error.sigma_t_m " << pooled.sigma_t_m << "\n"
            << "frame_error.sigma_rot_deg " << deg(pooled.sigma_rot_rad) << "\n";
  std::cout << "# per sequence: own fit (sigma_t_m sigma_rot_deg), then NEES with the pooled fit "
               "(mean, translation, rotation, share inside 95 %)\n";
  for (size_t i = 0; i < inputs.size(); ++i) {
    const pplvo::eval::FrameErrorFit own = pplvo::eval::fitFrameError({&results[i]});
    pplvo::eval::NeesOptions o = inputs[i].options;
    o.added_frame_sigma_t_m = pooled.sigma_t_m;
    o.added_frame_sigma_rot_rad = pooled.sigma_rot_rad;
    const pplvo::eval::NeesResult r = pplvo::eval::evaluateNees(inputs[i].gt, inputs[i].records, o);
    std::cout << "frame_error.sequence " << paths[2 * i + 1] << " pairs " << own.pairs
              << " own " << own.sigma_t_m << " " << deg(own.sigma_rot_rad) << " nees "
              << r.all.mean << " " << r.translation.mean << " " << r.rotation.mean << " "
              << r.all.share_inside << " without " << results[i].all.mean << "\n";
  }
  return pooled.ok ? 0 : kExitError;
}

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
  std::string plot_path, nees_data_path;
  bool json = false, nees = false, fit_frame_error = false, auto_offset = false;
  pplvo::eval::NeesOptions nees_options;
  bool t_given = false, rot_given = false, exact_gt = false;
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
    } else if (arg == "--nees") {
      nees = true;
    } else if (arg == "--fit-frame-error") {
      fit_frame_error = true;
    } else if (arg == "--gt-offset-ms") {
      const std::string v = k + 1 < argc ? argv[k + 1] : "";
      char* end = nullptr;
      const double ms = std::strtod(v.c_str(), &end);
      if (v == "auto") {
        auto_offset = true;
      } else if (v.empty() || *end != '\0' || !std::isfinite(ms) || std::abs(ms) > 1000) {
        std::cerr << "pplvo-eval: --gt-offset-ms needs 'auto' or milliseconds in [-1000, 1000]\n";
        return kExitError;
      } else {
        auto_offset = false;
        nees_options.gt_time_offset_s = ms * 1e-3;
      }
      ++k;
    } else if (arg == "--frame-sigma-t-m" || arg == "--frame-sigma-rot-deg") {
      double v = 0.0;
      if (k + 1 >= argc || !parseNonNegative(argv[k + 1], &v)) {
        std::cerr << "pplvo-eval: " << arg << " needs a number >= 0\n";
        return kExitError;
      }
      ++k;
      if (arg == "--frame-sigma-t-m") nees_options.added_frame_sigma_t_m = v;
      if (arg == "--frame-sigma-rot-deg") nees_options.added_frame_sigma_rot_rad = v * M_PI / 180;
    } else if (arg == "--exact-gt") {
      nees_options.gt = {0.0, 0.0, 0.0};
      exact_gt = true;
    } else if (arg == "--no-velocity-model") {
      nees_options.include_velocity_model = false;
    } else if (arg == "--gt-sigma-t-m" || arg == "--gt-sigma-rot-deg" || arg == "--stamp-sigma-s") {
      double v = 0.0;
      if (k + 1 >= argc || !parseNonNegative(argv[k + 1], &v)) {
        std::cerr << "pplvo-eval: " << arg << " needs a number >= 0\n";
        return kExitError;
      }
      ++k;
      t_given = t_given || arg == "--gt-sigma-t-m";
      rot_given = rot_given || arg == "--gt-sigma-rot-deg";
      if (arg == "--gt-sigma-t-m") nees_options.gt.sigma_t_m = v;
      if (arg == "--gt-sigma-rot-deg") nees_options.gt.sigma_rot_rad = v * M_PI / 180.0;
      if (arg == "--stamp-sigma-s") nees_options.gt.sigma_stamp_s = v;
    } else if (arg == "--nees-data") {
      if (k + 1 >= argc) {
        std::cerr << "pplvo-eval: --nees-data needs a file name\n";
        return kExitError;
      }
      nees_data_path = argv[++k];
    } else if (arg.size() > 1 && arg[0] == '-') {
      std::cerr << "pplvo-eval: unknown option '" << arg << "'\n" << kUsage;
      return kExitError;
    } else {
      positional.push_back(arg);
    }
  }
  if (exact_gt && (t_given || rot_given)) {
    std::cerr << "pplvo-eval: --exact-gt and --gt-sigma-* exclude each other\n";
    return kExitError;
  }
  const GtNoiseSource source{!exact_gt && !t_given, !exact_gt && !rot_given};
  if (fit_frame_error) {
    if (positional.empty() || positional.size() % 2 != 0) {
      std::cerr << "pplvo-eval: --fit-frame-error needs pairs of files (GT EST ...), got "
                << positional.size() << "\n"
                << kUsage;
      return kExitError;
    }
    return runFitFrameError(positional, nees_options, source, options.fps, auto_offset);
  }
  if (positional.size() != 2) {
    std::cerr << "pplvo-eval: expected two files (GT EST), got " << positional.size() << "\n"
              << kUsage;
    return kExitError;
  }
  if (nees) {
    return runNees(positional[0], positional[1], nees_options, source, options.fps, auto_offset,
                   nees_data_path, json);
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

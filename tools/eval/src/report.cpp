#include "pplvo/eval/report.h"

#include <cmath>
#include <cstdio>
#include <sstream>

namespace pplvo {
namespace eval {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

std::string fixed6(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.6f", v);
  return buf;
}

std::string full(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

std::string jsonString(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      case '\r':
        out += "\\r";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof(buf), "\\u%04x", static_cast<unsigned char>(c));
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

// (key suffix, value) lists shared by the text and JSON writers.
using Fields = std::vector<std::pair<std::string, double>>;

Fields statFields(const ErrorStats& s, const std::string& unit) {
  return {{"rmse_" + unit, s.rmse}, {"mean_" + unit, s.mean}, {"median_" + unit, s.median},
          {"std_" + unit, s.std},   {"min_" + unit, s.min},   {"max_" + unit, s.max}};
}

Fields rpeFields(const EvalReport& r) {
  const double per_s = 1.0 / r.delta_s;
  Fields f;
  for (const auto& kv : statFields(scaled(r.rpe.trans_m, per_s), "m_per_s")) {
    f.emplace_back("trans_" + kv.first, kv.second);
  }
  for (const auto& kv : statFields(scaled(r.rpe.rot_rad, kRadToDeg * per_s), "deg_per_s")) {
    f.emplace_back("rot_" + kv.first, kv.second);
  }
  f.emplace_back("trans_scale", r.rpe.trans_scale);
  return f;
}

std::string describeStamps(double fps) {
  return fps > 0.0 ? "frame indices / " + fixed6(fps) + " fps" : "seconds";
}

}  // namespace

EvalReport evaluateTrajectories(const TumFile& gt, const TumFile& est, const EvalOptions& options) {
  EvalReport report;
  report.gt_name = gt.name;
  report.est_name = est.name;
  report.fps = options.fps;
  report.delta_s = options.rpe.delta_s;
  report.max_difference_s = options.ate.association.max_difference_s;
  report.ate = evaluateAte(gt, est, options.ate);
  report.rpe = evaluateRpe(gt, est, options.rpe);
  if (options.fps <= 0.0) {
    const TumFile* files[2] = {&gt, &est};
    // The same file given twice: say it once.
    const int n_files = (est.name == gt.name) ? 1 : 2;
    for (int k = 0; k < n_files; ++k) {
      const TumFile* f = files[k];
      if (f->all_stamps_integer) {
        report.notes.push_back("hint: all stamps of '" + f->name +
                               "' are integers; if they are frame indices (ICL-NUIM), pass "
                               "--fps 30 so that the RPE delta is in seconds, not frames");
      }
    }
  }
  if (report.ate.skipped_non_finite_gt + report.ate.skipped_non_finite_est > 0) {
    report.notes.push_back("ATE ignored " + std::to_string(report.ate.skipped_non_finite_gt) +
                           " ground-truth and " +
                           std::to_string(report.ate.skipped_non_finite_est) +
                           " estimated rows with a NaN/inf stamp or position");
  }
  if (report.rpe.skipped_rows_gt + report.rpe.skipped_rows_est > 0) {
    report.notes.push_back("RPE ignored " + std::to_string(report.rpe.skipped_rows_gt) +
                           " ground-truth and " + std::to_string(report.rpe.skipped_rows_est) +
                           " estimated rows with an all-zero quaternion or a NaN (as TUM does)");
  }
  if (report.rpe.exceeds_max_pairs) {
    report.notes.push_back("RPE has " + std::to_string(report.rpe.candidate_pairs) +
                           " pairs, more than TUM's max_pairs " +
                           std::to_string(options.rpe.max_pairs) +
                           ": TUM would draw a random subset; all pairs are used here");
  }
  return report;
}

std::string formatText(const EvalReport& r) {
  std::ostringstream out;
  out << "# gt '" << r.gt_name << "' est '" << r.est_name << "', stamps in "
      << describeStamps(r.fps) << ", max_difference " << r.max_difference_s << " s, delta "
      << r.delta_s << " s\n";
  for (const std::string& note : r.notes) out << "# " << note << '\n';
  if (r.ate.ok) {
    out << "ate.pairs " << r.ate.error_m.count << '\n';
    for (const auto& kv : statFields(r.ate.error_m, "m")) {
      out << "ate." << kv.first << ' ' << fixed6(kv.second) << '\n';
    }
  } else {
    out << "ate.error " << r.ate.error << '\n';
  }
  if (r.rpe.ok) {
    out << "rpe.pairs " << r.rpe.pairs.size() << '\n';
    for (const auto& kv : rpeFields(r)) {
      out << "rpe." << kv.first << ' ' << fixed6(kv.second) << '\n';
    }
    out << "rpe.skipped_pairs_gt_time " << r.rpe.skipped_gt_time << '\n';
  } else {
    out << "rpe.error " << r.rpe.error << '\n';
  }
  return out.str();
}

std::string formatJson(const EvalReport& r) {
  std::ostringstream out;
  out << "{\n  \"gt\": " << jsonString(r.gt_name) << ",\n  \"est\": " << jsonString(r.est_name)
      << ",\n  \"fps\": " << full(r.fps)
      << ",\n  \"max_difference_s\": " << full(r.max_difference_s)
      << ",\n  \"delta_s\": " << full(r.delta_s) << ",\n  \"ok\": " << (r.ok() ? "true" : "false")
      << ",\n  \"ate\": {";
  if (r.ate.ok) {
    out << "\"ok\": true, \"pairs\": " << r.ate.error_m.count;
    for (const auto& kv : statFields(r.ate.error_m, "m")) {
      out << ", \"" << kv.first << "\": " << full(kv.second);
    }
  } else {
    out << "\"ok\": false, \"error\": " << jsonString(r.ate.error);
  }
  out << "},\n  \"rpe\": {";
  if (r.rpe.ok) {
    out << "\"ok\": true, \"pairs\": " << r.rpe.pairs.size();
    for (const auto& kv : rpeFields(r)) out << ", \"" << kv.first << "\": " << full(kv.second);
    out << ", \"skipped_pairs_gt_time\": " << r.rpe.skipped_gt_time;
  } else {
    out << "\"ok\": false, \"error\": " << jsonString(r.rpe.error);
  }
  out << "},\n  \"notes\": [";
  for (std::size_t k = 0; k < r.notes.size(); ++k) {
    out << (k ? ", " : "") << jsonString(r.notes[k]);
  }
  out << "]\n}\n";
  return out.str();
}

std::string formatPlotData(const EvalReport& r) {
  std::ostringstream out;
  out << "# ATE: gt_stamp_s est_stamp_s gt_x gt_y gt_z est_aligned_x est_aligned_y "
         "est_aligned_z error_m\n";
  for (const AtePair& p : r.ate.pairs) {
    out << full(p.gt_stamp_s) << ' ' << full(p.est_stamp_s);
    for (int k = 0; k < 3; ++k) out << ' ' << full(p.p_gt_m[k]);
    for (int k = 0; k < 3; ++k) out << ' ' << full(p.p_est_aligned_m[k]);
    out << ' ' << full(p.error_m) << '\n';
  }
  out << "\n\n# RPE: est0_s est1_s gt0_s gt1_s trans_m rot_deg (per delta " << r.delta_s << " s)\n";
  for (const RpePair& p : r.rpe.pairs) {
    out << full(p.est0_s) << ' ' << full(p.est1_s) << ' ' << full(p.gt0_s) << ' ' << full(p.gt1_s)
        << ' ' << full(p.trans_m) << ' ' << full(p.rot_rad * kRadToDeg) << '\n';
  }
  return out.str();
}

}  // namespace eval
}  // namespace pplvo

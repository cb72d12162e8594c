#pragma once
/// Running ATE and RPE together and formatting the figures (text, JSON, plot data).
/// Formatting returns strings: the caller does the I/O.
#include <string>
#include <vector>

#include "pplvo/eval/ate.h"
#include "pplvo/eval/rpe.h"
#include "pplvo/eval/tum_file.h"

namespace pplvo {
namespace eval {

struct EvalOptions {
  double fps = 0.0;  ///< as given to the reader (0: stamps in seconds); only used for notes
  AteOptions ate;
  RpeOptions rpe;
};

struct EvalReport {
  std::string gt_name, est_name;
  double fps = 0.0;
  double delta_s = 1.0;
  double max_difference_s = 0.02;
  AteResult ate;
  RpeResult rpe;
  std::vector<std::string> notes;  ///< hints and warnings for the reader, one line each
  bool ok() const { return ate.ok && rpe.ok; }
};

/// Runs evaluateAte and evaluateRpe and collects notes (integer stamps without fps, skipped
/// rows, more pairs than TUM's max_pairs).
EvalReport evaluateTrajectories(const TumFile& gt, const TumFile& est,
                                const EvalOptions& options = {});

/// `key value` lines (ate.rmse_m, ate.pairs, rpe.trans_rmse_m_per_s, rpe.rot_rmse_deg_per_s,
/// rpe.pairs, ...); notes as lines starting with '#'; failed parts as `ate.error ...`.
/// RPE figures per second are TUM's per-delta figures divided by delta_s.
std::string formatText(const EvalReport& report);
/// The same figures as one JSON object.
std::string formatJson(const EvalReport& report);
/// Per-pair data for plotting: ATE lines `gt_stamp est_stamp gx gy gz ex ey ez error_m` and
/// RPE lines `est0 est1 gt0 gt1 trans_m rot_deg`, in two blocks with '#' headers.
std::string formatPlotData(const EvalReport& report);

}  // namespace eval
}  // namespace pplvo

#include "pplvo/geometry/plane_matching.h"

#include <algorithm>
#include <cmath>

namespace pplvo::geometry {

PlaneMatchResult matchPlanesWithStats(const FrameFeatures& prev, const FrameFeatures& curr,
                                      const PlaneMatchOptions& options,
                                      const std::optional<Pose3>& T_curr_prev) {
  PlaneMatchResult res;
  PlaneMatchStats& st = res.stats;
  const int np = static_cast<int>(prev.planes.size()), nc = static_cast<int>(curr.planes.size());
  st.n_prev = np;
  st.n_curr = nc;
  if (np == 0 || nc == 0) return res;
  const cv::Mat& Lp = prev.plane_labels;
  const cv::Mat& Lc = curr.plane_labels;
  if (Lp.empty() || Lc.empty() || Lp.type() != CV_8UC1 || Lc.type() != CV_8UC1 ||
      Lp.size() != Lc.size()) {
    st.error = "plane label images missing, not CV_8UC1 or of different sizes";
    return res;
  }
  // Label -> plane index.
  std::vector<int> idx_p(256, -1), idx_c(256, -1);
  for (int i = 0; i < np; ++i)
    if (prev.planes[i].label > 0 && prev.planes[i].label < 256) idx_p[prev.planes[i].label] = i;
  for (int i = 0; i < nc; ++i)
    if (curr.planes[i].label > 0 && curr.planes[i].label < 256) idx_c[curr.planes[i].label] = i;

  // Co-occurrence of labels and per-plane pixel counts on the same grid: O(pixels).
  const int step = std::max(1, options.grid_step_px);
  std::vector<int> overlap(static_cast<size_t>(np) * nc, 0), cnt_p(np, 0), cnt_c(nc, 0);
  for (int v = 0; v < Lp.rows; v += step) {
    const uint8_t* a = Lp.ptr<uint8_t>(v);
    const uint8_t* b = Lc.ptr<uint8_t>(v);
    for (int u = 0; u < Lp.cols; u += step) {
      const int ip = a[u] ? idx_p[a[u]] : -1, ic = b[u] ? idx_c[b[u]] : -1;
      if (ip >= 0) ++cnt_p[ip];
      if (ic >= 0) ++cnt_c[ic];
      if (ip >= 0 && ic >= 0) ++overlap[static_cast<size_t>(ip) * nc + ic];
    }
  }
  const double cos_max = std::cos(options.max_normal_angle_deg * M_PI / 180.0);
  struct Cand {
    double dist;
    int p, c;
  };
  std::vector<Cand> cands;
  for (int i = 0; i < np; ++i) {
    const PlaneWithCov pl =
        T_curr_prev ? prev.planes[i].plane.transformed(*T_curr_prev) : prev.planes[i].plane;
    for (int j = 0; j < nc; ++j) {
      const int ov = overlap[static_cast<size_t>(i) * nc + j];
      const int smaller = std::min(cnt_p[i], cnt_c[j]);
      if (smaller <= 0 || ov < options.min_overlap_fraction * smaller) continue;
      ++st.n_overlap_pairs;
      const PlaneWithCov& pc = curr.planes[j].plane;
      if (pl.normal().dot(pc.normal()) < cos_max) continue;
      if (std::abs(pl.d() - pc.d()) > options.max_d_diff_m) continue;
      ++st.n_candidates;
      // Eq. 17: ||C - C'|| = ||d' N' - d N||.
      const double dist = (pc.d() * pc.normal() - pl.d() * pl.normal()).norm();
      cands.push_back({dist, i, j});
    }
  }
  // One-to-one: accept candidates by increasing eq. 18 distance.
  std::stable_sort(cands.begin(), cands.end(),
                   [](const Cand& a, const Cand& b) { return a.dist < b.dist; });
  std::vector<char> used_p(np, 0), used_c(nc, 0);
  for (const Cand& c : cands) {
    if (used_p[c.p] || used_c[c.c]) continue;
    used_p[c.p] = used_c[c.c] = 1;
    res.matches.emplace_back(c.p, c.c);
    res.distances_m.push_back(c.dist);
  }
  st.n_matches = static_cast<int>(res.matches.size());
  return res;
}

std::vector<std::pair<int, int>> matchPlanes(const FrameFeatures& prev, const FrameFeatures& curr,
                                             const PlaneMatchOptions& options) {
  return matchPlanesWithStats(prev, curr, options).matches;
}

}  // namespace pplvo::geometry

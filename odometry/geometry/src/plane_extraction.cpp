#include "pplvo/geometry/plane_extraction.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "pplvo/core/parallel.h"
#include "pplvo/geometry/lifting.h"  // validateDepth

namespace pplvo::geometry {

void PlaneExtractor::Moments::add(const Moments& o) {
  n += o.n;
  sx += o.sx;
  sy += o.sy;
  sz += o.sz;
  sxx += o.sxx;
  syy += o.syy;
  szz += o.szz;
  sxy += o.sxy;
  sxz += o.sxz;
  syz += o.syz;
}

bool PlaneExtractor::fitMoments(const Moments& m, CellPlane* out) {
  if (m.n < 3) return false;
  const double inv = 1.0 / m.n;
  const Eigen::Vector3d mean(m.sx * inv, m.sy * inv, m.sz * inv);
  Eigen::Matrix3d C;
  C(0, 0) = m.sxx * inv - mean.x() * mean.x();
  C(1, 1) = m.syy * inv - mean.y() * mean.y();
  C(2, 2) = m.szz * inv - mean.z() * mean.z();
  C(0, 1) = C(1, 0) = m.sxy * inv - mean.x() * mean.y();
  C(0, 2) = C(2, 0) = m.sxz * inv - mean.x() * mean.z();
  C(1, 2) = C(2, 1) = m.syz * inv - mean.y() * mean.z();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(C);
  Eigen::Vector3d n = es.eigenvectors().col(0);
  if (!n.allFinite()) return false;
  double d = -n.dot(mean);
  if (d < 0) {  // orient towards the camera: n.p + d = 0 with d > 0
    n = -n;
    d = -d;
  }
  out->normal = n;
  out->mean = mean;
  out->d = d;
  out->mse = std::max(0.0, es.eigenvalues()(0));
  return true;
}

PlaneExtractor::PlaneExtractor(const PinholeCamera& camera, const PlaneExtractionOptions& options)
    : camera_(camera), options_(options) {
  options_.cell_size_px = std::max(2, options_.cell_size_px);
  options_.histogram_bins = std::max(2, options_.histogram_bins);
  options_.max_planes = std::clamp(options_.max_planes, 1, 254);
  const int cs = options_.cell_size_px;
  cells_x_ = (std::max(0, camera_.width) + cs - 1) / cs;
  cells_y_ = (std::max(0, camera_.height) + cs - 1) / cs;
  x_factor_.resize(std::max(0, camera_.width));
  y_factor_.resize(std::max(0, camera_.height));
  cell_of_col_.resize(std::max(0, camera_.width));
  ray_x_.resize(x_factor_.size());
  ray_y_.resize(y_factor_.size());
  for (int u = 0; u < camera_.width; ++u) {
    x_factor_[u] = static_cast<float>((u - camera_.cx) / camera_.fx);
    ray_x_[u] = (static_cast<double>(u) - camera_.cx) / camera_.fx;
    cell_of_col_[u] = u / cs;
  }
  for (int v = 0; v < camera_.height; ++v) {
    y_factor_[v] = static_cast<float>((v - camera_.cy) / camera_.fy);
    ray_y_[v] = (static_cast<double>(v) - camera_.cy) / camera_.fy;
  }
  const size_t nc = static_cast<size_t>(cells_x_) * cells_y_;
  cell_moments_.resize(nc);
  cell_planes_.resize(nc);
  planar_.resize(nc);
  cell_segment_.resize(nc);
  cell_bin_.resize(nc);
  queue_.reserve(nc);
  bin_count_.resize(2 * options_.histogram_bins * options_.histogram_bins);
}

namespace {

/// Fixed bands of cell rows (independent of the thread count, so sums keep one order).
constexpr int kBands = 4;
/// At most (2R+1)^2 candidate planes per cell, R <= 2.
constexpr int kMaxCandidates = 25;

/// Pixel rectangle [u0, u1) x [v0, v1) of cell (cx, cy), clipped to the image.
struct CellRect {
  int u0, v0, u1, v1;
};

CellRect cellRect(int cx, int cy, int cs, int W, int H) {
  const int u0 = cx * cs, v0 = cy * cs;
  return {u0, v0, std::min(W, u0 + cs), std::min(H, v0 + cs)};
}

/// visit(label, px, py, z, thr) for every valid pixel of the cell, row-major, with
/// thr = k_sigma z^2 + margin.
template <typename Visit>
void forEachCellPoint(const cv::Mat& depth_m, cv::Mat& labels, const CellRect& r,
                      const std::vector<float>& x_factor, const std::vector<float>& y_factor,
                      double k_sigma, double margin, Visit&& visit) {
  for (int v = r.v0; v < r.v1; ++v) {
    const float* zr = depth_m.ptr<float>(v);
    uint8_t* lr = labels.ptr<uint8_t>(v);
    const double yf = y_factor[v];
    for (int u = r.u0; u < r.u1; ++u) {
      const double z = zr[u];
      if (!(z > 0.0) || !std::isfinite(z)) continue;
      visit(lr[u], x_factor[u] * z, yf * z, z, k_sigma * z * z + margin);
    }
  }
}

}  // namespace

struct PlaneExtractor::Segment {
  Moments m;
  CellPlane plane;
  bool alive = true;
};

struct PlaneExtractor::CellCandidates {
  int segment[kMaxCandidates];
  int n = 0;
  int own_slot = -1;  ///< slot of the cell's own segment, -1 if none
  bool interior = false;
};

struct PlaneExtractor::CellSums {
  int count[kMaxCandidates] = {0};
  double sum[kMaxCandidates][3] = {{0}};
};

struct PlaneExtractor::LabelStats {
  std::vector<int> count, umin, umax, vmin, vmax;
  std::vector<Eigen::Vector3d> sum;
  LabelStats(int np, int W, int H)
      : count(np, 0),
        umin(np, W),
        umax(np, -1),
        vmin(np, H),
        vmax(np, -1),
        sum(np, Eigen::Vector3d::Zero()) {}
};

PlaneExtractionResult PlaneExtractor::extract(const DepthWithVariance& depth) {
  PlaneExtractionResult res;
  PlaneExtractionStats& st = res.stats;
  st.error = validateDepth(depth, camera_);
  if (!st.error.empty()) {
    if (!depth.depth_m.empty()) res.labels = cv::Mat::zeros(depth.depth_m.size(), CV_8UC1);
    return res;
  }
  st.n_cells = cells_x_ * cells_y_;
  res.labels = cv::Mat::zeros(camera_.height, camera_.width, CV_8UC1);

  accumulateCellMoments(depth.depth_m);
  classifyCells(depth.depth_m, &st);
  std::vector<Segment> segs = growRegions(&st);
  const std::vector<CellPlane> planes = mergeSegments(segs, &st);
  const int np = std::min(static_cast<int>(planes.size()), 253);
  const LabelStats labelled = labelPixels(depth.depth_m, planes, np, res.labels);
  fitSegments(depth, labelled, np, &res);
  return res;
}

void PlaneExtractor::bandCellRows(int band, int* c0, int* c1) const {
  *c0 = band * cells_y_ / kBands;
  *c1 = (band + 1) * cells_y_ / kBands;
}

// 1) Per-cell moments of the backprojected points (one pass over the image).
void PlaneExtractor::accumulateCellMoments(const cv::Mat& depth_m) {
  const int W = camera_.width, H = camera_.height, cs = options_.cell_size_px;
  std::fill(cell_moments_.begin(), cell_moments_.end(), Moments{});
  // Each row's run of cs pixels is summed in registers (with y = yf z, so only x z, z and their
  // squares need per-pixel sums), then added to its cell once.
  constexpr float kInf = std::numeric_limits<float>::infinity();
  forEachTask(kBands, std::max(1, options_.threads), [&](int band) {
    int c0, c1;
    bandCellRows(band, &c0, &c1);
    for (int v = c0 * cs; v < std::min(H, c1 * cs); ++v) {
      const float* zr = depth_m.ptr<float>(v);
      const double yf = y_factor_[v];
      Moments* row_cells = &cell_moments_[static_cast<size_t>(v / cs) * cells_x_];
      for (int cx = 0; cx < cells_x_; ++cx) {
        const int u0 = cx * cs, u1 = std::min(W, u0 + cs);
        double n = 0, sx = 0, sz = 0, sxx = 0, szz = 0, sxz = 0;
        for (int u = u0; u < u1; ++u) {
          const float zf = zr[u];
          const bool ok = zf > 0.0f && zf < kInf;  // false for NaN
          const double z = ok ? zf : 0.0;
          const double x = static_cast<double>(x_factor_[u]) * z;
          n += ok ? 1.0 : 0.0;
          sx += x;
          sz += z;
          sxx += x * x;
          szz += z * z;
          sxz += x * z;
        }
        if (n == 0) continue;
        Moments& m = row_cells[cx];
        m.n += n;
        m.sx += sx;
        m.sy += yf * sz;
        m.sz += sz;
        m.sxx += sxx;
        m.syy += yf * yf * szz;
        m.szz += szz;
        m.sxy += yf * sxz;
        m.sxz += sxz;
        m.syz += yf * szz;
      }
    }
  });
}

bool PlaneExtractor::cellIsContinuous(const cv::Mat& depth_m, int cx, int cy) const {
  const double jump_k = options_.jump_sigma_factor, jump_m = options_.jump_margin_m;
  const CellRect r = cellRect(cx, cy, options_.cell_size_px, camera_.width, camera_.height);
  const int vm = (r.v0 + r.v1) / 2, um = (r.u0 + r.u1) / 2;
  const float* zr = depth_m.ptr<float>(vm);
  float prev = 0;
  for (int u = r.u0; u < r.u1; ++u) {
    const float z = zr[u];
    if (!(z > 0)) continue;
    if (prev > 0 && std::abs(z - prev) > jump_k * sigmaZ(z) + jump_m) return false;
    prev = z;
  }
  prev = 0;
  for (int v = r.v0; v < r.v1; ++v) {
    const float z = depth_m.at<float>(v, um);
    if (!(z > 0)) continue;
    if (prev > 0 && std::abs(z - prev) > jump_k * sigmaZ(z) + jump_m) return false;
    prev = z;
  }
  return true;
}

// 2) Planarity test per cell; planar cells enter the histogram of normals.
void PlaneExtractor::classifyCells(const cv::Mat& depth_m, PlaneExtractionStats* stats) {
  const int W = camera_.width, H = camera_.height, cs = options_.cell_size_px;
  const int B = options_.histogram_bins;
  std::fill(bin_count_.begin(), bin_count_.end(), 0);
  for (int cy = 0; cy < cells_y_; ++cy) {
    for (int cx = 0; cx < cells_x_; ++cx) {
      const int c = cy * cells_x_ + cx;
      planar_[c] = 0;
      cell_segment_[c] = -1;
      cell_bin_[c] = -1;
      const int area =
          (std::min(W, (cx + 1) * cs) - cx * cs) * (std::min(H, (cy + 1) * cs) - cy * cs);
      const Moments& m = cell_moments_[c];
      if (m.n < std::max(3.0, options_.min_valid_fraction * area)) continue;
      CellPlane& p = cell_planes_[c];
      if (!fitMoments(m, &p)) continue;
      const double thr =
          options_.planarity_sigma_factor * sigmaZ(p.mean.z()) + options_.planarity_margin_m;
      if (p.mse > thr * thr) continue;
      if (!cellIsContinuous(depth_m, cx, cy)) continue;
      planar_[c] = 1;
      ++stats->n_planar_cells;
      const int bx = std::clamp(static_cast<int>((p.normal.x() + 1.0) * 0.5 * B), 0, B - 1);
      const int by = std::clamp(static_cast<int>((p.normal.y() + 1.0) * 0.5 * B), 0, B - 1);
      const int bin = (p.normal.z() > 0 ? B * B : 0) + by * B + bx;
      cell_bin_[c] = bin;
      ++bin_count_[bin];
    }
  }
}

void PlaneExtractor::growRegion(int seed, int sid, std::vector<int>* region) {
  const double cos_grow = std::cos(options_.grow_max_angle_deg * M_PI / 180.0);
  const CellPlane sp = cell_planes_[seed];
  region->clear();
  queue_.clear();
  queue_.push_back(seed);
  cell_segment_[seed] = sid;
  for (size_t qi = 0; qi < queue_.size(); ++qi) {
    const int c = queue_[qi];
    region->push_back(c);
    const int cx = c % cells_x_, cy = c / cells_x_;
    const int nb[4][2] = {{cx - 1, cy}, {cx + 1, cy}, {cx, cy - 1}, {cx, cy + 1}};
    for (const auto& q : nb) {
      if (q[0] < 0 || q[1] < 0 || q[0] >= cells_x_ || q[1] >= cells_y_) continue;
      const int n = q[1] * cells_x_ + q[0];
      if (!planar_[n] || cell_segment_[n] >= 0) continue;
      const CellPlane& np = cell_planes_[n];
      if (np.normal.dot(sp.normal) < cos_grow) continue;
      const double dist = std::abs(sp.normal.dot(np.mean) + sp.d);
      if (dist >
          options_.grow_dist_sigma_factor * sigmaZ(np.mean.z()) + options_.grow_dist_margin_m)
        continue;
      cell_segment_[n] = sid;
      queue_.push_back(n);
    }
  }
}

// 3) Seeds from the histogram of normals, region growing over 4-neighbour planar cells.
std::vector<PlaneExtractor::Segment> PlaneExtractor::growRegions(PlaneExtractionStats* stats) {
  const int ncells = cells_x_ * cells_y_;
  std::vector<Segment> segs;
  std::vector<int> region;
  while (true) {
    const auto it = std::max_element(bin_count_.begin(), bin_count_.end());
    if (*it < std::max(1, options_.min_seed_bin_count)) break;
    const int bin = static_cast<int>(it - bin_count_.begin());
    int seed = -1;
    for (int c = 0; c < ncells; ++c) {
      if (cell_bin_[c] == bin && cell_segment_[c] < 0 &&
          (seed < 0 || cell_planes_[c].mse < cell_planes_[seed].mse))
        seed = c;
    }
    if (seed < 0) {  // cannot happen: counts track unassigned cells of the bin
      bin_count_[bin] = 0;
      continue;
    }
    growRegion(seed, static_cast<int>(segs.size()), &region);
    ++stats->n_regions_grown;
    for (int c : region) {
      if (cell_bin_[c] >= 0) --bin_count_[cell_bin_[c]];
      cell_bin_[c] = -1;  // out of the histogram for good
    }
    int cx_min = cells_x_, cx_max = -1, cy_min = cells_y_, cy_max = -1;
    for (int c : region) {
      cx_min = std::min(cx_min, c % cells_x_);
      cx_max = std::max(cx_max, c % cells_x_);
      cy_min = std::min(cy_min, c / cells_x_);
      cy_max = std::max(cy_max, c / cells_x_);
    }
    const bool strip =
        std::min(cx_max - cx_min, cy_max - cy_min) + 1 < options_.min_region_span_cells;
    if (static_cast<int>(region.size()) < options_.min_region_cells || strip) {
      ++stats->n_regions_too_small;
      for (int c : region) cell_segment_[c] = -1;  // may still join a later region
      continue;
    }
    Segment s;
    for (int c : region) s.m.add(cell_moments_[c]);
    fitMoments(s.m, &s.plane);
    segs.push_back(s);
  }
  return segs;
}

// 4) Merge adjacent segments with similar planes (O(1) moment addition), until stable; then
// compact the surviving segments and drop curved ones.
std::vector<PlaneExtractor::CellPlane> PlaneExtractor::mergeSegments(std::vector<Segment>& segs,
                                                                     PlaneExtractionStats* stats) {
  const int ncells = cells_x_ * cells_y_;
  const int nseg = static_cast<int>(segs.size());
  std::vector<int> parent(nseg);
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  const double cos_merge = std::cos(options_.merge_max_angle_deg * M_PI / 180.0);
  for (bool changed = true; changed;) {
    changed = false;
    for (int cy = 0; cy < cells_y_; ++cy) {
      for (int cx = 0; cx < cells_x_; ++cx) {
        const int c = cy * cells_x_ + cx;
        if (cell_segment_[c] < 0) continue;
        const int nbs[2] = {cx + 1 < cells_x_ ? c + 1 : -1, cy + 1 < cells_y_ ? c + cells_x_ : -1};
        for (int n : nbs) {
          if (n < 0 || cell_segment_[n] < 0) continue;
          const int a = root(cell_segment_[c]), b = root(cell_segment_[n]);
          if (a == b) continue;
          const CellPlane& pa = segs[a].plane;
          const CellPlane& pb = segs[b].plane;
          if (pa.normal.dot(pb.normal) < cos_merge) continue;
          if (std::abs(pa.normal.dot(pb.mean) + pa.d) > options_.merge_max_dist_m) continue;
          if (std::abs(pb.normal.dot(pa.mean) + pb.d) > options_.merge_max_dist_m) continue;
          segs[a].m.add(segs[b].m);
          fitMoments(segs[a].m, &segs[a].plane);
          segs[b].alive = false;
          parent[b] = a;
          ++stats->n_merges;
          changed = true;
        }
      }
    }
  }
  std::vector<int> compact(nseg, -1);
  std::vector<CellPlane> planes;
  for (int i = 0; i < nseg; ++i) {
    if (!segs[i].alive) continue;
    const CellPlane& p = segs[i].plane;
    const double thr =
        options_.segment_sigma_factor * sigmaZ(p.mean.z()) + options_.segment_margin_m;
    if (p.mse > thr * thr) {
      ++stats->n_segments_not_planar;
      continue;
    }
    compact[i] = static_cast<int>(planes.size());
    planes.push_back(p);
  }
  stats->n_segments = static_cast<int>(planes.size());
  for (int c = 0; c < ncells; ++c) {
    if (cell_segment_[c] >= 0) cell_segment_[c] = compact[root(cell_segment_[c])];
  }
  return planes;
}

// 5) Pixel labels: a pixel of an interior cell (whole neighbourhood in one segment) stays with
// it if within k sigma_z(z) + margin of its plane; in other cells it joins the nearest plane
// among the segments of the (2R+1)^2 cell neighbourhood if it is within k sigma_z(z) + margin
// (cells far from any segment are skipped). Without refinement, the valid pixels of each segment
// cell are labelled.
// Per band of cell rows: labels of its own pixels, and plane statistics merged in band order.
PlaneExtractor::LabelStats PlaneExtractor::labelPixels(const cv::Mat& depth_m,
                                                       const std::vector<CellPlane>& planes, int np,
                                                       cv::Mat& labels) const {
  const int W = camera_.width, H = camera_.height;
  std::vector<LabelStats> band_stats(kBands, LabelStats(np, W, H));
  forEachTask(kBands, std::max(1, options_.threads), [&](int band) {
    int c0, c1;
    bandCellRows(band, &c0, &c1);
    for (int cy = c0; cy < c1; ++cy) {
      for (int cx = 0; cx < cells_x_; ++cx) {
        CellCandidates cand;
        if (!cellCandidates(cx, cy, np, &cand)) continue;
        labelCell(depth_m, cx, cy, cand, planes, labels, &band_stats[band]);
      }
    }
  });
  LabelStats all(np, W, H);
  for (const LabelStats& bs : band_stats) {
    for (int b = 0; b < np; ++b) {
      all.count[b] += bs.count[b];
      all.sum[b] += bs.sum[b];
      all.umin[b] = std::min(all.umin[b], bs.umin[b]);
      all.umax[b] = std::max(all.umax[b], bs.umax[b]);
      all.vmin[b] = std::min(all.vmin[b], bs.vmin[b]);
      all.vmax[b] = std::max(all.vmax[b], bs.vmax[b]);
    }
  }
  return all;
}

// The candidate planes of cell (cx, cy): the segments (below np) of its (2R+1)^2
// neighbourhood; interior when the whole neighbourhood is its own segment. false: nothing to
// label in this cell.
bool PlaneExtractor::cellCandidates(int cx, int cy, int np, CellCandidates* out) const {
  const int own = cell_segment_[cy * cells_x_ + cx];
  int* cand = out->segment;
  int& ncand = out->n;
  bool interior = own >= 0;
  const int R = std::clamp(options_.refine_neighbourhood_cells, 1, 2);
  for (int dy = -R; dy <= R; ++dy) {
    for (int dx = -R; dx <= R; ++dx) {
      const int qx = cx + dx, qy = cy + dy;
      if (qx < 0 || qy < 0 || qx >= cells_x_ || qy >= cells_y_) continue;
      const int s = cell_segment_[qy * cells_x_ + qx];
      if (s != own) interior = false;
      if (s >= 0 && s < np && std::find(cand, cand + ncand, s) == cand + ncand) cand[ncand++] = s;
    }
  }
  if (ncand == 0) return false;
  if (own >= np) interior = false;    // beyond the label range
  if (!options_.refine_boundaries) {  // cell-level labels only
    if (own < 0 || own >= np) return false;
    interior = true;
  }
  for (int k = 0; k < ncand; ++k)
    if (cand[k] == own) out->own_slot = k;
  out->interior = interior;
  return !(interior && out->own_slot < 0);
}

// Labels the pixels of one cell and adds their counts, sums and the cell's box to `bs`.
void PlaneExtractor::labelCell(const cv::Mat& depth_m, int cx, int cy, const CellCandidates& cand,
                               const std::vector<CellPlane>& planes, cv::Mat& labels,
                               LabelStats* bs) const {
  const CellRect r = cellRect(cx, cy, options_.cell_size_px, camera_.width, camera_.height);
  const int ncand = cand.n;
  // Per-cell accumulators indexed by candidate slot; merged into the planes once per cell.
  CellSums local;
  // Plane coefficients as plain arrays for the inner loop.
  double pn[kMaxCandidates][4];
  for (int k = 0; k < ncand; ++k) {
    const CellPlane& p = planes[cand.segment[k]];
    pn[k][0] = p.normal.x();
    pn[k][1] = p.normal.y();
    pn[k][2] = p.normal.z();
    pn[k][3] = p.d;
  }
  const double k_sigma = options_.refine_sigma_factor * options_.noise.sigma_z_coeff_per_m;
  const double margin = options_.refine_margin_m;
  const bool test_interior = options_.refine_boundaries;
  if (cand.interior) {
    // One plane: the sums stay in registers (same order of additions as per slot below).
    const int slot = cand.own_slot;
    const double* q = pn[slot];
    const uint8_t label = static_cast<uint8_t>(cand.segment[slot] + 1);
    int n_in = 0;
    double sx = 0, sy = 0, sz = 0;
    forEachCellPoint(
        depth_m, labels, r, x_factor_, y_factor_, k_sigma, margin,
        [&](uint8_t& l, double px, double py, double z, double thr) {
          if (test_interior && !(std::abs(q[0] * px + q[1] * py + q[2] * z + q[3]) < thr)) return;
          l = label;
          ++n_in;
          sx += px;
          sy += py;
          sz += z;
        });
    local.count[slot] = n_in;
    local.sum[slot][0] = sx;
    local.sum[slot][1] = sy;
    local.sum[slot][2] = sz;
  } else {  // a boundary cell: each pixel joins the nearest candidate plane
    forEachCellPoint(depth_m, labels, r, x_factor_, y_factor_, k_sigma, margin,
                     [&](uint8_t& l, double px, double py, double z, double thr) {
                       double best_dist = thr;
                       int slot = -1;
                       for (int k = 0; k < ncand; ++k) {
                         const double dist =
                             std::abs(pn[k][0] * px + pn[k][1] * py + pn[k][2] * z + pn[k][3]);
                         if (dist < best_dist) {
                           best_dist = dist;
                           slot = k;
                         }
                       }
                       if (slot < 0) return;
                       l = static_cast<uint8_t>(cand.segment[slot] + 1);
                       ++local.count[slot];
                       local.sum[slot][0] += px;
                       local.sum[slot][1] += py;
                       local.sum[slot][2] += z;
                     });
  }
  for (int k = 0; k < ncand; ++k) {
    if (local.count[k] == 0) continue;
    const int b = cand.segment[k];
    bs->count[b] += local.count[k];
    bs->sum[b] += Eigen::Vector3d(local.sum[k][0], local.sum[k][1], local.sum[k][2]);
    bs->umin[b] = std::min(bs->umin[b], r.u0);  // bounding box at cell granularity
    bs->umax[b] = std::max(bs->umax[b], r.u1 - 1);
    bs->vmin[b] = std::min(bs->vmin[b], r.v0);
    bs->vmax[b] = std::max(bs->vmax[b], r.v1 - 1);
  }
}

// WLS fit of segment i on a regular subsample of its pixels.
PlaneFitResult PlaneExtractor::fitSegment(const DepthWithVariance& depth, const cv::Mat& labels,
                                          const LabelStats& ls, int i,
                                          FitSamples* samples) const {
  const DepthNoiseModel& noise = options_.noise;
  const int step =
      std::max(1, static_cast<int>(std::floor(std::sqrt(static_cast<double>(ls.count[i]) /
                                                        std::max(1, options_.max_fit_points)))));
  std::vector<Eigen::Vector3d>& P = samples->points;
  std::vector<Eigen::Matrix3d>& C = samples->covs;
  std::vector<double>& V = samples->var_z;
  P.clear();
  C.clear();
  V.clear();
  // depthAt() with its per-pixel checks hoisted: the grid lies inside the image (the labels'
  // box) and the variance map is usable or not for the whole image.
  const bool has_var = !depth.var_m2.empty() && depth.var_m2.size() == depth.depth_m.size();
  const double floor2 = noise.sigma_z_floor_m * noise.sigma_z_floor_m;
  const uint8_t label = static_cast<uint8_t>(i + 1);
  // Grid anchored at multiples of the step (independent of the bounding box).
  for (int v = (ls.vmin[i] + step - 1) / step * step; v <= ls.vmax[i]; v += step) {
    const uint8_t* lr = labels.ptr<uint8_t>(v);
    const float* zr = depth.depth_m.ptr<float>(v);
    const float* vr = has_var ? depth.var_m2.ptr<float>(v) : nullptr;
    for (int u = (ls.umin[i] + step - 1) / step * step; u <= ls.umax[i]; u += step) {
      if (lr[u] != label) continue;
      const float zf = zr[u];
      if (!(zf > 0.0f) || !std::isfinite(zf)) continue;
      double var = has_var ? static_cast<double>(vr[u]) : 0.0;
      if (!(var > 0.0) || !std::isfinite(var)) var = noise.varianceZ(zf);
      var = std::max(var, floor2);
      const double z = zf;
      const Point3WithCov pt = backprojectRayWithCov(camera_, ray_x_[u], ray_y_[v], z, var,
                                                     options_.pixel_variance_px2);
      P.push_back(pt.p);
      C.push_back(pt.cov);
      V.push_back(var);
    }
  }
  return fitPlaneWls(P, C, V, options_.fit);
}

// 6) WLS fit (eqs. 11-12) on a regular subsample of each segment's pixels; order by size.
void PlaneExtractor::fitSegments(const DepthWithVariance& depth, const LabelStats& ls, int np,
                                 PlaneExtractionResult* res) {
  PlaneExtractionStats& st = res->stats;
  std::vector<int> order;
  for (int i = 0; i < np; ++i) {
    if (ls.count[i] >= options_.min_plane_points)
      order.push_back(i);
    else
      ++st.n_too_few_points;
  }
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return ls.count[a] > ls.count[b]; });
  // The fits are independent: all candidates in parallel, then kept in size order.
  std::vector<PlaneFitResult> fits(order.size());
  const int n_fits = static_cast<int>(order.size());
  if (fit_samples_.size() < order.size()) fit_samples_.resize(order.size());
  forEachTask(n_fits, std::max(1, options_.threads), [&](int k) {
    fits[k] = fitSegment(depth, res->labels, ls, order[k], &fit_samples_[static_cast<size_t>(k)]);
  });
  std::vector<uint8_t> lut(256, 0);
  for (int k = 0; k < n_fits; ++k) {
    if (static_cast<int>(res->planes.size()) >= options_.max_planes) break;
    const int i = order[k];
    const PlaneFitResult& fit = fits[k];
    if (!fit.ok()) {
      ++st.n_fit_rejected;
      continue;
    }
    PlaneFeature f;
    f.plane = fit.plane;
    f.n_points = ls.count[i];
    f.centroid = ls.sum[i] / ls.count[i];
    f.label = static_cast<int>(res->planes.size()) + 1;
    lut[i + 1] = static_cast<uint8_t>(f.label);
    res->planes.push_back(f);
  }
  cv::LUT(res->labels, cv::Mat(1, 256, CV_8U, lut.data()), res->labels);
  st.n_planes = static_cast<int>(res->planes.size());
}

PlaneExtractionStats extractPlanes(FrameFeatures& frame, const DepthWithVariance& depth,
                                   const PlaneExtractionOptions& options) {
  PlaneExtractor ex(frame.camera, options);
  PlaneExtractionResult r = ex.extract(depth);
  frame.planes = std::move(r.planes);
  frame.plane_labels = r.labels;
  return r.stats;
}

}  // namespace pplvo::geometry

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
  for (int u = 0; u < camera_.width; ++u) {
    x_factor_[u] = static_cast<float>((u - camera_.cx) / camera_.fx);
    cell_of_col_[u] = u / cs;
  }
  for (int v = 0; v < camera_.height; ++v)
    y_factor_[v] = static_cast<float>((v - camera_.cy) / camera_.fy);
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

}  // namespace

PlaneExtractionResult PlaneExtractor::extract(const DepthWithVariance& depth) {
  PlaneExtractionResult res;
  PlaneExtractionStats& st = res.stats;
  st.error = validateDepth(depth, camera_);
  if (!st.error.empty()) {
    if (!depth.depth_m.empty()) res.labels = cv::Mat::zeros(depth.depth_m.size(), CV_8UC1);
    return res;
  }
  const int W = camera_.width, H = camera_.height, cs = options_.cell_size_px;
  const int ncells = cells_x_ * cells_y_;
  st.n_cells = ncells;
  res.labels = cv::Mat::zeros(H, W, CV_8UC1);

  // 1) Per-cell moments of the backprojected points (one pass over the image).
  std::fill(cell_moments_.begin(), cell_moments_.end(), Moments{});
  // Each row's run of cs pixels is summed in registers (with y = yf z, so only x z, z and their
  // squares need per-pixel sums), then added to its cell once.
  constexpr float kInf = std::numeric_limits<float>::infinity();
  const int threads = std::max(1, options_.threads);
  auto bandRows = [&](int band, int* c0, int* c1) {  // cell rows [c0, c1) of a band
    *c0 = band * cells_y_ / kBands;
    *c1 = (band + 1) * cells_y_ / kBands;
  };
  forEachTask(kBands, threads, [&](int band) {
    int c0, c1;
    bandRows(band, &c0, &c1);
    for (int v = c0 * cs; v < std::min(H, c1 * cs); ++v) {
      const float* zr = depth.depth_m.ptr<float>(v);
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

  // 2) Planarity test per cell.
  const double jump_k = options_.jump_sigma_factor, jump_m = options_.jump_margin_m;
  auto continuous = [&](int cx, int cy) {
    const int u0 = cx * cs, v0 = cy * cs, u1 = std::min(W, u0 + cs), v1 = std::min(H, v0 + cs);
    const int vm = (v0 + v1) / 2, um = (u0 + u1) / 2;
    const float* zr = depth.depth_m.ptr<float>(vm);
    float prev = 0;
    for (int u = u0; u < u1; ++u) {
      const float z = zr[u];
      if (!(z > 0)) continue;
      if (prev > 0 && std::abs(z - prev) > jump_k * sigmaZ(z) + jump_m) return false;
      prev = z;
    }
    prev = 0;
    for (int v = v0; v < v1; ++v) {
      const float z = depth.depth_m.at<float>(v, um);
      if (!(z > 0)) continue;
      if (prev > 0 && std::abs(z - prev) > jump_k * sigmaZ(z) + jump_m) return false;
      prev = z;
    }
    return true;
  };
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
      if (!continuous(cx, cy)) continue;
      planar_[c] = 1;
      ++st.n_planar_cells;
      const int bx = std::clamp(static_cast<int>((p.normal.x() + 1.0) * 0.5 * B), 0, B - 1);
      const int by = std::clamp(static_cast<int>((p.normal.y() + 1.0) * 0.5 * B), 0, B - 1);
      const int bin = (p.normal.z() > 0 ? B * B : 0) + by * B + bx;
      cell_bin_[c] = bin;
      ++bin_count_[bin];
    }
  }

  // 3) Seeds from the histogram of normals, region growing over 4-neighbour planar cells.
  struct Segment {
    Moments m;
    CellPlane plane;
    bool alive = true;
  };
  std::vector<Segment> segs;
  const double cos_grow = std::cos(options_.grow_max_angle_deg * M_PI / 180.0);
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
    const CellPlane sp = cell_planes_[seed];
    const int sid = static_cast<int>(segs.size());
    region.clear();
    queue_.clear();
    queue_.push_back(seed);
    cell_segment_[seed] = sid;
    for (size_t qi = 0; qi < queue_.size(); ++qi) {
      const int c = queue_[qi];
      region.push_back(c);
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
    ++st.n_regions_grown;
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
      ++st.n_regions_too_small;
      for (int c : region) cell_segment_[c] = -1;  // may still join a later region
      continue;
    }
    Segment s;
    for (int c : region) s.m.add(cell_moments_[c]);
    fitMoments(s.m, &s.plane);
    segs.push_back(s);
  }

  // 4) Merge adjacent segments with similar planes (O(1) moment addition), until stable.
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
          ++st.n_merges;
          changed = true;
        }
      }
    }
  }
  // Compact the surviving segments; drop curved ones.
  std::vector<int> compact(nseg, -1);
  std::vector<CellPlane> planes;
  for (int i = 0; i < nseg; ++i) {
    if (!segs[i].alive) continue;
    const CellPlane& p = segs[i].plane;
    const double thr =
        options_.segment_sigma_factor * sigmaZ(p.mean.z()) + options_.segment_margin_m;
    if (p.mse > thr * thr) {
      ++st.n_segments_not_planar;
      continue;
    }
    compact[i] = static_cast<int>(planes.size());
    planes.push_back(p);
  }
  st.n_segments = static_cast<int>(planes.size());
  for (int c = 0; c < ncells; ++c) {
    if (cell_segment_[c] >= 0) cell_segment_[c] = compact[root(cell_segment_[c])];
  }
  const int np = std::min(static_cast<int>(planes.size()), 253);

  // 5) Pixel labels: a pixel of an interior cell (whole neighbourhood in one segment) stays with
  // it if within k sigma_z(z) + margin of its plane; in other cells it joins the nearest plane
  // among the segments of the (2R+1)^2 cell neighbourhood if it is within k sigma_z(z) + margin
  // (cells far from any segment are skipped). Without refinement, the valid pixels of each segment
  // cell are labelled.
  // Per band of cell rows: labels of its own pixels, and plane statistics merged in band order.
  struct LabelStats {
    std::vector<int> count, umin, umax, vmin, vmax;
    std::vector<Eigen::Vector3d> sum;
  };
  std::vector<LabelStats> band_stats(kBands);
  forEachTask(kBands, threads, [&](int band) {
    LabelStats& bs = band_stats[band];
    bs.count.assign(np, 0);
    bs.sum.assign(np, Eigen::Vector3d::Zero());
    bs.umin.assign(np, W);
    bs.umax.assign(np, -1);
    bs.vmin.assign(np, H);
    bs.vmax.assign(np, -1);
    std::vector<int>& count = bs.count;
    std::vector<Eigen::Vector3d>& sum = bs.sum;
    std::vector<int>&umin = bs.umin, &umax = bs.umax, &vmin = bs.vmin, &vmax = bs.vmax;
    int c0, c1;
    bandRows(band, &c0, &c1);
    for (int cy = c0; cy < c1; ++cy) {
      for (int cx = 0; cx < cells_x_; ++cx) {
        const int c = cy * cells_x_ + cx;
        const int own = cell_segment_[c];
        int cand[25];
        int ncand = 0;
        bool interior = own >= 0;
        const int R = std::clamp(options_.refine_neighbourhood_cells, 1, 2);
        for (int dy = -R; dy <= R; ++dy) {
          for (int dx = -R; dx <= R; ++dx) {
            const int qx = cx + dx, qy = cy + dy;
            if (qx < 0 || qy < 0 || qx >= cells_x_ || qy >= cells_y_) continue;
            const int s = cell_segment_[qy * cells_x_ + qx];
            if (s != own) interior = false;
            if (s >= 0 && s < np && std::find(cand, cand + ncand, s) == cand + ncand)
              cand[ncand++] = s;
          }
        }
        if (ncand == 0) continue;
        if (own >= np) interior = false;    // beyond the label range
        if (!options_.refine_boundaries) {  // cell-level labels only
          if (own < 0 || own >= np) continue;
          interior = true;
        }
        const int u0 = cx * cs, v0 = cy * cs, u1 = std::min(W, u0 + cs), v1 = std::min(H, v0 + cs);
        // Per-cell accumulators indexed by candidate slot; merged into the planes once per cell.
        int own_slot = -1;
        for (int k = 0; k < ncand; ++k)
          if (cand[k] == own) own_slot = k;
        if (interior && own_slot < 0) continue;
        int local_count[25] = {0};
        double local_sum[25][3] = {{0}};
        // Plane coefficients as plain arrays for the inner loop.
        double pn[25][4];
        for (int k = 0; k < ncand; ++k) {
          pn[k][0] = planes[cand[k]].normal.x();
          pn[k][1] = planes[cand[k]].normal.y();
          pn[k][2] = planes[cand[k]].normal.z();
          pn[k][3] = planes[cand[k]].d;
        }
        const double k_sigma = options_.refine_sigma_factor * options_.noise.sigma_z_coeff_per_m;
        const double margin = options_.refine_margin_m;
        const bool test_interior = options_.refine_boundaries;
        // visit(label, px, py, z, thr) for every valid pixel of the cell, row-major.
        auto forEachPoint = [&](auto&& visit) {
          for (int v = v0; v < v1; ++v) {
            const float* zr = depth.depth_m.ptr<float>(v);
            uint8_t* lr = res.labels.ptr<uint8_t>(v);
            const double yf = y_factor_[v];
            for (int u = u0; u < u1; ++u) {
              const double z = zr[u];
              if (!(z > 0.0) || !std::isfinite(z)) continue;
              visit(lr[u], x_factor_[u] * z, yf * z, z, k_sigma * z * z + margin);
            }
          }
        };
        if (interior) {
          // One plane: the sums stay in registers (same order of additions as per slot below).
          const double* q = pn[own_slot];
          const uint8_t label = static_cast<uint8_t>(own + 1);
          int n_in = 0;
          double sx = 0, sy = 0, sz = 0;
          forEachPoint([&](uint8_t& l, double px, double py, double z, double thr) {
            if (test_interior && !(std::abs(q[0] * px + q[1] * py + q[2] * z + q[3]) < thr)) return;
            l = label;
            ++n_in;
            sx += px;
            sy += py;
            sz += z;
          });
          local_count[own_slot] = n_in;
          local_sum[own_slot][0] = sx;
          local_sum[own_slot][1] = sy;
          local_sum[own_slot][2] = sz;
        } else {  // a boundary cell: each pixel joins the nearest candidate plane
          forEachPoint([&](uint8_t& l, double px, double py, double z, double thr) {
            double best_dist = thr;
            int slot = -1;
            for (int k = 0; k < ncand; ++k) {
              const double dist = std::abs(pn[k][0] * px + pn[k][1] * py + pn[k][2] * z + pn[k][3]);
              if (dist < best_dist) {
                best_dist = dist;
                slot = k;
              }
            }
            if (slot < 0) return;
            l = static_cast<uint8_t>(cand[slot] + 1);
            ++local_count[slot];
            local_sum[slot][0] += px;
            local_sum[slot][1] += py;
            local_sum[slot][2] += z;
          });
        }
        for (int k = 0; k < ncand; ++k) {
          if (local_count[k] == 0) continue;
          const int b = cand[k];
          count[b] += local_count[k];
          sum[b] += Eigen::Vector3d(local_sum[k][0], local_sum[k][1], local_sum[k][2]);
          umin[b] = std::min(umin[b], u0);  // bounding box at cell granularity
          umax[b] = std::max(umax[b], u1 - 1);
          vmin[b] = std::min(vmin[b], v0);
          vmax[b] = std::max(vmax[b], v1 - 1);
        }
      }
    }
  });
  std::vector<int> count(np, 0);
  std::vector<Eigen::Vector3d> sum(np, Eigen::Vector3d::Zero());
  std::vector<int> umin(np, W), umax(np, -1), vmin(np, H), vmax(np, -1);
  for (const LabelStats& bs : band_stats) {
    for (int b = 0; b < np; ++b) {
      count[b] += bs.count[b];
      sum[b] += bs.sum[b];
      umin[b] = std::min(umin[b], bs.umin[b]);
      umax[b] = std::max(umax[b], bs.umax[b]);
      vmin[b] = std::min(vmin[b], bs.vmin[b]);
      vmax[b] = std::max(vmax[b], bs.vmax[b]);
    }
  }

  // 6) WLS fit (eqs. 10-11) on a regular subsample of each segment's pixels; order by size.
  std::vector<int> order;
  for (int i = 0; i < np; ++i) {
    if (count[i] >= options_.min_plane_points)
      order.push_back(i);
    else
      ++st.n_too_few_points;
  }
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return count[a] > count[b]; });
  // The fits are independent: all candidates in parallel, then kept in size order.
  const DepthNoiseModel noise = options_.noise;
  auto fitSegment = [&](int i) {
    const int step =
        std::max(1, static_cast<int>(std::floor(std::sqrt(static_cast<double>(count[i]) /
                                                          std::max(1, options_.max_fit_points)))));
    std::vector<Eigen::Vector3d> P;
    std::vector<Eigen::Matrix3d> C;
    std::vector<double> V;
    // Grid anchored at multiples of the step (independent of the bounding box).
    for (int v = (vmin[i] + step - 1) / step * step; v <= vmax[i]; v += step) {
      const uint8_t* lr = res.labels.ptr<uint8_t>(v);
      for (int u = (umin[i] + step - 1) / step * step; u <= umax[i]; u += step) {
        if (lr[u] != i + 1) continue;
        double z, var;
        if (!depthAt(depth, u, v, noise, &z, &var)) continue;
        const Point3WithCov pt =
            backprojectWithCov(camera_, u, v, z, var, options_.pixel_variance_px2);
        P.push_back(pt.p);
        C.push_back(pt.cov);
        V.push_back(var);
      }
    }
    return fitPlaneWls(P, C, V, options_.fit);
  };
  std::vector<PlaneFitResult> fits(order.size());
  const int n_fits = static_cast<int>(order.size());
  forEachTask(n_fits, threads, [&](int k) { fits[k] = fitSegment(order[k]); });
  std::vector<uint8_t> lut(256, 0);
  for (int k = 0; k < n_fits; ++k) {
    if (static_cast<int>(res.planes.size()) >= options_.max_planes) break;
    const int i = order[k];
    const PlaneFitResult& fit = fits[k];
    if (!fit.ok()) {
      ++st.n_fit_rejected;
      continue;
    }
    PlaneFeature f;
    f.plane = fit.plane;
    f.n_points = count[i];
    f.centroid = sum[i] / count[i];
    f.label = static_cast<int>(res.planes.size()) + 1;
    lut[i + 1] = static_cast<uint8_t>(f.label);
    res.planes.push_back(f);
  }
  cv::LUT(res.labels, cv::Mat(1, 256, CV_8U, lut.data()), res.labels);
  st.n_planes = static_cast<int>(res.planes.size());
  return res;
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

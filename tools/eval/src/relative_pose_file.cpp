#include "pplvo/eval/relative_pose_file.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace pplvo {
namespace eval {
namespace {

constexpr int kFields = 31;

bool parseNumber(const std::string& text, double* value) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end == text.c_str() || *end != '\0') return false;
  *value = v;
  return true;
}

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

}  // namespace

Vector6d poseToXi(const Eigen::Isometry3d& T) {
  Eigen::Quaterniond q(T.linear());
  q.normalize();
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  Vector6d xi;
  xi << T.translation(), q.x(), q.y(), q.z();
  return xi;
}

std::string relativePoseFileHeader() {
  return "# pplvo relative poses with covariance (docs/evaluation.md, \"Covariance file\")\n"
         "# stamp prev_stamp status tx ty tz qx qy qz qw c00 c01 c02 c03 c04 c05 c11 c12 c13 c14 "
         "c15 c22 c23 c24 c25 c33 c34 c35 c44 c45 c55\n"
         "# T_prev_curr maps current-camera points into the previous camera (m; qw >= 0);\n"
         "# c = upper triangle, row by row, of the covariance of xi = [tx ty tz qx qy qz] of "
         "T_prev_curr (m^2, m, 1)\n"
         "# status: 1 tracking, 2 velocity model, 3 lost, 4 reinitialised (pose_t STATUS_*)\n";
}

std::string formatRelativePoseLine(const RelativePoseRecord& r) {
  Eigen::Quaterniond q(r.T_prev_curr.linear());
  q.normalize();
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  std::ostringstream out;
  out << r.stamp_text << ' ' << r.prev_stamp_text << ' ' << r.status;
  const Eigen::Vector3d t = r.T_prev_curr.translation();
  for (double v : {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()}) out << ' ' << num(v);
  for (int i = 0; i < 6; ++i) {
    for (int j = i; j < 6; ++j) out << ' ' << num(r.covariance(i, j));
  }
  out << '\n';
  return out.str();
}

RelativePoseReadResult parseRelativePoseFile(std::istream& in, const std::string& name,
                                             double fps) {
  RelativePoseReadResult res;
  std::string line;
  int line_no = 0;
  auto fail = [&](const std::string& why) {
    res.ok = false;
    res.error = name + ":" + std::to_string(line_no) + ": " + why;
    res.records.clear();
    return res;
  };
  while (std::getline(in, line)) {
    ++line_no;
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream fields(line);
    std::vector<std::string> f;
    for (std::string s; fields >> s;) f.push_back(s);
    if (f.size() != kFields) {
      return fail("expected " + std::to_string(kFields) + " fields, got " +
                  std::to_string(f.size()));
    }
    double v[kFields];
    for (int k = 0; k < kFields; ++k) {
      if (!parseNumber(f[k], &v[k]))
        return fail("field " + std::to_string(k + 1) + " is not a number");
    }
    RelativePoseRecord r;
    r.line_no = line_no;
    r.stamp_text = f[0];
    r.prev_stamp_text = f[1];
    r.stamp_s = fps > 0 ? v[0] / fps : v[0];
    r.prev_stamp_s = fps > 0 ? v[1] / fps : v[1];
    r.status = static_cast<int>(v[2]);
    if (v[2] != r.status || r.status < 0 || r.status > 4) return fail("status must be 0..4");
    Eigen::Quaterniond q(v[9], v[6], v[7], v[8]);
    if (!(std::abs(q.norm() - 1.0) < 1e-6)) return fail("quaternion is not unit");
    r.T_prev_curr = Eigen::Isometry3d::Identity();
    r.T_prev_curr.linear() = q.normalized().toRotationMatrix();
    r.T_prev_curr.translation() = Eigen::Vector3d(v[3], v[4], v[5]);
    int k = 10;
    for (int i = 0; i < 6; ++i) {
      for (int j = i; j < 6; ++j) {
        r.covariance(i, j) = v[k];
        r.covariance(j, i) = v[k];
        ++k;
      }
    }
    bool finite = r.covariance.allFinite() && r.T_prev_curr.matrix().allFinite() &&
                  std::isfinite(r.stamp_s) && std::isfinite(r.prev_stamp_s);
    if (!finite) return fail("non-finite value");
    res.records.push_back(r);
  }
  if (in.bad()) return fail("read error");
  res.ok = true;
  return res;
}

RelativePoseReadResult readRelativePoseFile(const std::string& path, double fps) {
  std::ifstream in(path);
  if (!in) {
    RelativePoseReadResult res;
    res.error = "cannot open " + path;
    return res;
  }
  return parseRelativePoseFile(in, path, fps);
}

}  // namespace eval
}  // namespace pplvo

// Agreement check: the pplvo-eval program against the independent numpy implementation
// tools/eval/tum_reference_eval.py on perturbed copies of the shared ground truths
// (smooth drift + noise + dropped poses + stamp jitter), within 1 %.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "pplvo/eval/report.h"
#include "pplvo/eval/tum_file.h"

namespace pplvo {
namespace eval {
namespace {

const char* kPython = "/usr/bin/python3";

std::string env(const char* name, const std::string& fallback) {
  const char* v = std::getenv(name);
  return v ? v : fallback;
}

struct CommandOutput {
  int exit_code = -1;
  std::string out;
};

CommandOutput runCommand(const std::string& cmd) {
  CommandOutput result;
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return result;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof(buf), pipe)) > 0) result.out.append(buf, n);
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

std::string quote(const std::string& s) { return "'" + s + "'"; }

// The text of section "ate" or "rpe" of a JSON object written by either implementation.
std::string section(const std::string& json, const std::string& name) {
  const std::size_t start = json.find("\"" + name + "\": {");
  if (start == std::string::npos) return "";
  const std::size_t end = json.find('}', start);
  return json.substr(start, end == std::string::npos ? std::string::npos : end - start + 1);
}

bool number(const std::string& text, const std::string& key, double* value) {
  const std::size_t at = text.find("\"" + key + "\": ");
  if (at == std::string::npos) return false;
  const char* begin = text.c_str() + at + key.size() + 4;
  char* end = nullptr;
  *value = std::strtod(begin, &end);
  return end != begin;
}

struct Perturbation {
  int keep_every = 1;           ///< subsample the ground truth (TUM: 100 Hz -> ~33 Hz)
  double stamp_jitter_s = 0.0;  ///< uniform +- jitter on written stamps (seconds)
  bool integer_stamps = false;  ///< keep frame-index stamps verbatim (ICL)
};

// Writes a perturbed copy of `gt`: a rigid offset of the whole trajectory, a smooth drift
// growing with time (rotation about z and translation), Gaussian noise on position and
// orientation, and dropped poses (every 41st, plus a block of 6). Fixed seed.
void writePerturbed(const TumFile& gt, const std::string& path, const Perturbation& p, double fps) {
  std::mt19937 rng(20240611);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_real_distribution<double> jitter(-1.0, 1.0);
  const Eigen::Isometry3d offset =
      Eigen::Translation3d(0.4, -1.2, 0.3) *
      Eigen::AngleAxisd(0.8, Eigen::Vector3d(0.2, 0.5, 1.0).normalized());
  std::ofstream out(path);
  out << "# perturbed copy of " << gt.name << "\n";
  const double t0 = gt.rows.front().stamp_s;
  const std::size_t n = gt.rows.size();
  for (std::size_t i = 0; i < n; i += static_cast<std::size_t>(p.keep_every)) {
    const TumRow& row = gt.rows[i];
    const double t = row.stamp_s - t0;  // seconds when fps is applied to the reading
    // Drop a few poses deterministically (the draws below still happen for fixed streams).
    const bool dropped = (i % 41 == 17) || (i >= n / 2 && i < n / 2 + 6 * p.keep_every);
    const Eigen::Isometry3d G =
        Eigen::Translation3d(row.values[0], row.values[1], row.values[2]) *
        Eigen::Quaterniond(row.values[6], row.values[3], row.values[4], row.values[5]).normalized();
    const Eigen::Isometry3d drift =
        Eigen::Translation3d(Eigen::Vector3d(0.012, -0.006, 0.004) * t) *
        Eigen::AngleAxisd(0.015 * t, Eigen::Vector3d::UnitZ());
    const Eigen::Vector3d dp(noise(rng), noise(rng), noise(rng));
    const Eigen::Vector3d dr(noise(rng), noise(rng), noise(rng));
    const double dt = jitter(rng);
    if (dropped) continue;
    Eigen::Isometry3d E = offset * drift * G;
    E.translation() += 0.004 * dp;
    E.linear() =
        E.linear() * Eigen::AngleAxisd(0.003 * dr.norm(), dr.normalized()).toRotationMatrix();
    const Eigen::Quaterniond q(E.linear());
    char line[256];
    if (p.integer_stamps) {
      std::snprintf(line, sizeof(line), "%.0f", std::round(row.stamp_s * fps));
    } else {
      std::snprintf(line, sizeof(line), "%.6f", row.stamp_s + p.stamp_jitter_s * dt);
    }
    out << line;
    std::snprintf(line, sizeof(line), " %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", E.translation().x(),
                  E.translation().y(), E.translation().z(), q.x(), q.y(), q.z(), q.w());
    out << line;
  }
}

void expectAgreement(const std::string& ours, const std::string& reference, const std::string& name,
                     const std::vector<std::string>& keys) {
  const std::string a = section(ours, name), b = section(reference, name);
  ASSERT_FALSE(a.empty()) << ours;
  ASSERT_FALSE(b.empty()) << reference;
  double pairs_a = 0, pairs_b = 0;
  ASSERT_TRUE(number(a, "pairs", &pairs_a)) << a;
  ASSERT_TRUE(number(b, "pairs", &pairs_b)) << b;
  std::printf("%s.pairs pplvo %.0f reference %.0f\n", name.c_str(), pairs_a, pairs_b);
  EXPECT_EQ(pairs_a, pairs_b) << name;
  for (const std::string& key : keys) {
    double va = 0, vb = 0;
    ASSERT_TRUE(number(a, key, &va)) << key << " in " << a;
    ASSERT_TRUE(number(b, key, &vb)) << key << " in " << b;
    const double rel = std::abs(va - vb) / std::max(std::abs(vb), 1e-12);
    std::printf("%s.%-22s pplvo %.9g  reference %.9g  relative difference %.2e\n", name.c_str(),
                key.c_str(), va, vb, rel);
    EXPECT_LE(std::abs(va - vb), 0.01 * std::max(std::abs(va), std::abs(vb)) + 1e-12)
        << name << "." << key;
  }
}

class ReferenceAgreement : public ::testing::Test {
 protected:
  void SetUp() override {
    struct stat st {};
    ASSERT_EQ(stat(kPython, &st), 0) << kPython << " is missing: this check needs python3 with "
                                     << "numpy (scripts/install_deps.sh installs python3-numpy)";
    const CommandOutput numpy = runCommand(std::string(kPython) + " -c 'import numpy' 2>&1");
    ASSERT_EQ(numpy.exit_code, 0) << "numpy is not importable by " << kPython
                                  << ": install python3-numpy (scripts/install_deps.sh); output: "
                                  << numpy.out;
    work_dir_ = env("PPLVO_BINARY_DIR", "/tmp") + "/eval_reference";
    mkdir(work_dir_.c_str(), 0755);
  }

  void compare(const std::string& gt_path, const std::string& tag, double fps,
               const Perturbation& p) {
    TumReadOptions ro;
    ro.fps = fps;
    const TumReadResult gt = readTumFile(gt_path, ro);
    ASSERT_TRUE(gt.ok) << gt.error;
    const std::string est_path = work_dir_ + "/" + tag + "_perturbed.txt";
    writePerturbed(gt.file, est_path, p, fps);
    const std::string fps_arg = fps > 0.0 ? " --fps " + std::to_string(fps) : "";
    const CommandOutput ours = runCommand(std::string(PPLVO_EVAL_BINARY) + " " + quote(gt_path) +
                                          " " + quote(est_path) + fps_arg + " --json");
    const CommandOutput reference =
        runCommand(std::string(kPython) + " " + PPLVO_EVAL_REFERENCE_SCRIPT + " " + quote(gt_path) +
                   " " + quote(est_path) + fps_arg);
    ASSERT_EQ(ours.exit_code, 0) << ours.out;
    ASSERT_EQ(reference.exit_code, 0) << reference.out;
    const std::vector<std::string> stats = {"rmse", "mean", "median", "std", "min", "max"};
    std::vector<std::string> ate_keys, rpe_keys;
    for (const auto& s : stats) {
      ate_keys.push_back(s + "_m");
      rpe_keys.push_back("trans_" + s + "_m_per_s");
      rpe_keys.push_back("rot_" + s + "_deg_per_s");
    }
    expectAgreement(ours.out, reference.out, "ate", ate_keys);
    expectAgreement(ours.out, reference.out, "rpe", rpe_keys);
    // The perturbation must be visible, or agreement would prove nothing.
    double ate_rmse = 0, rpe_trans = 0, rpe_rot = 0;
    ASSERT_TRUE(number(section(ours.out, "ate"), "rmse_m", &ate_rmse));
    ASSERT_TRUE(number(section(ours.out, "rpe"), "trans_rmse_m_per_s", &rpe_trans));
    ASSERT_TRUE(number(section(ours.out, "rpe"), "rot_rmse_deg_per_s", &rpe_rot));
    EXPECT_GT(ate_rmse, 0.003);
    EXPECT_GT(rpe_trans, 0.005);
    EXPECT_GT(rpe_rot, 0.2);
  }

  std::string work_dir_;
};

TEST_F(ReferenceAgreement, TumGroundTruthPerturbed) {
  Perturbation p;
  p.keep_every = 3;
  p.stamp_jitter_s = 0.004;
  compare(
      env("PPLVO_SHARED_DATA", "../shared/data") + "/tum_fr3_sitting_static_short/groundtruth.txt",
      "tum", 0.0, p);
}

// Every ground-truth pose kept, stamps jittered by up to +-9 ms at ~100 Hz: estimates compete for
// the same ground-truth stamps, so the greedy order of the association decides the pairs.
TEST_F(ReferenceAgreement, TumDenseEstimateCompetingForStamps) {
  Perturbation p;
  p.keep_every = 1;
  p.stamp_jitter_s = 0.009;
  compare(env("PPLVO_SHARED_DATA", "../shared/data") +
              "/tum_fr3_sitting_static_short/groundtruth.txt",
          "tum_dense", 0.0, p);
}

TEST_F(ReferenceAgreement, IclGroundTruthPerturbedWithFps) {
  Perturbation p;
  p.integer_stamps = true;
  compare(env("PPLVO_SHARED_DATA", "../shared/data") + "/icl_living_room_kt0_short/groundtruth.txt",
          "icl", 30.0, p);
}

TEST(Cli, ErrorsExitWithCodeTwoAndNameTheFile) {
  const std::string bin = PPLVO_EVAL_BINARY;
  const CommandOutput missing = runCommand(bin + " /nonexistent/gt.txt /nonexistent/est.txt 2>&1");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.out.find("cannot read '/nonexistent/gt.txt'"), std::string::npos)
      << missing.out;
  const CommandOutput usage = runCommand(bin + " only_one_file 2>&1");
  EXPECT_EQ(usage.exit_code, 2);
  EXPECT_NE(usage.out.find("usage:"), std::string::npos) << usage.out;
  const CommandOutput bad = runCommand(bin + " a b --fps -3 2>&1");
  EXPECT_EQ(bad.exit_code, 2);

  // Same file twice with stamps in different clocks: clear association error, exit 2.
  const std::string dir = env("PPLVO_BINARY_DIR", "/tmp");
  const std::string a = dir + "/eval_cli_a.txt", b = dir + "/eval_cli_b.txt";
  {
    std::ofstream fa(a), fb(b);
    for (int i = 0; i < 50; ++i) {
      fa << 1000.0 + 0.1 * i << " " << 0.01 * i << " 0 0 0 0 0 1\n";
      fb << 0.1 * i << " " << 0.01 * i << " 0 0 0 0 0 1\n";
    }
  }
  const CommandOutput clocks = runCommand(bin + " " + a + " " + b + " 2>&1");
  EXPECT_EQ(clocks.exit_code, 2);
  EXPECT_NE(clocks.out.find("no pose pairs within 0.02 s: are the stamps in the same clock?"),
            std::string::npos)
      << clocks.out;
  const CommandOutput same =
      runCommand(bin + " " + a + " " + a + " --plot-data " + dir + "/eval_cli_plot.txt");
  EXPECT_EQ(same.exit_code, 0) << same.out;
  EXPECT_NE(same.out.find("ate.pairs 50\n"), std::string::npos) << same.out;
  EXPECT_NE(same.out.find("rpe.pairs "), std::string::npos) << same.out;
  std::ifstream plot(dir + "/eval_cli_plot.txt");
  EXPECT_TRUE(plot.good());
}

}  // namespace
}  // namespace eval
}  // namespace pplvo

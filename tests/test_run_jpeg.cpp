// pplvo-run on a TUM-layout folder whose colour images are JPEG (as 7-Scenes ships them): the
// same synthetic sequence with its colour PNGs re-encoded as JPEG (quality 95) tracks, and its
// trajectory stays close to the PNG one; a corrupt JPEG is a clear error or a counted skip.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "pplvo/run/run_pipeline.h"
#include "pplvo/fixtures/synthetic_sequence.h"

namespace fs = std::filesystem;

namespace pplvo::run {
namespace {

constexpr int kFrames = 24;

std::string readText(const fs::path& p) {
  std::ifstream in(p);
  return std::string((std::istreambuf_iterator<char>(in)), {});
}

/// Replaces every "rgb/<name>.png" in an index file with "rgb/<name>.jpg".
void pngToJpgNames(const fs::path& index) {
  std::string s = readText(index);
  for (size_t at = s.find("rgb/"); at != std::string::npos; at = s.find("rgb/", at + 1)) {
    const size_t end = s.find_first_of(" \n", at);
    const size_t dot = s.rfind(".png", end);
    if (dot != std::string::npos && dot > at) s.replace(dot, 4, ".jpg");
  }
  std::ofstream(index, std::ios::trunc) << s;
}

class RunJpegTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const fs::path base = fs::temp_directory_path() / ("pplvo_run_jpeg_" + std::to_string(::getpid()));
    fs::remove_all(base);
    png_dir_ = (base / "png").string();
    jpg_dir_ = (base / "jpg").string();
    synth::SynthOptions o;
    o.frames = kFrames;
    o.seed = 11;
    synth::writeTumFolder(synth::SyntheticSequence(o), png_dir_);
    fs::copy(png_dir_, jpg_dir_, fs::copy_options::recursive);
    for (const auto& e : fs::directory_iterator(fs::path(jpg_dir_) / "rgb")) {
      const cv::Mat bgr = cv::imread(e.path().string(), cv::IMREAD_COLOR);
      ASSERT_FALSE(bgr.empty()) << e.path();
      fs::path jpg = e.path();
      jpg.replace_extension(".jpg");
      ASSERT_TRUE(cv::imwrite(jpg.string(), bgr, {cv::IMWRITE_JPEG_QUALITY, 95}));
      fs::remove(e.path());
    }
    for (const char* index : {"rgb.txt", "associations.txt"}) {
      if (fs::exists(fs::path(jpg_dir_) / index)) pngToJpgNames(fs::path(jpg_dir_) / index);
    }
  }
  static void TearDownTestSuite() { fs::remove_all(fs::path(png_dir_).parent_path()); }
  static std::string png_dir_, jpg_dir_;
};
std::string RunJpegTest::png_dir_;
std::string RunJpegTest::jpg_dir_;

TEST_F(RunJpegTest, JpegColourTracksLikePng) {
  RunOptions o;
  o.dataset_dir = png_dir_;
  const RunResult png = runPipeline(o);
  o.dataset_dir = jpg_dir_;
  const RunResult jpg = runPipeline(o);
  ASSERT_FALSE(png.failed) << png.error;
  ASSERT_FALSE(jpg.failed) << jpg.error;
  EXPECT_EQ(jpg.frames_published, kFrames);
  EXPECT_EQ(jpg.frames_skipped, 0);
  ASSERT_EQ(jpg.poses, kFrames);
  EXPECT_EQ(jpg.tracking, kFrames - 1);
  ASSERT_EQ(png.poses, kFrames);

  synth::SynthOptions so;
  so.frames = kFrames;
  so.seed = 11;
  const synth::SyntheticSequence seq(so);
  double max_diff = 0, max_drift = 0;
  for (int i = 0; i < kFrames; ++i) {
    EXPECT_EQ(jpg.trajectory[i].stamp_text, png.trajectory[i].stamp_text);
    const Pose3 truth = seq.pose(0).inverse() * seq.pose(i);
    max_diff = std::max(max_diff, (png.trajectory[i].T_w_c.translation() -
                                   jpg.trajectory[i].T_w_c.translation())
                                      .norm());
    max_drift = std::max(max_drift,
                         (truth.translation() - jpg.trajectory[i].T_w_c.translation()).norm());
  }
  std::printf("JPEG colour, %d frames: max distance to the PNG trajectory %.2f mm, max drift "
              "%.2f mm\n",
              kFrames, 1e3 * max_diff, 1e3 * max_drift);
  // JPEG at quality 95 moves features by a fraction of a pixel: the trajectories differ by
  // well under the PNG run's own drift bound (test_run_pipeline: 3 cm).
  EXPECT_LT(max_diff, 0.01);
  EXPECT_LT(max_drift, 0.03);
}

TEST_F(RunJpegTest, TruncatedJpegIsAClearErrorOrACountedSkip) {
  const fs::path copy = fs::path(jpg_dir_ + "_corrupt");
  fs::remove_all(copy);
  fs::copy(jpg_dir_, copy, fs::copy_options::recursive);
  std::vector<fs::path> rgb;
  for (const auto& e : fs::directory_iterator(copy / "rgb")) rgb.push_back(e.path());
  std::sort(rgb.begin(), rgb.end());
  ASSERT_GT(rgb.size(), 10u);
  // Cut the JPEG in half: cv::imdecode would return the image with its lower half grey.
  fs::resize_file(rgb[10], fs::file_size(rgb[10]) / 2);

  RunOptions o;
  o.dataset_dir = copy.string();
  const RunResult stop = runPipeline(o);
  EXPECT_TRUE(stop.failed);
  EXPECT_NE(stop.error.find(rgb[10].filename().string()), std::string::npos) << stop.error;
  EXPECT_NE(stop.error.find("corrupt image file"), std::string::npos) << stop.error;

  o.skip_bad = true;
  const RunResult skip = runPipeline(o);
  EXPECT_FALSE(skip.failed) << skip.error;
  EXPECT_EQ(skip.frames_skipped, 1);
  EXPECT_EQ(skip.poses, kFrames - 1);
  fs::remove_all(copy);
}

}  // namespace
}  // namespace pplvo::run

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <thread>
#include <vector>

#include <opencv2/core/persistence.hpp>
#include <opencv2/imgcodecs.hpp>

#include "pplvo/synth/synthetic_sequence.h"

namespace pplvo::synth {
namespace {

constexpr double kDepthScale = 5000.0;  // TUM: 16-bit units per metre

void writePng(const std::string& path, const cv::Mat& img) {
  // Compression level 1: files ~20% larger than the default, writing several times faster.
  const std::vector<int> params = {cv::IMWRITE_PNG_COMPRESSION, 1};
  bool ok = false;
  try {
    ok = cv::imwrite(path, img, params);
  } catch (const cv::Exception& e) {
    throw std::runtime_error("cannot write '" + path + "': " + e.what());
  }
  if (!ok) throw std::runtime_error("cannot write '" + path + "'");
}

std::ofstream openText(const std::string& path) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write '" + path + "'");
  return out;
}

void closeText(std::ofstream& out, const std::string& path) {
  out.flush();
  if (!out) throw std::runtime_error("write failed for '" + path + "'");
}

void writeCalib(const SyntheticSequence& seq, const std::string& path) {
  const PinholeCamera& c = seq.camera();
  const cv::Mat K = (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
  const cv::Mat dist = cv::Mat::zeros(1, 5, CV_64F);
  cv::FileStorage fs(path, cv::FileStorage::WRITE);
  if (!fs.isOpened()) throw std::runtime_error("cannot write '" + path + "'");
  fs << "RGB_intrinsic_params" << K;
  fs << "RGB_distortion_coefficients" << dist;
  fs << "IR_intrinsic_params" << K;  // depth is registered to colour
  fs << "IR_distortion_coefficients" << dist;
  fs << "Rotation" << cv::Mat::eye(3, 3, CV_64F);
  fs << "Translation" << cv::Mat::zeros(3, 1, CV_64F);
  fs << "depth_scale" << kDepthScale;
  fs << "image_width" << c.width;
  fs << "image_height" << c.height;
  fs.release();
}

}  // namespace

void writeTumFolder(const SyntheticSequence& seq, const std::string& dir, bool write_true_depth) {
  namespace fs = std::filesystem;
  std::error_code ec;
  for (const char* sub : {"rgb", "depth", "depth_true"}) {
    if (std::string(sub) == "depth_true" && !write_true_depth) continue;
    fs::create_directories(fs::path(dir) / sub, ec);
    if (ec) throw std::runtime_error("cannot create '" + dir + "/" + sub + "': " + ec.message());
  }
  const std::string p_rgb = dir + "/rgb.txt", p_depth = dir + "/depth.txt",
                    p_assoc = dir + "/associations.txt";
  std::ofstream rgb_txt = openText(p_rgb), depth_txt = openText(p_depth),
                assoc_txt = openText(p_assoc);
  std::ofstream depth_true_txt;
  const std::string p_depth_true = dir + "/depth_true.txt";
  if (write_true_depth) depth_true_txt = openText(p_depth_true);
  const auto& o = seq.options();
  char header[256];
  std::snprintf(header, sizeof(header),
                "# pplvo synthetic sequence: scene %s, seed %llu, %d frames\n", o.scene.c_str(),
                static_cast<unsigned long long>(o.seed), o.frames);
  rgb_txt << "# color images\n" << header << "# timestamp filename\n";
  depth_txt << "# depth maps (16-bit PNG, 5000 units per metre, 0 = missing)\n"
            << header << "# timestamp filename\n";
  if (write_true_depth) {
    depth_true_txt << "# noiseless depth maps (16-bit PNG, 5000 units per metre)\n"
                   << header << "# timestamp filename\n";
  }
  // Frames are rendered and encoded by two workers (render() is const and thread-safe); the
  // text files are written afterwards in frame order, so the output does not depend on timing.
  const auto writeFrame = [&](int i) {
    const SynthFrame f = seq.render(i);
    const std::string s = seq.stamp(i);
    writePng(dir + "/rgb/" + s + ".png", f.frame.bgr);
    writePng(dir + "/depth/" + s + ".png", depthMetresToUnits(f.frame.depth_m, kDepthScale));
    if (write_true_depth) {
      writePng(dir + "/depth_true/" + s + ".png", depthMetresToUnits(f.depth_true_m, kDepthScale));
    }
  };
  const int workers =
      std::max(1, std::min(2, static_cast<int>(std::thread::hardware_concurrency())));
  std::vector<std::exception_ptr> errors(workers);
  std::atomic<bool> failed{false};
  const auto work = [&](int w) {
    try {
      for (int i = w; i < seq.size() && !failed.load(); i += workers) writeFrame(i);
    } catch (...) {
      errors[w] = std::current_exception();
      failed.store(true);
    }
  };
  std::vector<std::thread> threads;
  for (int w = 1; w < workers; ++w) threads.emplace_back(work, w);
  work(0);
  for (std::thread& t : threads) t.join();
  for (const std::exception_ptr& e : errors) {
    if (e) std::rethrow_exception(e);
  }
  for (int i = 0; i < seq.size(); ++i) {
    const std::string s = seq.stamp(i);
    const std::string rgb_name = "rgb/" + s + ".png", depth_name = "depth/" + s + ".png";
    if (write_true_depth) depth_true_txt << s << " depth_true/" << s << ".png\n";
    rgb_txt << s << ' ' << rgb_name << '\n';
    depth_txt << s << ' ' << depth_name << '\n';
    assoc_txt << s << ' ' << depth_name << ' ' << s << ' ' << rgb_name << '\n';
  }
  closeText(rgb_txt, p_rgb);
  closeText(depth_txt, p_depth);
  closeText(assoc_txt, p_assoc);
  if (write_true_depth) closeText(depth_true_txt, p_depth_true);
  writeTumTrajectory(dir + "/groundtruth.txt", seq.groundTruth());
  writeCalib(seq, dir + "/calib_params.xml");
}

}  // namespace pplvo::synth

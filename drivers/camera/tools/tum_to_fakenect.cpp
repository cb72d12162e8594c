// pplvo-tum-to-fakenect: converts a TUM-layout RGB-D sequence into a dump that Debian's
// fakenect (libfreenect 0.5.x) replays as if a Kinect v1 were plugged in.
//
// Dump format (fakenect.c / fakenect-record in libfreenect 0.5.3):
//   INDEX.txt             one file name per line, replayed in order
//   d-<time>-<ticks>.pgm  "P5 640 480 65535\n" + 640*480 uint16 raw 11-bit disparity, host
//                         byte order (fakenect memcpy's it; it is not big-endian PGM)
//   r-<time>-<ticks>.ppm  "P6 640 480 255\n" + 640*480*3 bytes R G B
// <time> (seconds, %f) paces playback; <ticks> is the 60 MHz device counter handed to the
// callbacks. Debian's fakenect offers only FREENECT_DEPTH_11BIT, so depth is stored as raw
// disparity, the inverse of the conversion pplvo-camera applies (KinectDisparityModel).
// Each associated pair is written with the colour frame's stamp for both halves.
// pplvo_frames.txt (ignored by fakenect) lists the source files of each pair, for tests.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "pplvo/camera/convert.h"
#include "pplvo/core/rgbd_frame.h"
#include "pplvo/dataset/dataset.h"

namespace {

bool writeFile(const std::string& path, const std::string& header, const void* data, size_t bytes) {
  std::ofstream f(path, std::ios::binary);
  f << header;
  f.write(static_cast<const char*>(data), static_cast<std::streamsize>(bytes));
  return static_cast<bool>(f);
}

void usage() {
  std::fprintf(stderr,
               "usage: pplvo-tum-to-fakenect --dataset DIR --output DUMP [--max-frames N]\n"
               "       [--depth-scale 5000] [--max-dt 0.02]\n"
               "Writes a fakenect dump (replay: fakenect DUMP pplvo-camera --backend freenect)\n");
}

}  // namespace

int main(int argc, char** argv) {
  std::string dataset, output;
  long max_frames = 0;
  double depth_scale = 5000.0, max_dt = 0.02;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      usage();
      return 0;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "pplvo-tum-to-fakenect: missing value after %s\n", a.c_str());
      return 1;
    }
    const std::string v = argv[++i];
    try {
      if (a == "--dataset")
        dataset = v;
      else if (a == "--output")
        output = v;
      else if (a == "--max-frames")
        max_frames = std::stol(v);
      else if (a == "--depth-scale")
        depth_scale = std::stod(v);
      else if (a == "--max-dt")
        max_dt = std::stod(v);
      else {
        std::fprintf(stderr, "pplvo-tum-to-fakenect: unknown option %s\n", a.c_str());
        usage();
        return 1;
      }
    } catch (...) {
      std::fprintf(stderr, "pplvo-tum-to-fakenect: bad value '%s' for %s\n", v.c_str(), a.c_str());
      return 1;
    }
  }
  if (dataset.empty() || output.empty() || max_frames < 0 || !(depth_scale > 0)) {
    usage();
    return 1;
  }

  // The player's index rules (pplvo_dataset): associations.txt in either column order, else
  // rgb.txt + depth.txt associated within max_dt; listed files that do not exist are dropped.
  pplvo::dataset::DatasetIndex index;
  try {
    pplvo::dataset::DatasetOptions dopt;
    dopt.max_association_dt_s = max_dt;
    index = pplvo::dataset::buildIndex(dataset, dopt);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pplvo-tum-to-fakenect: %s\n", e.what());
    return 2;
  }
  if (index.entries.empty()) {
    std::fprintf(stderr, "pplvo-tum-to-fakenect: no colour/depth pairs in %s (%s)\n",
                 dataset.c_str(), index.summary.text().c_str());
    return 2;
  }
  std::error_code ec;
  std::filesystem::create_directories(output, ec);
  if (ec) {
    std::fprintf(stderr, "pplvo-tum-to-fakenect: cannot create %s\n", output.c_str());
    return 2;
  }

  const pplvo::camera::KinectDisparityModel model;
  std::ofstream index_out(output + "/INDEX.txt");
  std::ofstream frames(output + "/pplvo_frames.txt");
  frames << "# n rgb_stamp rgb_path depth_stamp depth_path device_ticks (source: " << dataset
         << "; " << index.summary.source << ")\n";
  const int64_t t0_us = index.entries.front().utime;
  long written = 0, skipped = 0, unrepresentable = 0;
  for (const pplvo::dataset::DatasetEntry& e : index.entries) {
    if (max_frames > 0 && written >= max_frames) break;
    cv::Mat bgr, depth;
    try {
      pplvo::dataset::RawFrame raw_frame = pplvo::dataset::loadRawFrame(e, depth_scale);
      bgr = raw_frame.bgr;
      depth = raw_frame.depth_units;
    } catch (const std::exception& ex) {
      std::fprintf(stderr, "pplvo-tum-to-fakenect: skipping frame: %s\n", ex.what());
      ++skipped;
      continue;
    }
    if (bgr.size() != cv::Size(640, 480)) cv::resize(bgr, bgr, {640, 480}, 0, 0, cv::INTER_AREA);
    if (depth.size() != cv::Size(640, 480)) {
      cv::resize(depth, depth, {640, 480}, 0, 0, cv::INTER_NEAREST);
    }
    int bad = 0;
    const cv::Mat raw = pplvo::camera::kinectRawFromMetres(
        pplvo::depthUnitsToMetres(depth, depth_scale), model, &bad);
    unrepresentable += bad;
    cv::Mat rgb;
    cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);

    // 60 MHz counter from the colour stamp, starting away from 0, wrapping at 2^32.
    const auto ticks =
        static_cast<uint32_t>(static_cast<uint64_t>((e.utime - t0_us) * 60 + 600000) & 0xffffffffu);
    char time_text[64];
    std::snprintf(time_text, sizeof(time_text), "%.6f", e.utime * 1e-6);
    const std::string dname = std::string("d-") + time_text + "-" + std::to_string(ticks) + ".pgm";
    const std::string rname = std::string("r-") + time_text + "-" + std::to_string(ticks) + ".ppm";
    if (!writeFile(output + "/" + dname, "P5 640 480 65535\n", raw.data, 640 * 480 * 2) ||
        !writeFile(output + "/" + rname, "P6 640 480 255\n", rgb.data, 640 * 480 * 3)) {
      std::fprintf(stderr, "pplvo-tum-to-fakenect: cannot write into %s\n", output.c_str());
      return 2;
    }
    index_out << dname << "\n" << rname << "\n";
    frames << written << " " << e.stamp_text << " "
           << std::filesystem::absolute(e.rgb_path).string() << " " << e.depth_stamp_text << " "
           << std::filesystem::absolute(e.depth_path).string() << " " << ticks << "\n";
    ++written;
  }
  std::fprintf(stderr,
               "pplvo-tum-to-fakenect: wrote %ld frame pairs to %s (%ld skipped, %ld depth "
               "pixels outside the Kinect range [%.3f, %.2f] m set to no reading)\n",
               written, output.c_str(), skipped, unrepresentable, model.metresFromRaw(0),
               model.metresFromRaw(model.max_valid_raw));
  return written > 0 ? 0 : 2;
}

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
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "pplvo/camera/convert.h"
#include "pplvo/core/rgbd_frame.h"

namespace {

struct Entry {
  std::string stamp;  // verbatim text
  double t = 0;
  std::string path;   // relative to the dataset folder
};
struct PairEntry {
  Entry rgb, depth;
};

bool fileExists(const std::string& p) {
  std::ifstream f(p);
  return f.good();
}

std::vector<Entry> readList(const std::string& path) {
  std::vector<Entry> out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    Entry e;
    if (!(ss >> e.stamp >> e.path)) continue;
    try {
      e.t = std::stod(e.stamp);
    } catch (...) {
      continue;
    }
    out.push_back(e);
  }
  return out;
}

// associations.txt: "t1 path1 t2 path2" in either order (TUM: rgb first; ICL: depth first).
std::vector<PairEntry> readAssociations(const std::string& path) {
  std::vector<PairEntry> out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    Entry a, b;
    if (!(ss >> a.stamp >> a.path >> b.stamp >> b.path)) continue;
    try {
      a.t = std::stod(a.stamp);
      b.t = std::stod(b.stamp);
    } catch (...) {
      continue;
    }
    if (a.path.rfind("depth", 0) == 0) std::swap(a, b);
    out.push_back({a, b});
  }
  return out;
}

// Nearest depth for each colour frame within max_dt seconds, each depth used once.
std::vector<PairEntry> associate(const std::vector<Entry>& rgb, const std::vector<Entry>& depth,
                                 double max_dt) {
  std::vector<PairEntry> out;
  std::vector<bool> used(depth.size(), false);
  for (const Entry& r : rgb) {
    int best = -1;
    double best_dt = max_dt;
    for (size_t j = 0; j < depth.size(); ++j) {
      const double dt = std::abs(depth[j].t - r.t);
      if (!used[j] && dt <= best_dt) {
        best_dt = dt;
        best = static_cast<int>(j);
      }
    }
    if (best >= 0) {
      used[best] = true;
      out.push_back({r, depth[best]});
    }
  }
  return out;
}

bool writeFile(const std::string& path, const std::string& header, const void* data,
               size_t bytes) {
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
      if (a == "--dataset") dataset = v;
      else if (a == "--output") output = v;
      else if (a == "--max-frames") max_frames = std::stol(v);
      else if (a == "--depth-scale") depth_scale = std::stod(v);
      else if (a == "--max-dt") max_dt = std::stod(v);
      else {
        std::fprintf(stderr, "pplvo-tum-to-fakenect: unknown option %s\n", a.c_str());
        usage();
        return 1;
      }
    } catch (...) {
      std::fprintf(stderr, "pplvo-tum-to-fakenect: bad value '%s' for %s\n", v.c_str(),
                   a.c_str());
      return 1;
    }
  }
  if (dataset.empty() || output.empty() || max_frames < 0 || !(depth_scale > 0)) {
    usage();
    return 1;
  }

  std::vector<PairEntry> pairs;
  if (fileExists(dataset + "/associations.txt")) {
    pairs = readAssociations(dataset + "/associations.txt");
  } else if (fileExists(dataset + "/rgb.txt") && fileExists(dataset + "/depth.txt")) {
    std::vector<Entry> depth;
    for (const Entry& e : readList(dataset + "/depth.txt")) {
      if (fileExists(dataset + "/" + e.path)) depth.push_back(e);  // depth.txt lists absent files
    }
    std::vector<Entry> rgb;
    for (const Entry& e : readList(dataset + "/rgb.txt")) {
      if (fileExists(dataset + "/" + e.path)) rgb.push_back(e);
    }
    pairs = associate(rgb, depth, max_dt);
  } else {
    std::fprintf(stderr, "pplvo-tum-to-fakenect: %s has neither associations.txt nor "
                         "rgb.txt + depth.txt\n", dataset.c_str());
    return 2;
  }
  if (pairs.empty()) {
    std::fprintf(stderr, "pplvo-tum-to-fakenect: no colour/depth pairs in %s\n",
                 dataset.c_str());
    return 2;
  }
  if (std::system(("mkdir -p '" + output + "'").c_str()) != 0) {
    std::fprintf(stderr, "pplvo-tum-to-fakenect: cannot create %s\n", output.c_str());
    return 2;
  }

  const pplvo::camera::KinectDisparityModel model;
  std::ofstream index(output + "/INDEX.txt");
  std::ofstream frames(output + "/pplvo_frames.txt");
  frames << "# n rgb_stamp rgb_path depth_stamp depth_path device_ticks (source: " << dataset
         << ")\n";
  const double t0 = pairs.front().rgb.t;
  long written = 0, skipped = 0, unrepresentable = 0;
  for (const PairEntry& p : pairs) {
    if (max_frames > 0 && written >= max_frames) break;
    cv::Mat bgr = cv::imread(dataset + "/" + p.rgb.path, cv::IMREAD_COLOR);
    cv::Mat depth = cv::imread(dataset + "/" + p.depth.path, cv::IMREAD_ANYDEPTH);
    if (bgr.empty() || depth.empty() || depth.type() != CV_16UC1) {
      std::fprintf(stderr, "pplvo-tum-to-fakenect: skipping unreadable pair %s / %s\n",
                   p.rgb.path.c_str(), p.depth.path.c_str());
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
    const auto ticks = static_cast<uint32_t>(
        static_cast<uint64_t>(std::llround((p.rgb.t - t0) * 60e6) + 600000) & 0xffffffffu);
    char time_text[64];
    std::snprintf(time_text, sizeof(time_text), "%f", p.rgb.t);
    const std::string dname = std::string("d-") + time_text + "-" + std::to_string(ticks) + ".pgm";
    const std::string rname = std::string("r-") + time_text + "-" + std::to_string(ticks) + ".ppm";
    if (!writeFile(output + "/" + dname, "P5 640 480 65535\n", raw.data, 640 * 480 * 2) ||
        !writeFile(output + "/" + rname, "P6 640 480 255\n", rgb.data, 640 * 480 * 3)) {
      std::fprintf(stderr, "pplvo-tum-to-fakenect: cannot write into %s\n", output.c_str());
      return 2;
    }
    index << dname << "\n" << rname << "\n";
    frames << written << " " << p.rgb.stamp << " " << p.rgb.path << " " << p.depth.stamp << " "
           << p.depth.path << " " << ticks << "\n";
    ++written;
  }
  std::fprintf(stderr,
               "pplvo-tum-to-fakenect: wrote %ld frame pairs to %s (%ld skipped, %ld depth "
               "pixels outside the Kinect range [%.3f, %.2f] m set to no reading)\n",
               written, output.c_str(), skipped, unrepresentable,
               model.metresFromRaw(0), model.metresFromRaw(model.max_valid_raw));
  return written > 0 ? 0 : 2;
}

// pplvo-synth: writes a synthetic RGB-D sequence as a TUM-layout folder.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "pplvo/synth/synthetic_sequence.h"

namespace {

void usage() {
  std::fprintf(stderr,
               "usage: pplvo-synth --output DIR [--frames N] [--seed S] "
               "[--scene room|textureless|lines]\n"
               "                   [--moving-object] [--no-noise] [--true-depth] "
               "[--width W --height H]\n"
               "                   [--fps F] [--trajectory-scale X]\n");
}

}  // namespace

int main(int argc, char** argv) {
  pplvo::synth::SynthOptions opt;
  std::string output;
  bool true_depth = false;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= argc) throw std::invalid_argument("missing value after " + a);
        return argv[++i];
      };
      if (a == "--output") {
        output = value();
      } else if (a == "--frames") {
        opt.frames = std::stoi(value());
      } else if (a == "--seed") {
        opt.seed = std::stoull(value());
      } else if (a == "--scene") {
        opt.scene = value();
      } else if (a == "--moving-object") {
        opt.moving_object = true;
      } else if (a == "--no-noise") {
        opt.noise.enabled = false;
      } else if (a == "--true-depth") {
        true_depth = true;
      } else if (a == "--width") {
        opt.width = std::stoi(value());
      } else if (a == "--height") {
        opt.height = std::stoi(value());
      } else if (a == "--fps") {
        opt.fps = std::stod(value());
      } else if (a == "--trajectory-scale") {
        opt.trajectory_scale = std::stod(value());
      } else if (a == "--help" || a == "-h") {
        usage();
        return 0;
      } else {
        throw std::invalid_argument("unknown argument '" + a + "'");
      }
    }
    if (output.empty()) throw std::invalid_argument("--output DIR is required");
    // Keep the principal point at the image centre when the size changes, and the field of
    // view of the 640 x 480 default (focal length scales with the width).
    opt.cx = (opt.width - 1) / 2.0;
    opt.cy = (opt.height - 1) / 2.0;
    opt.fx = opt.fy = 525.0 * opt.width / 640.0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pplvo-synth: %s\n", e.what());
    usage();
    return 2;
  }
  try {
    const auto t0 = std::chrono::steady_clock::now();
    const pplvo::synth::SyntheticSequence seq(opt);
    pplvo::synth::writeTumFolder(seq, output, true_depth);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("pplvo-synth: wrote %d frames (%s, seed %llu) to %s in %.1f s\n", seq.size(),
                opt.scene.c_str(), static_cast<unsigned long long>(opt.seed), output.c_str(), s);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pplvo-synth: %s\n", e.what());
    return 1;
  }
  return 0;
}

// pplvo-peer-odometry: runs OpenCV's RGB-D odometry (the benchmark's peer) over a TUM-layout
// folder and writes a TUM trajectory with the dataset's stamps verbatim.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <optional>
#include <string>

#include "pplvo/core/allocator.h"
#include "pplvo/core/trajectory.h"
#include "pplvo/dataset/dataset.h"
#include "pplvo/peer/peer_odometry.h"

namespace {

void usage(std::ostream& out) {
  out << "usage: pplvo-peer-odometry --dataset DIR [--camera FILE.yaml] --output TRAJ.txt\n"
         "                           [--method rgbd|icp|rgbd_icp] [--max-frames N]\n"
         "                           [--failure hold|constant_velocity] [--signed-camera]\n"
         "                           [--max-points-part F] [--max-depth M]\n"
         "                           [--keyframes [--keyframe-translation M]\n"
         "                            [--keyframe-rotation DEG]]\n"
         "  Runs OpenCV contrib's cv::rgbd odometry (default rgbd) on a TUM-layout folder and\n"
         "  writes camera-to-world poses (world = first camera) with the dataset's stamps.\n"
         "  --camera: a camera file for a folder without calib_params.xml (config/cameras/).\n"
         "  --signed-camera passes a mirrored camera matrix (fy < 0) to OpenCV unchanged\n"
         "  instead of flipping the images (for comparison only).\n"
         "  --max-points-part: fraction of valid pixels OpenCV samples (default 0.07);\n"
         "  --max-depth: depths at or beyond this are ignored, metres (default 4).\n"
         "  --keyframes: register each frame to a keyframe instead of the previous frame;\n"
         "  a frame becomes the keyframe when its motion from the keyframe passes\n"
         "  --keyframe-translation (default 0.10 m) or --keyframe-rotation (default 10 deg),\n"
         "  or when only the previous frame could track it.\n"
         "exit codes: 0 ok, 1 dataset or output error, 2 bad arguments\n";
}

bool parseDouble(const std::string& s, double* v) {
  char* end = nullptr;
  const double x = std::strtod(s.c_str(), &end);
  if (s.empty() || *end != '\0' || !std::isfinite(x)) return false;
  *v = x;
  return true;
}

bool parseInt(const std::string& s, long* v) {
  char* end = nullptr;
  const long x = std::strtol(s.c_str(), &end, 10);
  if (s.empty() || *end != '\0') return false;
  *v = x;
  return true;
}

struct PeerArgs {
  std::string dataset_dir, camera_file, output;
  long max_frames = -1;
  pplvo::peer::PeerOdometryOptions options;
};

/// One option with a value that tunes the odometry (--method, --max-frames, --failure,
/// --max-points-part, --max-depth, --keyframe-translation, --keyframe-rotation); false, with
/// the message printed, when the value is bad. `*keyframe_threshold_given` is set by the
/// keyframe thresholds.
bool readTuningValue(const std::string& a, const std::string& v, PeerArgs* args,
                     bool* keyframe_threshold_given) {
  namespace peer = pplvo::peer;
  peer::PeerOdometryOptions& options = args->options;
  if (a == "--method") {
    if (!peer::parseMethod(v, &options.method)) {
      std::cerr << "pplvo-peer-odometry: unknown --method '" << v
                << "' (expected rgbd, icp or rgbd_icp)\n";
      return false;
    }
  } else if (a == "--max-frames") {
    if (!parseInt(v, &args->max_frames) || args->max_frames <= 0) {
      std::cerr << "pplvo-peer-odometry: --max-frames needs a positive integer, got '" << v
                << "'\n";
      return false;
    }
  } else if (a == "--failure") {
    if (v == "hold") {
      options.failure_policy = peer::FailurePolicy::kHoldPose;
    } else if (v == "constant_velocity") {
      options.failure_policy = peer::FailurePolicy::kConstantVelocity;
    } else {
      std::cerr << "pplvo-peer-odometry: unknown --failure '" << v
                << "' (expected hold or constant_velocity)\n";
      return false;
    }
  } else if (a == "--max-points-part" || a == "--max-depth") {
    double x = 0;
    const bool part = a == "--max-points-part";
    if (!parseDouble(v, &x) || x <= 0 || (part && x > 1)) {
      std::cerr << "pplvo-peer-odometry: " << a << " needs a number in "
                << (part ? "(0, 1]" : "(0, inf)") << ", got '" << v << "'\n";
      return false;
    }
    (part ? options.max_points_part : options.max_depth_m) = static_cast<float>(x);
  } else {  // --keyframe-translation, --keyframe-rotation
    double x = 0;
    if (!parseDouble(v, &x) || x < 0) {
      std::cerr << "pplvo-peer-odometry: " << a << " needs a number >= 0, got '" << v << "'\n";
      return false;
    }
    (a == "--keyframe-translation" ? options.keyframe_translation_m
                                   : options.keyframe_rotation_deg) = x;
    *keyframe_threshold_given = true;
  }
  return true;
}

/// The command line; an exit status when the program ends here (0 for --help, 2 for an
/// error, with its message printed).
std::optional<int> parseArgs(int argc, char** argv, PeerArgs* args) {
  namespace peer = pplvo::peer;
  bool keyframe_threshold_given = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](std::string* out) {
      if (i + 1 >= argc) {
        std::cerr << "pplvo-peer-odometry: " << a << " needs a value\n";
        return false;
      }
      *out = argv[++i];
      return true;
    };
    std::string v;
    if (a == "-h" || a == "--help") {
      usage(std::cout);
      return 0;
    } else if (a == "--dataset") {
      if (!value(&args->dataset_dir)) return 2;
    } else if (a == "--camera") {
      if (!value(&args->camera_file)) return 2;
    } else if (a == "--output") {
      if (!value(&args->output)) return 2;
    } else if (a == "--method" || a == "--max-frames" || a == "--failure" ||
               a == "--max-points-part" || a == "--max-depth" || a == "--keyframe-translation" ||
               a == "--keyframe-rotation") {
      if (!value(&v) || !readTuningValue(a, v, args, &keyframe_threshold_given)) return 2;
    } else if (a == "--keyframes") {
      args->options.reference_mode = peer::ReferenceMode::kKeyframe;
    } else if (a == "--signed-camera") {
      args->options.mirror_handling = peer::MirrorHandling::kSignedMatrix;
    } else {
      std::cerr << "pplvo-peer-odometry: unknown argument '" << a << "'\n";
      usage(std::cerr);
      return 2;
    }
  }
  if (keyframe_threshold_given && args->options.reference_mode != peer::ReferenceMode::kKeyframe) {
    std::cerr << "pplvo-peer-odometry: --keyframe-translation and --keyframe-rotation need "
                 "--keyframes\n";
    return 2;
  }
  if (args->dataset_dir.empty() || args->output.empty()) {
    std::cerr << "pplvo-peer-odometry: --dataset and --output are required\n";
    usage(std::cerr);
    return 2;
  }
  return std::nullopt;
}

/// The dataset, camera and odometry settings, before the run.
void printSetup(const std::string& dataset_dir, const pplvo::dataset::Dataset& data,
                const pplvo::peer::PeerOdometryOptions& options) {
  namespace peer = pplvo::peer;
  std::cout << "dataset: " << dataset_dir << "\n  " << data.index().summary.text() << "\n";
  const auto& cam = data.camera().camera;
  std::cout << "camera: " << cam.width << "x" << cam.height << " fx " << cam.fx << " fy " << cam.fy
            << " cx " << cam.cx << " cy " << cam.cy << " (" << data.camera().source << ")\n";
  if (cam.hasDistortion()) {
    std::cout << "warning: the camera has distortion coefficients; OpenCV's odometry "
                 "ignores them\n";
  }
  std::cout << "method: " << peer::methodName(options.method) << " (max_points_part "
            << options.max_points_part << ", depth (" << options.min_depth_m << ", "
            << options.max_depth_m << ") m, mirrored camera: "
            << (options.mirror_handling == peer::MirrorHandling::kFlipImage ? "flip images"
                                                                            : "signed matrix")
            << ")\n";
  if (options.reference_mode == peer::ReferenceMode::kKeyframe) {
    std::cout << "reference: keyframe (new keyframe beyond " << options.keyframe_translation_m
              << " m or " << options.keyframe_rotation_deg
              << " deg from it, or after a fallback to the previous frame)\n";
  } else {
    std::cout << "reference: previous frame\n";
  }
}

/// The poses of the first `n` frames; an unreadable frame is skipped (no pose written) and
/// counted.
struct PeerRun {
  pplvo::Trajectory trajectory;
  int64_t load_failures = 0;
  std::string first_load_error;
};
PeerRun runOdometry(const pplvo::dataset::Dataset& data, size_t n,
                    pplvo::peer::PeerOdometry& odometry) {
  PeerRun run;
  run.trajectory.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    pplvo::RgbdFrame frame;
    try {
      frame = data.loadFrame(i);
    } catch (const pplvo::dataset::FrameLoadError& e) {
      if (run.load_failures++ == 0) run.first_load_error = e.what();
      continue;
    }
    const pplvo::peer::PeerFrameResult r = odometry.process(frame);
    pplvo::StampedPose p;
    p.stamp_text = frame.stamp;
    p.stamp = data.entry(i).stamp;
    p.T_w_c = r.T_w_c;
    run.trajectory.push_back(p);
  }
  return run;
}

/// The counts and times of the run.
void printStats(const pplvo::peer::PeerStats& s, const PeerRun& run, bool keyframes,
                const std::string& output) {
  std::printf(
      "frames: %lld processed, %lld tracked, %lld failures (no_depth %lld, "
      "not_converged %lld, bad_input %lld, opencv_error %lld), %lld reference resets, "
      "%lld unreadable frames skipped\n",
      static_cast<long long>(s.frames), static_cast<long long>(s.tracked),
      static_cast<long long>(s.failures), static_cast<long long>(s.no_depth),
      static_cast<long long>(s.not_converged), static_cast<long long>(s.bad_input),
      static_cast<long long>(s.opencv_errors), static_cast<long long>(s.reference_resets),
      static_cast<long long>(run.load_failures));
  if (keyframes) {
    std::printf(
        "keyframes: %lld (%lld by motion, %lld after a fallback to the previous frame, the "
        "rest first frame or reference resets)\n",
        static_cast<long long>(s.keyframes), static_cast<long long>(s.keyframes_by_motion),
        static_cast<long long>(s.keyframe_fallbacks));
  }
  if (run.load_failures > 0) {
    std::printf("first unreadable frame: %s\n", run.first_load_error.c_str());
  }
  const double mean_ms = s.meanMs();
  std::printf("time per frame: mean %.2f ms, max %.2f ms; %.1f frames/s (odometry only)\n", mean_ms,
              s.max_ms, mean_ms > 0 ? 1000.0 / mean_ms : 0.0);
  std::printf("trajectory: %zu poses written to %s\n", run.trajectory.size(), output.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  pplvo::keepFrameBuffersMapped();  // frame-sized buffers: no page faults per frame
  using namespace pplvo;
  PeerArgs args;
  if (const std::optional<int> status = parseArgs(argc, argv, &args)) return *status;
  const peer::PeerOdometryOptions& options = args.options;

  try {
    dataset::DatasetOptions dataset_options;
    dataset_options.camera_file = args.camera_file;  // a folder without calib_params.xml
    const dataset::Dataset data = dataset::Dataset::open(args.dataset_dir, dataset_options);
    printSetup(args.dataset_dir, data, options);
    size_t n = data.size();
    if (args.max_frames > 0 && static_cast<size_t>(args.max_frames) < n) {
      n = static_cast<size_t>(args.max_frames);
    }
    peer::PeerOdometry odometry(options);
    const PeerRun run = runOdometry(data, n, odometry);
    if (run.trajectory.empty()) {
      std::cerr << "pplvo-peer-odometry: no frame of " << args.dataset_dir << " could be loaded"
                << (run.first_load_error.empty() ? "" : ": " + run.first_load_error) << "\n";
      return 1;
    }
    writeTumTrajectory(args.output, run.trajectory);
    printStats(odometry.stats(), run, options.reference_mode == peer::ReferenceMode::kKeyframe,
               args.output);
    return 0;
  } catch (const dataset::DatasetError& e) {
    std::cerr << "pplvo-peer-odometry: bad dataset: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "pplvo-peer-odometry: " << e.what() << "\n";
    return 1;
  }
}

// pplvo-export: what a run knows of the scene as PLY files for a 3D viewer (MeshLab,
// CloudCompare, Open3D): the keyframes' 3D points, line segments and plane segments.
#include <cstdio>
#include <string>

#include "pplvo/export/scene_export.h"

namespace {

void usage(FILE* out) {
  std::fprintf(out,
               "usage: pplvo-export --log RUN.lcmlog --output DIR [--all-frames]\n"
               "                    [--max-point-sigma M]\n"
               "Writes DIR/points.ply, DIR/lines.ply and DIR/planes.ply in the world frame (the\n"
               "first camera's) from a run's event log (pplvo-run --log, or pplvo-logger with\n"
               "PPLVO_POSE and PPLVO_FEATURES_3D).\n"
               "  --all-frames         every posed frame, not only the keyframes\n"
               "  --max-point-sigma M  leave out points less certain than M metres (0.05)\n"
               "Exit: 0 written, 1 the log cannot be read or holds no posed lifted frame, 2 bad\n"
               "command line.\n");
}

}  // namespace

int main(int argc, char** argv) {
  std::string log, output;
  pplvo::exporting::LogExportOptions options;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      usage(stdout);
      return 0;
    }
    if (a == "--all-frames") {
      options.all_frames = true;
      continue;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "pplvo-export: %s needs a value\n", a.c_str());
      return 2;
    }
    const std::string v = argv[++i];
    if (a == "--log") {
      log = v;
    } else if (a == "--output") {
      output = v;
    } else if (a == "--max-point-sigma") {
      try {
        options.max_point_sigma_m = std::stod(v);
      } catch (...) {
        options.max_point_sigma_m = -1;
      }
      if (!(options.max_point_sigma_m > 0)) {
        std::fprintf(stderr, "pplvo-export: --max-point-sigma needs a positive number\n");
        return 2;
      }
    } else {
      std::fprintf(stderr, "pplvo-export: unknown option %s\n", a.c_str());
      usage(stderr);
      return 2;
    }
  }
  if (log.empty() || output.empty()) {
    usage(stderr);
    return 2;
  }
  try {
    int skipped = 0;
    const pplvo::exporting::SceneExport scene =
        pplvo::exporting::exportFromLog(log, options, &skipped);
    pplvo::exporting::writePly(scene, output);
    std::printf("keyframes: %d\npoints: %zu\nlines: %zu\nplanes: %zu\nskipped_messages: %d\n",
                scene.keyframes, scene.points.size(), scene.lines.size(),
                scene.plane_outlines.size(), skipped);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pplvo-export: %s\n", e.what());
    return 1;
  }
}

// pplvo-export's library on a real run: pplvo-run --log over a synthetic room, exported. Every
// primitive must lie in the room (the truth: the room is [0,6] x [0,5] x [0,3] m in the
// generator's world, the export in the first camera's), every plane outline on its plane, and
// a log without the needed channels refused with a clear error.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "pplvo/export/scene_export.h"
#include "pplvo/fixtures/cameras.h"
#include "pplvo/fixtures/synthetic_sequence.h"
#include "pplvo/run/run_pipeline.h"

namespace pplvo::exporting {
namespace {

namespace fs = std::filesystem;

bool insideRoom(const Eigen::Vector3d& p_room, double margin) {
  return p_room.x() > -margin && p_room.x() < 6 + margin && p_room.y() > -margin &&
         p_room.y() < 5 + margin && p_room.z() > -margin && p_room.z() < 3 + margin;
}

/// The element counts of a PLY header: "vertex" -> n, ...
std::map<std::string, size_t> plyElements(const fs::path& path) {
  std::ifstream in(path);
  std::map<std::string, size_t> counts;
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "ply") << path;
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream s(line);
    std::string word, name;
    size_t n = 0;
    if (s >> word >> name >> n && word == "element") counts[name] = n;
  }
  return counts;
}

TEST(Export, RunLogToPlyEveryPrimitiveInTheRoom) {
  const fs::path dir = fs::temp_directory_path() / ("pplvo_export_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  synth::SynthOptions o;
  o.frames = 40;
  o.seed = 7;
  o.setCamera(fixtures::kinectQvgaCamera());
  const synth::SyntheticSequence seq(o);
  synth::writeTumFolder(seq, (dir / "seq").string());
  run::RunOptions r;
  r.dataset_dir = (dir / "seq").string();
  r.log = (dir / "run.lcmlog").string();
  const run::RunResult result = run::runPipeline(r);
  ASSERT_FALSE(result.failed) << result.error;

  int skipped = -1;
  const SceneExport scene = exportFromLog(r.log, {}, &skipped);
  EXPECT_EQ(skipped, 0);
  EXPECT_GE(scene.keyframes, 2);
  EXPECT_GT(scene.points.size(), 100u);
  EXPECT_GT(scene.lines.size(), 10u);
  EXPECT_GT(scene.plane_outlines.size(), 3u);
  // The export's world is the first camera's; the generator's room is in its own world.
  const Pose3 T_room_w = seq.pose(0);
  size_t inside = 0;
  for (const Eigen::Vector3d& p : scene.points) inside += insideRoom(T_room_w * p, 0.05);
  EXPECT_GE(inside, scene.points.size() * 98 / 100) << inside << " of " << scene.points.size();
  for (const auto& [a, b] : scene.lines) {
    EXPECT_TRUE(insideRoom(T_room_w * a, 0.1) && insideRoom(T_room_w * b, 0.1));
  }
  for (size_t i = 0; i < scene.plane_outlines.size(); ++i) {
    const std::vector<Eigen::Vector3d>& outline = scene.plane_outlines[i];
    ASSERT_GE(outline.size(), 3u);
    // Flat: every vertex on the plane through the first one with the plane's normal.
    for (const Eigen::Vector3d& v : outline) {
      EXPECT_NEAR(scene.plane_normals[i].dot(v - outline[0]), 0.0, 1e-6);
      // The far corners of an outline are cast along grazing rays: within 5 cm plus 5 % of
      // their distance from the first camera (measured: floor corners 10-15 cm past the wall
      // at 3.1-4.4 m).
      const Eigen::Vector3d v_room = T_room_w * v;
      EXPECT_TRUE(insideRoom(v_room, 0.05 + 0.05 * v.norm())) << v_room.transpose();
    }
  }
  // With every frame instead of the keyframes: more of the same.
  LogExportOptions all;
  all.all_frames = true;
  EXPECT_GT(exportFromLog(r.log, all).keyframes, scene.keyframes);

  writePly(scene, (dir / "ply").string());
  EXPECT_EQ(plyElements(dir / "ply" / "points.ply")["vertex"], scene.points.size());
  EXPECT_EQ(plyElements(dir / "ply" / "lines.ply")["edge"], scene.lines.size());
  EXPECT_EQ(plyElements(dir / "ply" / "planes.ply")["face"], scene.plane_outlines.size());

  // A log cut mid-event (a killed logger): its complete events, the cut counted.
  const fs::path cut = dir / "cut.lcmlog";
  fs::copy_file(r.log, cut);
  fs::resize_file(cut, fs::file_size(cut) - 1000);
  int cut_skipped = 0;
  const SceneExport partial = exportFromLog(cut.string(), {}, &cut_skipped);
  EXPECT_EQ(cut_skipped, 1);
  EXPECT_GE(partial.keyframes, 1);
  EXPECT_LE(partial.points.size(), scene.points.size());

  // Refused with a clear error: no log, and a log of poses only.
  EXPECT_THROW(exportFromLog((dir / "missing.lcmlog").string(), {}), std::runtime_error);
  run::RunOptions poses_only = r;
  poses_only.log = (dir / "poses.lcmlog").string();
  poses_only.log_channels = "PPLVO_POSE";
  ASSERT_FALSE(run::runPipeline(poses_only).failed);
  try {
    exportFromLog(poses_only.log, {});
    ADD_FAILURE() << "a log without lifted features was exported";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("PPLVO_FEATURES_3D"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace pplvo::exporting

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "pplvo/pipeline/pipeline_config.h"

namespace pplvo::pipeline {
namespace {

std::string sourceDir() {
  const char* dir = std::getenv("PPLVO_SOURCE_DIR");
  return dir ? dir : ".";
}

std::string join(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += l + "\n";
  return s;
}

/// The message of the ConfigError thrown by `f` (fails the test if none is thrown).
std::string configError(const std::function<void()>& f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected a ConfigError";
  return "";
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

/// Dotted paths of the leaves of a YAML tree.
void leafKeys(const YAML::Node& node, const std::string& prefix, std::vector<std::string>* out) {
  if (node.IsMap()) {
    for (const auto& kv : node) {
      leafKeys(kv.second, prefix + (prefix.empty() ? "" : ".") + kv.first.Scalar(), out);
    }
  } else {
    out->push_back(prefix);
  }
}

std::vector<std::string> flattenedKeys(const PipelineOptions& o) {
  std::vector<std::string> keys;
  for (const auto& e : flattenPipelineConfig(o)) keys.push_back(e.key);
  return keys;
}

/// config/minimal.yaml: the keys a user sets, at their defaults; its commented ablation block
/// is valid configuration once uncommented.
TEST(PipelineConfig, MinimalFileHoldsDefaultsAndItsAblationsParse) {
  const std::string path = sourceDir() + "/config/minimal.yaml";
  const PipelineOptions defaults;
  const PipelineOptions loaded = loadPipelineConfig(path);
  EXPECT_TRUE(diffPipelineOptions(loaded, defaults).empty())
      << join(diffPipelineOptions(loaded, defaults));
  std::vector<std::string> keys;
  leafKeys(YAML::LoadFile(path), "", &keys);
  EXPECT_GE(keys.size(), 8u);
  EXPECT_LE(keys.size(), 15u);  // minimal: the full list is config/pplvo.yaml
  // The ablation block: every line after its heading, "# " removed, up to a trailing comment.
  std::ifstream f(path);
  std::string line, ablations;
  bool in_block = false;
  while (std::getline(f, line)) {
    if (line.find("--- Ablations") != std::string::npos) in_block = true;
    if (!in_block || line.rfind("# ", 0) != 0) continue;
    const std::string text = line.substr(2);
    if (text.find(':') == std::string::npos) continue;  // prose
    ablations += text.substr(0, text.find("  #")) + "\n";
  }
  ASSERT_NE(ablations.find("reference: keyframe"), std::string::npos) << ablations;
  const PipelineOptions parsed = parsePipelineConfig(ablations);
  EXPECT_TRUE(diffPipelineOptions(parsed, defaults).empty()) << ablations;
}

TEST(PipelineConfig, DefaultFileEqualsCodeDefaults) {
  const std::string path = sourceDir() + "/config/pplvo.yaml";
  const PipelineOptions defaults;
  const PipelineOptions loaded = loadPipelineConfig(path);
  const std::vector<std::string> diff = diffPipelineOptions(loaded, defaults);

  // The file holds every parameter, in the code's order, and nothing else.
  std::vector<std::string> file_keys;
  leafKeys(YAML::LoadFile(path), "", &file_keys);
  const std::vector<std::string> code_keys = flattenedKeys(defaults);

  if (!diff.empty() || file_keys != code_keys || [&] {
        std::ifstream f(path);
        std::stringstream t;
        t << f.rdbuf();
        return t.str() != dumpPipelineConfig(defaults);
      }()) {
    const char* bin = std::getenv("PPLVO_BINARY_DIR");
    const std::string out = std::string(bin ? bin : "/tmp") + "/pplvo.default.yaml";
    std::ofstream(out) << dumpPipelineConfig(defaults);
    ADD_FAILURE() << "config/pplvo.yaml has drifted from the code's defaults; the current "
                     "defaults are written to "
                  << out << "\nvalues that differ (file != code):\n"
                  << join(diff);
  }
  EXPECT_EQ(file_keys, code_keys);
  // Generated, comments included: regenerate with the file written above.
  std::ifstream file(path);
  std::stringstream file_text;
  file_text << file.rdbuf();
  EXPECT_TRUE(file_text.str() == dumpPipelineConfig(defaults))
      << "config/pplvo.yaml is not the dump of the defaults (comments or order differ)";
  // A few of the paper's values, as read from the file.
  EXPECT_EQ(loaded.depth_filter.model, depth_filter::DepthModel::kOgm);
  EXPECT_EQ(loaded.depth_filter.ogm.max_window, 10);
  EXPECT_EQ(loaded.depth_filter.ogm.k_consistency, 5);
  EXPECT_DOUBLE_EQ(loaded.depth_filter.ogm.gate_sigma, 3.0);
  EXPECT_DOUBLE_EQ(loaded.depth_filter.sensor.sigma_z_coeff_per_m, 1.425e-3);
  EXPECT_DOUBLE_EQ(loaded.odometry.tracker.estimator.plane_scale_alpha, 0.02);
  EXPECT_DOUBLE_EQ(loaded.odometry.plane_matching.min_overlap_fraction, 0.5);
  EXPECT_DOUBLE_EQ(loaded.odometry.plane_matching.max_normal_angle_deg, 10.0);
  EXPECT_DOUBLE_EQ(loaded.odometry.plane_matching.max_d_diff_m, 0.10);
  EXPECT_DOUBLE_EQ(loaded.frontend.lift.pixel_variance_px2, 1.0 / 12.0);
  EXPECT_EQ(loaded.frontend.lift.max_line_samples, 100);
  EXPECT_EQ(loaded.odometry.tracker.window_length, 10);
}

TEST(PipelineConfig, DumpOfDefaultsIsDocumentedAndValid) {
  const PipelineOptions defaults;
  EXPECT_TRUE(validatePipelineOptions(defaults).empty()) << join(validatePipelineOptions(defaults));
  for (const ConfigEntry& e : flattenPipelineConfig(defaults)) {
    EXPECT_FALSE(e.doc.empty()) << e.key << " has no documentation";
    EXPECT_FALSE(e.value.empty()) << e.key;
  }
  const std::string dump = dumpPipelineConfig(defaults);
  EXPECT_TRUE(contains(dump, "features: [points, lines, planes]")) << dump;
  EXPECT_TRUE(contains(dump, "Sec. 3.4")) << dump;
  EXPECT_TRUE(contains(dump, "    max_window: 10\n")) << dump;
  EXPECT_TRUE(contains(dump, "sigma_z_coeff_per_m: 0.001425\n")) << dump;
  // Every parameter line is preceded by its comment.
  std::istringstream lines(dump);
  std::string line, previous;
  while (std::getline(lines, line)) {
    const auto colon = line.find(": ");
    if (colon != std::string::npos && line.find('#') == std::string::npos) {
      EXPECT_NE(previous.find('#'), std::string::npos) << "undocumented: " << line;
    }
    previous = line;
  }
}

TEST(PipelineConfig, DumpParseRoundTripWithNonDefaultValues) {
  PipelineOptions o;
  o.setFamilies({true, false, true});
  o.depth_filter.model = depth_filter::DepthModel::kCgm;
  o.depth_filter.sensor.sigma_z_coeff_per_m = 0.1 + 0.2;  // not exactly 0.3
  o.depth_filter.cgm.missing_centre_stays_missing = false;
  o.depth_filter.ogm.max_window = 7;
  o.depth_filter.ogm.k_consistency = 3;
  o.depth_filter.ogm.gate_sigma = std::sqrt(2.0);
  o.depth_filter.ogm.max_translation_variance_m2 = 2.5e-7;
  o.frontend.points.detector = features::PointDetector::kSift;
  o.frontend.points.max_points = 1234;
  o.frontend.points.oversample = 1.0 / 3.0;
  o.frontend.points.oversample = 1.5;
  o.frontend.lines.detection_scale = 0.5;
  o.frontend.lines.lbd_band_width = 5;
  o.frontend.planes.cell_size_px = 16;
  o.frontend.planes.noise.sigma_z_floor_m = 3e-5;
  o.frontend.planes.fit.outlier_sigma = 0.0;
  o.frontend.lift.seed = 18446744073709551557ull;
  o.frontend.lift.line_fit.weighting = geometry::LineFitOptions::Weighting::kPaperScalar;
  o.frontend.lift.max_line_samples = 64;
  o.frontend.planes_from_fused_depth = false;
  o.frontend.fused_planes_only_for_references = false;
  o.odometry.tracker.window_length = 12;
  o.odometry.tracker.estimator.plane_scale_alpha = 0.05;
  o.odometry.tracker.estimator.point_sigma_px = 1.0 / 7.0;
  o.odometry.tracker.estimator.use_tukey = false;
  o.odometry.point_matching.max_hamming_bits = -1.0;
  o.odometry.line_matching.max_angle_deg = 7.5;
  o.odometry.plane_matching.min_overlap_fraction = 0.25;
  o.odometry.predict_plane_positions = false;
  // The sensor model's copies are not in the file: set in code, they must agree.
  EXPECT_FALSE(validatePipelineOptions(o).empty());
  o.shareSensorModel();
  EXPECT_EQ(o.frontend.lift.noise.sigma_z_coeff_per_m, 0.1 + 0.2);
  EXPECT_EQ(o.frontend.planes.noise.sigma_z_coeff_per_m, 0.1 + 0.2);
  ASSERT_TRUE(validatePipelineOptions(o).empty()) << join(validatePipelineOptions(o));

  const std::string dump = dumpPipelineConfig(o);
  const PipelineOptions back = parsePipelineConfig(dump);
  EXPECT_TRUE(diffPipelineOptions(back, o).empty()) << join(diffPipelineOptions(back, o));
  // The comparison itself sees changes (it is not vacuous).
  EXPECT_FALSE(diffPipelineOptions(back, PipelineOptions()).empty());
  // Bit-exact doubles, enums, 64-bit seed and the families on both sides.
  EXPECT_EQ(back.depth_filter.sensor.sigma_z_coeff_per_m, 0.1 + 0.2);
  EXPECT_EQ(back.depth_filter.ogm.gate_sigma, std::sqrt(2.0));
  EXPECT_EQ(back.odometry.tracker.estimator.point_sigma_px, 1.0 / 7.0);
  EXPECT_EQ(back.depth_filter.model, depth_filter::DepthModel::kCgm);
  EXPECT_EQ(back.frontend.points.detector, features::PointDetector::kSift);
  EXPECT_EQ(back.frontend.lift.line_fit.weighting,
            geometry::LineFitOptions::Weighting::kPaperScalar);
  EXPECT_EQ(back.frontend.lift.seed, 18446744073709551557ull);
  EXPECT_TRUE(back.frontend.families.points);
  EXPECT_FALSE(back.frontend.families.lines);
  EXPECT_TRUE(back.frontend.families.planes);
  EXPECT_FALSE(back.odometry.tracker.estimator.use_lines);
  EXPECT_TRUE(back.odometry.tracker.estimator.use_planes);
  EXPECT_TRUE(contains(dump, "features: [points, planes]")) << dump;
}

TEST(PipelineConfig, DiffNamesTheKeyThatDiffers) {
  PipelineOptions a, b;
  b.odometry.line_matching.max_rho_px = 41.0;
  const auto diff = diffPipelineOptions(a, b);
  ASSERT_EQ(diff.size(), 1u);
  EXPECT_EQ(diff[0], "odometry.line_matching.max_rho_px: 40.0 != 41.0");
}

TEST(PipelineConfig, PartialFileKeepsBaseValues) {
  PipelineOptions base;
  base.frontend.points.max_points = 500;
  const PipelineOptions o = parsePipelineConfig("depth_filter:\n  ogm:\n    max_window: 5\n", base);
  EXPECT_EQ(o.depth_filter.ogm.max_window, 5);
  EXPECT_EQ(o.frontend.points.max_points, 500);
  EXPECT_EQ(o.depth_filter.ogm.k_consistency, 5);
  EXPECT_TRUE(diffPipelineOptions(parsePipelineConfig(""), PipelineOptions()).empty());
}

TEST(PipelineConfig, UnknownKeyAndBadValueReportedTogether) {
  const std::string yaml =
      "depth_filter:\n"
      "  ogm:\n"
      "    max_windw: 5\n"         // unknown key (typo)
      "    k_consistency: five\n"  // bad value
      "    gate_sigma: -3\n"       // out of range
      "frontend:\n"
      "  points:\n"
      "    max_points: 10.5\n"  // not an integer
      "odometry:\n"
      "  predict_point_positions: maybe\n"  // not a bool
      "colour: blue\n";                     // unknown top-level key
  const std::string msg = configError([&] { parsePipelineConfig(yaml); });
  EXPECT_TRUE(contains(msg, "6 error(s)")) << msg;
  EXPECT_TRUE(contains(msg, "depth_filter.ogm.max_windw: unknown key")) << msg;
  EXPECT_TRUE(contains(msg, "depth_filter.ogm.k_consistency: cannot read 'five' as an integer"))
      << msg;
  EXPECT_TRUE(contains(msg, "depth_filter.ogm.gate_sigma: -3.0 is out of range (must be > 0.0)"))
      << msg;
  EXPECT_TRUE(contains(msg, "frontend.points.max_points: cannot read '10.5'")) << msg;
  EXPECT_TRUE(contains(msg, "odometry.predict_point_positions: cannot read 'maybe'")) << msg;
  EXPECT_TRUE(contains(msg, "colour: unknown key")) << msg;
}

TEST(PipelineConfig, OutOfRangeValuesAreErrors) {
  const std::string msg = configError([] {
    parsePipelineConfig(
        "depth_filter: {ogm: {max_window: -10}}\n"
        "odometry: {tracker: {window_length: 0}, plane_matching: {min_overlap_fraction: 1.5}}\n"
        "frontend: {lines: {detection_scale: .nan}}\n");
  });
  EXPECT_TRUE(contains(msg, "4 error(s)")) << msg;
  EXPECT_TRUE(contains(msg, "depth_filter.ogm.max_window: -10 is out of range (must be >= 1)"))
      << msg;
  EXPECT_TRUE(contains(msg, "odometry.tracker.window_length: 0 is out of range")) << msg;
  EXPECT_TRUE(contains(msg, "odometry.plane_matching.min_overlap_fraction: 1.5 is out of range"))
      << msg;
  EXPECT_TRUE(contains(msg, "frontend.lines.detection_scale: .nan is not a finite number")) << msg;
}

TEST(PipelineConfig, TrackerWindowMustCoverFusionWindow) {
  const std::string msg =
      configError([] { parsePipelineConfig("odometry: {tracker: {window_length: 5}}\n"); });
  EXPECT_TRUE(contains(msg, "window_length: 5 is shorter than depth_filter.ogm.max_window 10"))
      << msg;
  // Without O-GM there is no fusion window to cover.
  EXPECT_NO_THROW(
      parsePipelineConfig("depth_filter: {model: cgm}\nodometry: {tracker: {window_length: 5}}\n"));
}

TEST(PipelineConfig, FeatureListParsing) {
  PipelineOptions o = parsePipelineConfig("features: [points, planes]\n");
  EXPECT_TRUE(o.frontend.families.points);
  EXPECT_FALSE(o.frontend.families.lines);
  EXPECT_TRUE(o.frontend.families.planes);
  EXPECT_TRUE(o.odometry.tracker.estimator.use_points);
  EXPECT_FALSE(o.odometry.tracker.estimator.use_lines);
  EXPECT_TRUE(o.odometry.tracker.estimator.use_planes);

  o = parsePipelineConfig("features: lines\n");
  EXPECT_FALSE(o.frontend.families.points);
  EXPECT_TRUE(o.frontend.families.lines);
  EXPECT_FALSE(o.odometry.tracker.estimator.use_points);

  o = parsePipelineConfig("features: points, lines\n");  // comma-separated string
  EXPECT_TRUE(o.frontend.families.points && o.frontend.families.lines);
  EXPECT_FALSE(o.frontend.families.planes);
  EXPECT_FALSE(o.odometry.tracker.estimator.use_planes);

  o = parsePipelineConfig("features: all\n");
  EXPECT_TRUE(o.frontend.families.points && o.frontend.families.lines &&
              o.frontend.families.planes);

  // A base whose families disagree is made consistent by the `features` list.
  PipelineOptions base;
  base.frontend.families.lines = false;
  o = parsePipelineConfig("", base);
  EXPECT_FALSE(o.odometry.tracker.estimator.use_lines);

  std::string msg = configError([] { parsePipelineConfig("features: [points, corners]\n"); });
  EXPECT_TRUE(contains(msg, "features: invalid feature list 'points,corners'")) << msg;
  msg = configError([] { parsePipelineConfig("features: []\n"); });
  EXPECT_TRUE(contains(msg, "features: invalid feature list")) << msg;
  msg = configError([] { parsePipelineConfig("features: {points: true}\n"); });
  EXPECT_TRUE(contains(msg, "features: expected a list")) << msg;
}

TEST(PipelineConfig, EstimatorFamilyFlagsAreNotSettable) {
  const std::string msg = configError(
      [] { parsePipelineConfig("odometry: {tracker: {estimator: {use_lines: false}}}\n"); });
  EXPECT_TRUE(contains(msg, "odometry.tracker.estimator.use_lines: not settable here")) << msg;
  EXPECT_TRUE(contains(msg, "`features`")) << msg;

  PipelineOptions o;
  o.frontend.families.planes = false;  // without setFamilies: disagreement
  const auto errors = validatePipelineOptions(o);
  ASSERT_EQ(errors.size(), 1u) << join(errors);
  EXPECT_TRUE(contains(errors[0], "disagree")) << errors[0];
  EXPECT_THROW(dumpPipelineConfig(o), ConfigError);
}

TEST(PipelineConfig, InvalidEnumStrings) {
  std::string msg = configError([] { parsePipelineConfig("depth_filter: {model: gaussian}\n"); });
  EXPECT_TRUE(contains(msg, "1 error(s)")) << msg;
  EXPECT_TRUE(contains(msg,
                       "depth_filter.model: invalid value 'gaussian' (choose one of: "
                       "sensor, cgm, ogm)"))
      << msg;
  msg = configError([] { parsePipelineConfig("depth_filter: {model: [ogm]}\n"); });
  EXPECT_TRUE(contains(msg, "depth_filter.model: expected a single value")) << msg;
  msg = configError([] { parsePipelineConfig("frontend: {points: {detector: surf}}\n"); });
  EXPECT_TRUE(contains(msg, "frontend.points.detector: invalid value 'surf'")) << msg;
  msg = configError(
      [] { parsePipelineConfig("frontend: {lift: {line_fit: {weighting: median}}}\n"); });
  EXPECT_TRUE(contains(msg, "frontend.lift.line_fit.weighting: invalid value 'median'")) << msg;

  EXPECT_EQ(parsePipelineConfig("depth_filter: {model: sensor}\n").depth_filter.model,
            depth_filter::DepthModel::kSensor);
  EXPECT_EQ(parsePipelineConfig("frontend: {points: {detector: akaze}}\n").frontend.points.detector,
            features::PointDetector::kAkaze);
}

TEST(PipelineConfig, StructuralErrors) {
  std::string msg = configError([] { parsePipelineConfig("- a\n- b\n"); });
  EXPECT_TRUE(contains(msg, "must be a map")) << msg;
  msg = configError([] { parsePipelineConfig("depth_filter: 3\n"); });
  EXPECT_TRUE(contains(msg, "depth_filter: expected a section")) << msg;
  msg = configError(
      [] { parsePipelineConfig("depth_filter: {ogm: {max_window: 4, max_window: 5}}\n"); });
  EXPECT_TRUE(contains(msg, "depth_filter.ogm.max_window: duplicate key")) << msg;
  msg = configError([] { parsePipelineConfig("depth_filter: {model: }\n"); });
  EXPECT_TRUE(contains(msg, "depth_filter.model: no value")) << msg;
  msg = configError([] { parsePipelineConfig("depth_filter: [unclosed\n"); });
  EXPECT_TRUE(contains(msg, "not valid YAML")) << msg;
}

TEST(PipelineConfig, LoadErrorsNameTheFile) {
  std::string msg = configError([] { loadPipelineConfig("/nonexistent/pplvo.yaml"); });
  EXPECT_TRUE(contains(msg, "/nonexistent/pplvo.yaml: cannot open")) << msg;

  const char* bin = std::getenv("PPLVO_BINARY_DIR");
  const std::string path = std::string(bin ? bin : "/tmp") + "/test_pipeline_config_bad.yaml";
  std::ofstream(path) << "depth_filter:\n  model: foo\n  sensr: {}\n";
  msg = configError([&] { loadPipelineConfig(path); });
  EXPECT_TRUE(contains(msg, path + ": configuration has 2 error(s)")) << msg;
  EXPECT_TRUE(contains(msg, "depth_filter.sensr: unknown key")) << msg;
  std::remove(path.c_str());
}

TEST(PipelineConfig, CommandLineOverrides) {
  PipelineOptions base;
  base.frontend.points.max_points = 500;
  const PipelineOptions o =
      applyPipelineOverrides({"depth_filter.ogm.max_window=5", "features=[points, planes]",
                              "depth_filter.model=cgm", "depth_filter.ogm.gate_sigma=2.5"},
                             base);
  EXPECT_EQ(o.depth_filter.ogm.max_window, 5);
  EXPECT_DOUBLE_EQ(o.depth_filter.ogm.gate_sigma, 2.5);
  EXPECT_EQ(o.depth_filter.model, depth_filter::DepthModel::kCgm);
  EXPECT_FALSE(o.frontend.families.lines);
  EXPECT_FALSE(o.odometry.tracker.estimator.use_lines);
  EXPECT_EQ(o.frontend.points.max_points, 500);

  std::string msg = configError([&] {
    applyPipelineOverrides({"depth_filter.ogm.max_windw=5", "depth_filter.ogm.k_consistency=x"},
                           base);
  });
  EXPECT_TRUE(contains(msg, "overrides: configuration has 2 error(s)")) << msg;
  EXPECT_TRUE(contains(msg, "depth_filter.ogm.max_windw: unknown key")) << msg;
  EXPECT_TRUE(contains(msg, "depth_filter.ogm.k_consistency: cannot read 'x'")) << msg;
  msg = configError([&] {
    applyPipelineOverrides({"depth_filter.ogm", "=3", "a..b=1", "x=1", "x.y=2"}, base);
  });
  EXPECT_TRUE(contains(msg, "4 error(s)")) << msg;
  EXPECT_TRUE(contains(msg, "'depth_filter.ogm': expected key=value")) << msg;
  EXPECT_TRUE(contains(msg, "'x.y=2': invalid or conflicting key")) << msg;
}

/// Collects dotted keys from the libraries' own schemas (visit(V&, Options&) beside each
/// options struct), to check that the configuration composes exactly those fields.
struct KeyCollector {
  std::string prefix;
  std::vector<std::string> keys;
  template <typename T>
  void field(const std::string& key, T&, const std::string& = "",
             const config::Range& = config::anyValue()) {
    keys.push_back(prefix + key);
  }
  void forbid(const std::string&, const std::string&) {}
  void section(const std::string& key, const std::string&, const std::function<void()>& body) {
    const std::string saved = prefix;
    prefix += key + ".";
    body();
    prefix = saved;
  }
};

std::vector<std::string> keysUnder(const std::string& prefix) {
  std::vector<std::string> keys;
  for (const auto& k : flattenedKeys(PipelineOptions())) {
    if (k.rfind(prefix, 0) == 0) keys.push_back(k);
  }
  return keys;
}

TEST(PipelineConfig, FieldListsMatchTheLibrariesOwnLists) {
  PipelineOptions o;
  const auto sameKeys = [](const std::string& prefix, auto& options) {
    KeyCollector c{prefix, {}};
    visit(c, options);
    EXPECT_EQ(c.keys, keysUnder(prefix)) << prefix;
  };
  sameKeys("frontend.points.", o.frontend.points);
  sameKeys("frontend.lines.", o.frontend.lines);
  sameKeys("odometry.point_matching.", o.odometry.point_matching);
  sameKeys("odometry.line_matching.", o.odometry.line_matching);
  sameKeys("depth_filter.", o.depth_filter);
  {
    KeyCollector c{"odometry.tracker.", {}};
    visit(c, o.odometry.tracker);
    std::set<std::string> expected(c.keys.begin(), c.keys.end());
    for (const char* k : {"use_points", "use_lines", "use_planes"})
      EXPECT_EQ(expected.erase(std::string("odometry.tracker.estimator.") + k), 1u);
    const auto ours = keysUnder("odometry.tracker.");
    EXPECT_EQ(std::set<std::string>(ours.begin(), ours.end()), expected);
  }
}

}  // namespace
}  // namespace pplvo::pipeline

#include "pplvo/pipeline/pipeline_config.h"

#include <yaml-cpp/yaml.h>

#include <string>
#include <vector>

#include "pplvo/core/config_visitor.h"

namespace pplvo::pipeline {

// The top-level `features` list: text and parsing of FeatureFamilies (found by the config
// visitors through ADL).
std::string configText(const FeatureFamilies& f) {
  std::string s;
  auto add = [&](bool on, const char* name) {
    if (!on) return;
    s += s.empty() ? "" : ", ";
    s += name;
  };
  add(f.points, "points");
  add(f.lines, "lines");
  add(f.planes, "planes");
  return "[" + s + "]";
}

std::string parseConfigValue(const YAML::Node& node, FeatureFamilies* value) {
  std::string list;
  if (node.IsSequence()) {
    for (const auto& item : node) {
      if (!item.IsScalar()) return "expected a list of names (points, lines, planes)";
      list += (list.empty() ? "" : ",") + item.Scalar();
    }
  } else if (node.IsScalar()) {
    for (char c : node.Scalar()) {
      if (c != ' ') list += c;
    }
  } else {
    return "expected a list such as [points, lines, planes]";
  }
  if (!parseFeatureFamilies(list, value))
    return "invalid feature list '" + list +
           "' (a non-empty subset of points, lines, planes, or all)";
  return "";
}

namespace {

const std::vector<std::string> kFamilyFlags = {"odometry.tracker.estimator.use_points",
                                               "odometry.tracker.estimator.use_lines",
                                               "odometry.tracker.estimator.use_planes"};
/// Copies of the sensor model (PipelineOptions::shareSensorModel), not settable on their own.
const std::vector<std::string> kSensorModelCopies = {
    "frontend.planes.noise.sigma_z_coeff_per_m", "frontend.lift.noise.sigma_z_coeff_per_m",
    "frontend.planes.pixel_variance_px2"};

/// The whole file: the modules' schemas (each declared beside its options struct) under their
/// sections, plus the top-level `features` list, which sets frontend.families and the
/// estimator's use_* together (those are therefore not settable on their own); the sensor
/// model's copies follow their source (depth_filter.sensor, frontend.lift) likewise.
struct VisitPipeline {
  template <class V>
  void operator()(V& visitor, PipelineOptions& o) const {
    config::ForbidPaths<V> sensor(visitor, kSensorModelCopies,
                                  "the sensor model is set once: "
                                  "depth_filter.sensor.sigma_z_coeff_per_m and "
                                  "frontend.lift.pixel_variance_px2");
    config::ForbidPaths<config::ForbidPaths<V>> v(
        sensor, kFamilyFlags, "the families are set once, by the top-level `features` list");
    FeatureFamilies families = o.frontend.families;
    v.field("features", families,
            "primitive families used for extraction, matching and estimation (the paper's "
            "ablations): any non-empty subset of [points, lines, planes]");
    depth_filter::visitConfigFile(v, o.depth_filter);
    v.section("frontend",
              "Feature frontend (paper Sec. 4.1-4.4): extraction, back-projection, WLS fitting",
              [&] { visit(v, o.frontend); });
    v.section("odometry",
              "Frame-to-frame odometry (paper Sec. 4.5-4.6): matching, pose estimation, "
              "pose uncertainty",
              [&] { visit(v, o.odometry); });
    o.setFamilies(families);
    o.shareSensorModel();
  }
};

const char* kHeader =
    "# pplvo configuration: every parameter of the pipeline (PipelineOptions).\n"
    "# Paper: Proenca & Gao, \"Probabilistic RGB-D Odometry based on Points, Lines and Planes\n"
    "# Under Depth Uncertainty\" (section numbers below refer to it). Defaults follow the\n"
    "# paper where it gives a value. Keys left out keep their defaults; unknown keys, bad values\n"
    "# and values outside the Range shown are errors (reported all together).\n"
    "# Documentation: docs/configuration.md. Written by dumpPipelineConfig(PipelineOptions());\n"
    "# the test test_pipeline_config fails if this file drifts from the code's defaults.\n";

bool familiesAgree(const PipelineOptions& o) {
  const FeatureFamilies& f = o.frontend.families;
  const estimator::PoseEstimatorOptions& e = o.odometry.tracker.estimator;
  return f.points == e.use_points && f.lines == e.use_lines && f.planes == e.use_planes;
}

std::string familiesDisagreement(const PipelineOptions& o) {
  const estimator::PoseEstimatorOptions& e = o.odometry.tracker.estimator;
  return "features: frontend.families " + configText(o.frontend.families) +
         " disagree with odometry.tracker.estimator.use_* " +
         configText(FeatureFamilies{e.use_points, e.use_lines, e.use_planes}) +
         " (set them with PipelineOptions::setFamilies)";
}

PipelineOptions parseNode(const YAML::Node& root, const PipelineOptions& base,
                          const std::string& where) {
  PipelineOptions o = base;
  o.setFamilies(base.frontend.families);
  std::vector<std::string> errors = config::readConfig(root, &o, VisitPipeline());
  if (errors.empty()) errors = crossModuleErrors(o);
  if (!errors.empty()) throw ConfigError(config::joinErrors(where, errors));
  return o;
}

}  // namespace

std::vector<std::string> crossModuleErrors(const PipelineOptions& o) {
  std::vector<std::string> errors;
  const FeatureFamilies& f = o.frontend.families;
  if (!f.points && !f.lines && !f.planes) errors.push_back("features: no feature family selected");
  if (!familiesAgree(o)) errors.push_back(familiesDisagreement(o));
  if (!o.sensorModelShared()) {
    errors.push_back(
        "frontend: the planes' and the lifting's sensor model differ from "
        "depth_filter.sensor.sigma_z_coeff_per_m / frontend.lift.pixel_variance_px2 (set them "
        "with PipelineOptions::shareSensorModel)");
  }
  if (o.depth_filter.model == depth_filter::DepthModel::kOgm &&
      o.odometry.tracker.window_length < o.depth_filter.ogm.max_window) {
    errors.push_back(
        "odometry.tracker.window_length: " + std::to_string(o.odometry.tracker.window_length) +
        " is shorter than depth_filter.ogm.max_window " +
        std::to_string(o.depth_filter.ogm.max_window) +
        " (the fusion window needs the uncertainty of every frame it holds)");
  }
  return errors;
}

PipelineOptions applyPipelineOverrides(const std::vector<std::string>& assignments,
                                       const PipelineOptions& base) {
  std::vector<std::string> errors;
  const YAML::Node root = config::overridesToYaml(assignments, &errors);
  if (!errors.empty()) throw ConfigError(config::joinErrors("overrides", errors));
  return parseNode(root, base, "overrides");
}

PipelineOptions parsePipelineConfig(const std::string& yaml_text, const PipelineOptions& base) {
  return parseNode(config::parseYamlText(yaml_text), base, "configuration text");
}

PipelineOptions loadPipelineConfig(const std::string& path, const PipelineOptions& base) {
  return parseNode(config::loadYamlFile(path), base, path);
}

std::vector<std::string> applyPipelineConfigArgs(const config::ConfigArgs& args,
                                                 PipelineOptions* options) {
  return config::applyConfigArgs(args, pipelineShortcuts(), options, VisitPipeline(),
                                 crossModuleErrors);
}

std::vector<config::Shortcut> pipelineShortcuts() {
  std::vector<config::Shortcut> s = {
      {"--features", "features", "LIST  points,lines,planes (any subset; default all)"}};
  for (const config::Shortcut& d : depth_filter::depthModelShortcut()) s.push_back(d);
  return s;
}

std::vector<std::string> validatePipelineOptions(const PipelineOptions& options) {
  // Ranges on a copy whose families agree (a disagreement is reported once, below).
  PipelineOptions o = options;
  o.setFamilies(options.frontend.families);
  std::vector<std::string> errors = config::rangeErrors(o, VisitPipeline());
  const std::vector<std::string> cross = crossModuleErrors(options);
  errors.insert(errors.end(), cross.begin(), cross.end());
  return errors;
}

std::string dumpPipelineConfig(const PipelineOptions& options) {
  if (!familiesAgree(options))
    throw ConfigError("dumpPipelineConfig: " + familiesDisagreement(options));
  return config::dumpConfig(options, VisitPipeline(), kHeader);
}

std::vector<ConfigEntry> flattenPipelineConfig(const PipelineOptions& options) {
  return config::flattenConfig(options, VisitPipeline());
}

std::vector<std::string> diffPipelineOptions(const PipelineOptions& a, const PipelineOptions& b) {
  const std::vector<ConfigEntry> ea = flattenPipelineConfig(a);
  const std::vector<ConfigEntry> eb = flattenPipelineConfig(b);
  std::vector<std::string> diff;
  for (size_t i = 0; i < ea.size() && i < eb.size(); ++i) {
    if (ea[i].value != eb[i].value)
      diff.push_back(ea[i].key + ": " + ea[i].value + " != " + eb[i].value);
  }
  // flatten() of two PipelineOptions always has the same keys; the estimator's use_* are
  // covered by `features` only when they agree with it, so compare them directly.
  const estimator::PoseEstimatorOptions& xa = a.odometry.tracker.estimator;
  const estimator::PoseEstimatorOptions& xb = b.odometry.tracker.estimator;
  const FeatureFamilies ua{xa.use_points, xa.use_lines, xa.use_planes};
  const FeatureFamilies ub{xb.use_points, xb.use_lines, xb.use_planes};
  if (configText(ua) != configText(ub))
    diff.push_back("odometry.tracker.estimator.use_*: " + configText(ua) + " != " + configText(ub));
  return diff;
}

}  // namespace pplvo::pipeline

#pragma once
/// The pipeline's YAML configuration (config/pplvo.yaml, docs/configuration.md): one file
/// with every parameter of PipelineOptions, grouped as depth_filter / frontend / odometry,
/// plus a top-level `features` list that selects the primitive families once (applied with
/// PipelineOptions::setFamilies, so the frontend and the estimator always agree).
///
/// Every options struct declares its schema once, beside the struct (a `visit` function with
/// names, docs and ranges; pplvo/core/config_schema.h); pipeline_config.cpp composes those
/// schemas into the file and adds the cross-module rules (crossModuleErrors). The one list
/// drives loading, dumping, flattening and validation (pplvo/core/config_visitor.h). Loading
/// collects every problem (unknown keys, values of the wrong type, invalid enum strings, values out
/// of range) and reports them together in one ConfigError. Missing keys keep their defaults.
#include <string>
#include <vector>

#include "pplvo/core/config_visitor.h"  // ConfigError
#include "pplvo/pipeline/pipeline_options.h"

namespace pplvo::pipeline {

/// Reads a configuration file. Keys absent from the file keep the values of `base`.
/// Throws ConfigError whose message names `path` and lists every problem (also when the file
/// cannot be read or is not valid YAML).
PipelineOptions loadPipelineConfig(const std::string& path,
                                   const PipelineOptions& base = PipelineOptions());

/// Same from YAML text (an empty text gives `base`). Throws ConfigError listing every problem.
PipelineOptions parsePipelineConfig(const std::string& yaml_text,
                                    const PipelineOptions& base = PipelineOptions());

/// Command-line overrides applied on top of `base`: each entry is "dotted.key=value" with the
/// value in YAML syntax, e.g. "depth_filter.ogm.max_window=5", "features=[points,planes]",
/// "depth_filter.model=cgm". Same checks and errors as a file (unknown keys, bad values,
/// ranges), plus entries without '=' or with an empty key or value. Throws ConfigError.
PipelineOptions applyPipelineOverrides(const std::vector<std::string>& assignments,
                                       const PipelineOptions& base);

/// Documented YAML (a comment above every key) that parses back to exactly the same values
/// (doubles are written with the shortest text that reads back bit for bit). Meant for the
/// "effective configuration" written at start-up and for regenerating config/pplvo.yaml.
/// Throws ConfigError if the options cannot be represented: frontend.families disagrees with
/// odometry.tracker.estimator.use_* (set them with PipelineOptions::setFamilies).
std::string dumpPipelineConfig(const PipelineOptions& options);

/// Range and cross-module problems of `options` (empty = valid), one "key.path: problem" per
/// entry. loadPipelineConfig / parsePipelineConfig already include these in their ConfigError;
/// call this for options built in code.
std::vector<std::string> validatePipelineOptions(const PipelineOptions& options);

/// Rules between modules, checked once on the final options (after the file, every --set
/// and every shortcut such as --depth-model): at least one feature family, the frontend's and
/// the estimator's families agree, and with O-GM the tracker's window
/// (odometry.tracker.window_length) covers the fusion window (depth_filter.ogm.max_window).
std::vector<std::string> crossModuleErrors(const PipelineOptions& options);

/// Command-line shortcuts of pipeline keys: --features (features), --depth-model
/// (depth_filter.model).
std::vector<config::Shortcut> pipelineShortcuts();

/// Applies --config, --set and the pipelineShortcuts() in that order, then crossModuleErrors()
/// once. Returns every problem (empty: `*options` holds the result).
std::vector<std::string> applyPipelineConfigArgs(const config::ConfigArgs& args,
                                                 PipelineOptions* options);

/// One parameter: its dotted key (e.g. "depth_filter.ogm.max_window"), its value as written
/// in the YAML, and its documentation.
using ConfigEntry = config::ConfigEntry;

/// Every parameter in file order (the same order and texts as dumpPipelineConfig).
std::vector<ConfigEntry> flattenPipelineConfig(const PipelineOptions& options);

/// Keys whose values differ, as "key: a_value != b_value" (empty = equal on every parameter).
std::vector<std::string> diffPipelineOptions(const PipelineOptions& a, const PipelineOptions& b);

}  // namespace pplvo::pipeline

#pragma once
/// The command-line options every program that runs (part of) the pipeline shares, on top of
/// pplvo::ArgParser (pplvo/core/args.h):
///   --config FILE        a pipeline YAML (config/pplvo.yaml), loaded first
///   --set KEY=VALUE      one value of that YAML by dotted key (repeatable), applied next
///   --features LIST      points,lines,planes (any subset)
///   --depth-model MODEL  sensor | cgm | ogm
///
///   PipelineArgs pa;
///   addPipelineOptions(parser, &pa);
///   parser.parse(args);
///   applyPipelineArgs(pa, &options, &parser);   // errors go to the parser
#include <string>
#include <vector>

#include "pplvo/core/args.h"
#include "pplvo/pipeline/pipeline_options.h"

namespace pplvo::pipeline {

struct PipelineArgs {
  std::string config;
  std::vector<std::string> overrides;  ///< --set, in order
  std::string features;
  std::string depth_model;
};

void addPipelineOptions(ArgParser& parser, PipelineArgs* args);

/// Applies the parsed options to `options` (config file, then --set, then --features and
/// --depth-model). Every problem (unreadable file, unknown key, bad value) is added to `parser`.
void applyPipelineArgs(const PipelineArgs& args, PipelineOptions* options, ArgParser* parser);

/// Usage lines of these options, for the programs' --help.
const char* pipelineOptionsUsage();

}  // namespace pplvo::pipeline

#pragma once
/// The command-line options every program that runs (part of) the pipeline shares, on top of
/// pplvo::ArgParser (pplvo/core/args.h):
///   --config FILE        a pipeline YAML (config/pplvo.yaml), loaded first
///   --set KEY=VALUE      one value of that YAML by dotted key (repeatable), applied next
///   --features LIST      = --set features=LIST
///   --depth-model MODEL  = --set depth_filter.model=MODEL
/// then the cross-module rules once (crossModuleErrors in pipeline_config.h).
///
///   PipelineArgs pa;
///   addPipelineOptions(parser, &pa);
///   parser.parse(args);
///   applyPipelineArgs(pa, &options, &parser);   // errors go to the parser
#include <string>

#include "pplvo/core/args.h"
#include "pplvo/core/config_visitor.h"
#include "pplvo/pipeline/pipeline_options.h"

namespace pplvo::pipeline {

using PipelineArgs = config::ConfigArgs;

void addPipelineOptions(ArgParser& parser, PipelineArgs* args);

/// Applies the parsed options to `options` (config file, then --set, then --features and
/// --depth-model, then the cross-module rules). Every problem (unreadable file, unknown key, bad
/// value, rule broken) is added to `parser`.
void applyPipelineArgs(const PipelineArgs& args, PipelineOptions* options, ArgParser* parser);

/// Usage lines of these options, for the programs' --help.
const char* pipelineOptionsUsage();

}  // namespace pplvo::pipeline

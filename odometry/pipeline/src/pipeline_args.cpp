#include "pplvo/pipeline/pipeline_args.h"

#include "pplvo/pipeline/pipeline_config.h"

namespace pplvo::pipeline {

void addPipelineOptions(ArgParser& parser, PipelineArgs* args) {
  config::addConfigOptions(parser, args, pipelineShortcuts());
}

void applyPipelineArgs(const PipelineArgs& args, PipelineOptions* options, ArgParser* parser) {
  for (const std::string& e : applyPipelineConfigArgs(args, options)) parser->addError(e);
}

const char* pipelineOptionsUsage() {
  static const std::string usage =
      config::configUsage("pipeline YAML (config/pplvo.yaml; default: built-in defaults)",
                          "odometry.tracker.estimator.plane_scale_alpha=1", pipelineShortcuts());
  return usage.c_str();
}

}  // namespace pplvo::pipeline

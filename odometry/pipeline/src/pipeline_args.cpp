#include "pplvo/pipeline/pipeline_args.h"

#include "pplvo/pipeline/pipeline_config.h"

namespace pplvo::pipeline {

void addPipelineOptions(ArgParser& parser, PipelineArgs* args) {
  parser.option("--config", &args->config)
      .option("--set",
              [args](const std::string& v) -> std::string {
                args->overrides.push_back(v);
                return "";
              })
      .option("--features", &args->features)
      .option("--depth-model", &args->depth_model);
}

void applyPipelineArgs(const PipelineArgs& args, PipelineOptions* options, ArgParser* parser) {
  try {
    if (!args.config.empty()) *options = loadPipelineConfig(args.config, *options);
    if (!args.overrides.empty()) *options = applyPipelineOverrides(args.overrides, *options);
  } catch (const std::exception& e) {
    parser->addError(e.what());
  }
  if (!args.features.empty()) {
    FeatureFamilies f;
    if (parseFeatureFamilies(args.features, &f))
      options->setFamilies(f);
    else
      parser->addError("--features: a list of points, lines, planes, not '" + args.features + "'");
  }
  if (!args.depth_model.empty() &&
      !depth_filter::parseDepthModel(args.depth_model, &options->depth_filter.model)) {
    parser->addError("--depth-model: sensor, cgm or ogm, not '" + args.depth_model + "'");
  }
}

const char* pipelineOptionsUsage() {
  return "  --config FILE           pipeline YAML (config/pplvo.yaml; default: built-in defaults)\n"
         "  --set KEY=VALUE         one configuration value by dotted key (repeatable), e.g.\n"
         "                          --set odometry.tracker.estimator.plane_scale_alpha=1\n"
         "  --features LIST         points,lines,planes (any subset; default all)\n"
         "  --depth-model MODEL     sensor | cgm | ogm (default ogm)\n";
}

}  // namespace pplvo::pipeline

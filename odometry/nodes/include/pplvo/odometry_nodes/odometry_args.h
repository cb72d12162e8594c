#pragma once
/// The command lines of pplvo-frontend and pplvo-estimator as testable functions. Both read the
/// whole pipeline configuration (--config, --set, --features, --depth-model; the cross-module
/// rules checked once on the result, pplvo/pipeline/pipeline_config.h) and keep their section.
#include <string>
#include <vector>

#include "pplvo/odometry_nodes/estimator_node.h"
#include "pplvo/odometry_nodes/frontend_node.h"

namespace pplvo::nodes {

struct FrontendArgs {
  FrontendNodeOptions options;  ///< options.frontend: the configuration's frontend section
  int prefault_mb = 64;         ///< --prefault-mb
  bool help = false;
  std::vector<std::string> errors;  ///< every problem, for "pplvo-frontend: ..." lines
};

/// Parses pplvo-frontend's arguments (no program name). Never throws.
FrontendArgs parseFrontendArgs(const std::vector<std::string>& args);
std::string frontendUsage();

struct EstimatorArgs {
  EstimatorNodeOptions options;  ///< options.odometry: the configuration's odometry section
  int prefault_mb = 16;          ///< --prefault-mb (features and poses only)
  bool help = false;
  std::vector<std::string> errors;  ///< every problem, for "pplvo-estimator: ..." lines
};

/// Parses pplvo-estimator's arguments (no program name). Never throws.
EstimatorArgs parseEstimatorArgs(const std::vector<std::string>& args);
std::string estimatorUsage();

}  // namespace pplvo::nodes

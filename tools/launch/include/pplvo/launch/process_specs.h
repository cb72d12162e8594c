#pragma once
/// The command lines of the five processes of a launch.
#include <string>
#include <vector>

#include "pplvo/launch/launch_args.h"
#include "pplvo/launch/lcm_url.h"
#include "pplvo/launch/supervisor.h"

namespace pplvo::launch {

/// Builds the five process specs (binaries in `bin_dir`, logs in `log_dir`), start order:
/// depth filter, frontend, estimator, logger, player.
/// Every process gets `--lcm-url url.url` and one `--route` per entry of `url.routes`.
std::vector<ProcessSpec> buildProcessSpecs(const LaunchOptions& o, const UrlDecision& url,
                                           const std::string& bin_dir, const std::string& log_dir);

}  // namespace pplvo::launch

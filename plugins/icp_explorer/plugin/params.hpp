// icp_explorer's parameters (config/plugins/icp_explorer.yaml) read into IcpExplorerConfig:
// every key, its range and its error message. Unknown keys are an error.
#pragma once

#include "locd/icp_explorer/config.hpp"
#include "locd/sdk/params.hpp"
#include "locd/sdk/plugin.hpp"

namespace locd::icp_explorer {

// Parses the plugin's params (rooted at "icp_explorer"); limits bound max_points and the map cells.
IcpExplorerConfig parse_config(const Params& params, const Limits& limits);

}  // namespace locd::icp_explorer

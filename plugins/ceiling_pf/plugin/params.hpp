// ceiling_pf's parameters (config/plugins/ceiling_pf.yaml) read into Config: every key, its range
// and its error message. Unknown keys are an error.
#pragma once

#include <functional>
#include <string>

#include "locd/ceiling_pf/config.hpp"
#include "locd/sdk/params.hpp"
#include "locd/sdk/plugin.hpp"

namespace locd::ceiling_pf {

// limits bound the image size and the particle counts. ceiling_height_of(map) loads the named map
// and returns its ceiling height, the default of ceiling_height (the lens must stay below it).
Config parse_config(const Params& params, const Limits& limits,
                    const std::function<double(const std::string& map)>& ceiling_height_of);

}  // namespace locd::ceiling_pf

// grid_mcl's parameters (config/plugins/grid_mcl.yaml) read into Config: every key, its range and
// its error message. Keys are Nav2 AMCL's, flat as in an amcl YAML; AMCL keys that have no
// meaning inside locd (frames, topics, TF) are accepted and listed in `ignored`; do_beamskip: true
// is refused: locd has no beam skipping (README "AMCL -> grid_mcl"). Any other unknown key is an
// error.
#pragma once

#include <string>
#include <vector>

#include "locd/grid_mcl/config.hpp"
#include "locd/sdk/params.hpp"
#include "locd/sdk/plugin.hpp"

namespace locd::grid_mcl {

Config parse_config(const Params& params, const Limits& limits, std::vector<std::string>* ignored = nullptr);

}  // namespace locd::grid_mcl

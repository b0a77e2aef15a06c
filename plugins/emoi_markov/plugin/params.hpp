// emoi_markov's parameters (config/plugins/emoi_markov.yaml) read into EmoiMarkovConfig: every key,
// its range and its error message. Unknown keys are an error.
#pragma once

#include "locd/emoi_markov/config.hpp"
#include "locd/sdk/params.hpp"

namespace locd::emoi {

EmoiMarkovConfig parse_config(const Params& params);

}  // namespace locd::emoi

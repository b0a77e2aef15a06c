// feature_ekf's parameters (config/plugins/feature_ekf.yaml, feature_ekf_road_signs.yaml) read
// into Config: every key, its range and its error message. Unknown keys are an error.
#pragma once

#include "locd/feature_ekf/config.hpp"
#include "locd/sdk/params.hpp"

namespace locd::feature_ekf {

// `model` picks the keys that follow: laser_features (default) reads the laser keys, the
// landmark models (geodetic_landmarks, enu_landmarks) read the landmark keys.
Config parse_config(const Params& params);

const char* model_name(Model model);  // "laser_features", "geodetic_landmarks", "enu_landmarks"

}  // namespace locd::feature_ekf

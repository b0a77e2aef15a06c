#include "localizer.hpp"

LOCD_REGISTER_PLUGIN(locd::grid_mcl::GridMclLocalizer, "grid_mcl", "1.0.0",
                     "Monte Carlo localization on map_server occupancy grids (AMCL's models and parameters, "
                     "KLD sampling, augmented MCL, global localization)",
                     locd::kinds(locd::MeasurementKind::kOdometry, locd::MeasurementKind::kLaserScan))

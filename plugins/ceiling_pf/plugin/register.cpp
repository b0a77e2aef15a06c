#include "localizer.hpp"

LOCD_REGISTER_PLUGIN(locd::ceiling_pf::CeilingPfLocalizer, "ceiling_pf", "1.0.0",
                     "Particle filter on identical ceiling landmarks (camera or on-board detections), "
                     "global localization and kidnap recovery",
                     locd::kinds(locd::MeasurementKind::kOdometry, locd::MeasurementKind::kImage,
                                 locd::MeasurementKind::kLandmarkDetections))

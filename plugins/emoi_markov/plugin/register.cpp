#include "localizer.hpp"

LOCD_REGISTER_PLUGIN(locd::emoi::EmoiMarkovLocalizer, "emoi_markov", "0.1.0",
                     "grid Markov localization on a DSM with elevation moments of inertia (Kwon, Song, Kang 2008)",
                     locd::kinds(locd::MeasurementKind::kOdometry, locd::MeasurementKind::kImu,
                                 locd::MeasurementKind::kLaserScan, locd::MeasurementKind::kPointCloud))

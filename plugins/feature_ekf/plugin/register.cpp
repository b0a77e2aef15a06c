#include "localizer.hpp"

LOCD_REGISTER_PLUGIN(locd::feature_ekf::FeatureEkfLocalizer, "feature_ekf", "1.1.0",
                     "EKF: 2D laser features against a feature map (Lim et al.), or imu + non-unique "
                     "landmark detections against a landmark database with data association (Kim et al.)",
                     locd::kinds(locd::MeasurementKind::kOdometry, locd::MeasurementKind::kLaserScan,
                                 locd::MeasurementKind::kImu, locd::MeasurementKind::kLandmarkDetections))

#include "localizer.hpp"

LOCD_REGISTER_PLUGIN(locd::icp_explorer::IcpExplorerLocalizer, "icp_explorer", "1.0.0",
                     "3D scan registration (modified ICP with odometry/intensity rejection) and next-best-view "
                     "exploration on a layered hexahedral map",
                     locd::kinds(locd::MeasurementKind::kOdometry, locd::MeasurementKind::kPointCloud))

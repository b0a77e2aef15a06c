// The one check of each measurement type. The server's DDS bridge runs these on every sample it
// converts (dds/src/convert.cpp), so a plugin trusts what it is given and never checks it again.
// Each throws InputError naming the topic, the field and what is allowed.
//
// Sizes from the network are bounded by check_limit before anything is allocated (the bridge
// calls it on the wire lengths); the validate functions check what a converted value holds.
#pragma once

#include <cstddef>

#include "locd/sdk/types.hpp"

namespace locd {

// Throws InputError "<topic>: <count> <what> exceed the limit <key> = <limit>" when count > limit.
void check_limit(const char* topic, const char* what, size_t count, size_t limit, const char* key);

void validate(const Odometry& odometry);        // finite pose and velocities
void validate(const Imu& imu);                  // finite, non-zero attitude; finite rates
// At least one beam, one intensity per range or none, finite angles with a non-zero increment,
// finite range_min < range_max, a finite sensor pose and at least one valid return.
void validate(const LaserScan& scan);
// At least one finite point (NaN points are "no return"), one intensity per point or none, a finite pose.
void validate(const PointCloud& cloud);
void validate(const Image& image);              // positive size, mono8 or bgr8, data = width * height * channels
void validate(const LandmarkDetections& frame); // finite positions and covariances
void validate(const Measurement& measurement);  // whichever it holds

// What a plugin returns, checked by the server before it is published (a plugin runs in a worker
// process and is trusted no more than the network): a finite pose with an orthonormal rotation,
// and a finite, symmetric, positive semi-definite covariance. Throws InputError saying what is wrong.
void validate(const PoseEstimate& estimate);

}  // namespace locd

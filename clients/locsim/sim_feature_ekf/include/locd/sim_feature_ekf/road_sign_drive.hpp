// A drive through a RoadSignWorld with the paper's sensors (Table 1): a random route along the
// roads (no U-turns, rounded corners), an IMU at 400 Hz (body acceleration, gravity removed,
// plus white noise 0.0152 m/s^2; AHRS attitude with Gauss-Markov errors of 0.6 deg RMS heading
// and 0.3 deg roll/pitch, optionally leaking gravity) and a sign
// detector (relative position in base_link with noise growing to sigma_max at the maximum range,
// missed and false detections). The vehicle moves on the WGS84 ellipsoid consistently with
// eq. 6-7 (the specific force includes the Coriolis and transport-rate terms), so the only
// errors a filter sees are the sensors'. Deterministic from (world, route seed, noise seed).
#pragma once

#include <Eigen/Core>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "locd/sdk/params.hpp"
#include "locd/sdk/types.hpp"
#include "locd/sim_feature_ekf/road_sign_world.hpp"

namespace locd::sim::road_signs {

struct DriveConfig {
  double duration = 600.0;          // s
  double cruise_speed = 12.0;       // m/s
  double turn_speed = 6.0;          // m/s through a corner
  double turn_radius = 12.0;        // m
  double max_acceleration = 1.5;    // m/s^2
  double imu_rate = 400.0;          // Hz
  double accelerometer_stddev = 0.0152;  // m/s^2 per sample
  double heading_error_rms_deg = 0.6;
  double tilt_error_rms_deg = 0.3;       // roll and pitch
  double attitude_error_time = 60.0;     // s, correlation time of the attitude errors
  // false: the IMU removes gravity with the true tilt (the sdk's "gravity removed"), the AHRS
  // errors only rotate the motion's acceleration; true: gravity is removed with the AHRS's
  // attitude, so tilt errors leak g * error (0.05 m/s^2 at 0.3 deg) into the horizontal.
  bool gravity_leak = false;
  double detection_rate = 1.0;      // Hz, detector frames
  double min_range = 5.0;           // m
  double max_range = 40.0;          // m
  double field_of_view_deg = 60.0;
  double max_facing_error_deg = 45.0;  // a sign is readable when it faces the vehicle within this
  double detection_probability = 0.9;  // per frame and visible sign
  double position_stddev_at_max_range = 3.0;  // m, per horizontal axis; proportional to range
  double false_detection_rate = 0.02; // per second, random class and place in the field of view
  bool oracle_ids = true;           // labels "class#id" (known_id strategy, evaluation)

  static DriveConfig from_params(const Params& drive, const Params& imu, const Params& detector);
};

struct DriveTruth {
  double time = 0.0;
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  // ENU m (the plugin's output frame)
  Eigen::Vector2d velocity = Eigen::Vector2d::Zero();  // (vE, vN) m/s, geodetic (eq. 6)
  double yaw = 0.0;                                     // ENU
  double latitude = 0.0, longitude = 0.0;               // rad
};

struct DriveEvent {
  Measurement measurement;  // Imu or LandmarkDetections
  DriveTruth truth;
  std::vector<int> true_signs;  // per detection: the sign index in the world, -1 = false detection
};

class RoadSignDrive {
 public:
  RoadSignDrive(const RoadSignWorld& world, DriveConfig config, uint64_t route_seed, uint64_t noise_seed);

  // The next event with time <= until (and <= the drive's duration), or nothing.
  std::optional<DriveEvent> next(double until = 1e300);
  const DriveTruth& truth() const { return truth_; }
  double route_length() const { return route_length_; }
  const DriveConfig& config() const { return config_; }

 private:
  struct Piece {
    Eigen::Vector2d start;
    double heading = 0.0;
    double length = 0.0;
    double curvature = 0.0;  // 0 = straight
  };
  void build_route(uint64_t seed);
  void evaluate(double s, Eigen::Vector2d* position, double* heading, double* curvature) const;
  double distance_to_next_turn(double s) const;
  void step_truth();
  Imu make_imu();
  LandmarkDetections make_detections(std::vector<int>* true_signs);

  const RoadSignWorld& world_;
  DriveConfig config_;
  std::vector<Piece> pieces_;
  std::vector<double> piece_start_;
  double route_length_ = 0.0;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  std::uniform_real_distribution<double> uniform_{0.0, 1.0};

  long tick_ = 0;
  long ticks_per_frame_ = 400;
  double s_ = 0.0, speed_ = 0.0, acceleration_ = 0.0;
  Eigen::Vector3d attitude_error_ = Eigen::Vector3d::Zero();  // roll, pitch, yaw errors (rad)
  Eigen::Vector2d specific_force_ = Eigen::Vector2d::Zero();  // (fE, fN), eq. 7
  DriveTruth truth_;
  bool frame_pending_ = false;
};

}  // namespace locd::sim::road_signs

// `locsim montecarlo SCENARIO.yaml --runs N`: N seeded drives of a road-sign scenario through the
// built feature_ekf plugin, once per association strategy (the scenario's plugin config with
// `association` replaced), every strategy side by side: CEP50 / CEP95 pooled and over time, and
// the probability of a wrong association (the chosen sign is not the detection's origin, or a
// false detection got a sign), as the paper's Fig. 8 and 9; the consistency of the reported
// covariance and the localization state (locd/sim/evaluation_report.hpp). No DDS.
#pragma once

#include <filesystem>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "locd/sim/consistency.hpp"
#include "locd/sim/state_evaluation.hpp"

namespace locd::sim::road_signs {

struct MonteCarloOptions {
  std::filesystem::path scenario_file;
  int runs = 100;
  std::vector<std::string> strategies = {"known_id", "nearest_neighbor", "jcbb", "pda"};
  std::vector<std::filesystem::path> plugin_directories;
  std::optional<uint64_t> seed;          // route seed; default the scenario's
  std::optional<double> duration_s;
  double bin_s = 10.0;                   // time bins of the curves
  double error_threshold_m = 5.0;        // a "small" error, for the state's false alarms (CEP95 scale)
  std::string plot_file;                 // PNG: CEP50/CEP95 and wrong-association probability over time
};

struct StrategyResult {
  std::string strategy;
  double cep50_m = 0.0, cep95_m = 0.0, max_error_m = 0.0;
  double wrong_association_rate = 0.0;
  size_t detections = 0, false_detections = 0, wrong = 0, false_associated = 0, rejected = 0;
  std::vector<double> cep50_over_time, cep95_over_time, wrong_over_time;
  // Over every estimate of every run: the horizontal position's NEES against the reported
  // covariance (no heading: the landmark models do not estimate it) and the plugin's state.
  ConsistencySummary consistency;
  StateSummary localization;
};

struct MonteCarloResult {
  std::string scenario;
  int runs = 0;
  double bin_s = 10.0;
  std::vector<StrategyResult> strategies;
};

// A road-sign scenario: one with sensors.sign_detector (read with yaml only, no validation).
bool is_road_signs_scenario(const std::filesystem::path& scenario_file);

// Throws ConfigError / std::runtime_error on a bad scenario or plugin config.
MonteCarloResult run_montecarlo(const MonteCarloOptions& options);
void write_montecarlo_json(std::ostream& out, const MonteCarloResult& result);
void write_montecarlo_summary(std::ostream& out, const MonteCarloResult& result);
void plot_montecarlo(const std::string& png_file, const MonteCarloResult& result);

}  // namespace locd::sim::road_signs

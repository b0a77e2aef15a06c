// Monte Carlo of the road-sign drive (issue 3, paper sec. 3.2): N seeded runs per association
// strategy on the scenario's world and route, every strategy side by side. Prints JSON with, per
// strategy, cep50_m / cep95_m (pooled over time and runs), the wrong-association rate, and CEP50,
// CEP95 and the wrong-association probability over time (10 s bins, as the paper's Fig. 8, 9).
//   road_signs_montecarlo config/scenarios/road_signs.yaml --runs 100 [--strategies a,b] [--csv DIR]
#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "locd/sdk/errors.hpp"
#include "road_sign_run.hpp"

using namespace locd;
using namespace locd::feature_ekf;
namespace rs = locd::sim::road_signs;

namespace {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double index = p * static_cast<double>(v.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(index)), hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (index - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: road_signs_montecarlo SCENARIO.yaml [--runs N] [--strategies known_id,...] [--csv DIR]\n";
    return 2;
  }
  int runs = 100;
  std::string csv_dir;
  std::vector<AssociationStrategy> strategies = {AssociationStrategy::kKnownId, AssociationStrategy::kNearestNeighbor,
                                                 AssociationStrategy::kJcbb, AssociationStrategy::kPda};
  for (int i = 2; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--runs") && i + 1 < argc) {
      runs = std::atoi(argv[++i]);
    } else if (!std::strcmp(argv[i], "--csv") && i + 1 < argc) {
      csv_dir = argv[++i];
    } else if (!std::strcmp(argv[i], "--strategies") && i + 1 < argc) {
      strategies.clear();
      std::stringstream list(argv[++i]);
      std::string name;
      while (std::getline(list, name, ',')) strategies.push_back(association_strategy_from_name(name));
    } else if (!std::strcmp(argv[i], "--json")) {
    } else {
      std::cerr << "road_signs_montecarlo: unknown argument '" << argv[i] << "'\n";
      return 2;
    }
  }
  try {
    const Params scenario = Params::load_file(argv[1]);
    const rs::RoadSignWorld world(rs::WorldConfig::from_params(scenario.child("world")));
    const Params sensors = scenario.child("sensors");
    const rs::DriveConfig drive = rs::DriveConfig::from_params(scenario.child("drive"), sensors.child("imu"),
                                                               sensors.child("sign_detector"));
    const uint64_t route_seed = static_cast<uint64_t>(scenario.integer("seed", 5, 0, 1L << 40));
    const std::vector<double> offset = scenario.child("localizer").numbers("initial_position_offset", {3.0, -2.0}, 2);
    const std::vector<double> stddev = scenario.child("localizer").numbers("initial_stddev", {5.0, 0.5}, 2);
    // The filter's parameters from the scenario's plugin config (the strategy is varied here).
    const std::filesystem::path config_file = std::filesystem::path(argv[1]).parent_path() /
                                              scenario.child("localizer").required_text("config_file");
    const Params plugin = Params::load_file(config_file.string()).child("params");

    std::cout << std::fixed << std::setprecision(4) << "{\n  \"scenario\": \"" << argv[1] << "\",\n  \"runs\": " << runs
              << ",\n  \"signs\": " << world.signs().size() << ",\n  \"road_length_m\": " << world.road_length()
              << ",\n  \"strategies\": {";
    for (size_t si = 0; si < strategies.size(); ++si) {
      LandmarkEkfConfig config = test::config_for(world, strategies[si]);
      LandmarkAssociationConfig& a = config.association;
      a.gate_threshold = plugin.number("gate_threshold", a.gate_threshold);
      a.false_detection_probability = plugin.number("false_detection_probability", a.false_detection_probability);
      a.jcbb_max_nodes = static_cast<size_t>(plugin.integer("jcbb_max_nodes", static_cast<long>(a.jcbb_max_nodes), 1, 10'000'000));
      config.velocity_noise_per_step = plugin.number("velocity_noise_per_step", config.velocity_noise_per_step);
      config.position_noise_per_step = plugin.number("position_noise_per_step", config.position_noise_per_step);
      config.detection_stddev = plugin.number("detection_stddev", config.detection_stddev);
      config.initial_position_stddev = stddev[0];
      config.initial_velocity_stddev = stddev[1];
      std::vector<double> pooled;
      std::vector<std::vector<double>> per_bin;
      std::vector<size_t> bin_wrong, bin_detections;
      size_t detections = 0, wrong = 0, false_detections = 0, false_associated = 0;
      double max_error = 0.0;
      for (int r = 0; r < runs; ++r) {
        const test::RunResult run = test::run_drive(world, drive, config, route_seed, 1000 + r, {offset[0], offset[1]});
        for (size_t k = 0; k < run.errors.size(); ++k) {
          const size_t bin = static_cast<size_t>(run.times[k] / 10.0);
          if (per_bin.size() <= bin) {
            per_bin.resize(bin + 1);
            bin_wrong.resize(bin + 1, 0);
            bin_detections.resize(bin + 1, 0);
          }
          per_bin[bin].push_back(run.errors[k]);
          bin_wrong[bin] += run.wrong_per_second[k];
          bin_detections[bin] += run.detections_per_second[k];
          pooled.push_back(run.errors[k]);
          max_error = std::max(max_error, run.errors[k]);
        }
        detections += run.detections;
        wrong += run.wrong;
        false_detections += run.false_detections;
        false_associated += run.false_associated;
      }
      const std::string name = association_strategy_name(strategies[si]);
      std::cout << (si ? "," : "") << "\n    \"" << name << "\": {\n"
                << "      \"cep50_m\": " << percentile(pooled, 0.5) << ",\n"
                << "      \"cep95_m\": " << percentile(pooled, 0.95) << ",\n"
                << "      \"max_error_m\": " << max_error << ",\n"
                << "      \"wrong_association_rate\": " << (detections ? double(wrong) / double(detections) : 0.0) << ",\n"
                << "      \"detections\": " << detections << ",\n"
                << "      \"false_detections\": " << false_detections << ",\n"
                << "      \"false_detections_associated\": " << false_associated << ",\n"
                << "      \"over_time\": {\"bin_s\": 10, \"cep50_m\": [";
      for (size_t b = 0; b < per_bin.size(); ++b) std::cout << (b ? ", " : "") << percentile(per_bin[b], 0.5);
      std::cout << "],\n        \"cep95_m\": [";
      for (size_t b = 0; b < per_bin.size(); ++b) std::cout << (b ? ", " : "") << percentile(per_bin[b], 0.95);
      std::cout << "],\n        \"wrong_association_probability\": [";
      for (size_t b = 0; b < per_bin.size(); ++b)
        std::cout << (b ? ", " : "") << (bin_detections[b] ? double(bin_wrong[b]) / double(bin_detections[b]) : 0.0);
      std::cout << "]}\n    }";
      if (!csv_dir.empty()) {
        std::ofstream csv(csv_dir + "/" + name + ".csv");
        csv << "time_s,cep50_m,cep95_m,wrong_association_probability\n";
        for (size_t b = 0; b < per_bin.size(); ++b)
          csv << 10.0 * b + 5.0 << ',' << percentile(per_bin[b], 0.5) << ',' << percentile(per_bin[b], 0.95) << ','
              << (bin_detections[b] ? double(bin_wrong[b]) / double(bin_detections[b]) : 0.0) << '\n';
      }
    }
    std::cout << "\n  }\n}\n";
  } catch (const std::exception& e) {
    std::cerr << "road_signs_montecarlo: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

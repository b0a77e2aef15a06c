#include "locd/sim_feature_ekf/montecarlo.hpp"

#include <nlohmann/json.hpp>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <iomanip>

#include "locd/sdk/errors.hpp"
#include "locd/sdk/plugin_config.hpp"
#include "locd/sdk/plugin_loader.hpp"
#include "locd/sim/evaluation_report.hpp"
#include "locd/sim_feature_ekf/road_sign_drive.hpp"

namespace locd::sim::road_signs {

namespace {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double index = p * static_cast<double>(v.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(index)), hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (index - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

}  // namespace

bool is_road_signs_scenario(const std::filesystem::path& scenario_file) {
  try {
    const YAML::Node root = YAML::LoadFile(scenario_file.string());
    return root.IsMap() && root["sensors"] && root["sensors"].IsMap() && root["sensors"]["sign_detector"];
  } catch (const YAML::Exception&) {
    return false;
  }
}

MonteCarloResult run_montecarlo(const MonteCarloOptions& options) {
  const Params scenario = Params::load_file(options.scenario_file.string());
  const RoadSignWorld world(WorldConfig::from_params(scenario.child("world")));
  const Params sensors = scenario.child("sensors");
  DriveConfig drive = DriveConfig::from_params(scenario.child("drive"), sensors.child("imu"), sensors.child("sign_detector"));
  drive.oracle_ids = true;  // known_id needs them; the others read the class only
  if (options.duration_s) drive.duration = *options.duration_s;
  const uint64_t route_seed = options.seed ? *options.seed : static_cast<uint64_t>(scenario.integer("seed", 1, 0, 1L << 40));
  const Params localizer = scenario.child("localizer");
  const std::vector<double> offset = localizer.numbers("initial_position_offset", {0.0, 0.0}, 2);
  const std::vector<double> stddev = localizer.numbers("initial_stddev", {5.0, 0.5}, 2, Range::positive());
  const std::filesystem::path config_file = options.scenario_file.parent_path() / localizer.required_text("config_file");
  const Params config_document = Params::load_file(config_file.string());

  PluginContext context;
  context.robot_id = scenario.child("robot").text("id", "sign_car");
  std::vector<std::filesystem::path> map_directories;
  for (const std::string& d : scenario.node()["map_directories"].as<std::vector<std::string>>(std::vector<std::string>{}))
    map_directories.push_back(options.scenario_file.parent_path() / d);
  context.maps = MapResolver(map_directories);
  const PluginCatalog catalog(options.plugin_directories);

  MonteCarloResult result;
  result.scenario = options.scenario_file.string();
  result.runs = options.runs;
  result.bin_s = options.bin_s;
  for (const std::string& strategy : options.strategies) {
    YAML::Node document = YAML::Clone(config_document.node());
    document["params"]["association"] = strategy;
    const PluginConfig config = split_plugin_config(Params(document, config_file.string()), config_file.string());
    StrategyResult s;
    s.strategy = strategy;
    std::vector<double> pooled;
    std::vector<ConsistencySample> consistency;
    std::vector<StateSample> states;  // runs one after another on one time line, each shifted
    std::vector<std::vector<double>> per_bin;
    std::vector<size_t> bin_wrong, bin_detections;
    for (int run = 0; run < options.runs; ++run) {
      LocalizerPtr plugin = create_configured(catalog, config.plugin, context, config.params);
      RoadSignDrive sim(world, drive, route_seed, 1000 + static_cast<uint64_t>(run));
      PoseEstimate start;
      start.pose.translation() << sim.truth().position + Eigen::Vector2d(offset[0], offset[1]), 0.0;
      start.linear_velocity << sim.truth().velocity, 0.0;
      start.covariance = Matrix6d::Identity() * 1e-6;
      start.covariance(0, 0) = start.covariance(1, 1) = stddev[0] * stddev[0];
      plugin->set_pose(start);
      LocalizationState state = LocalizationState::kUnknown;
      const double run_offset = states.empty() ? 0.0 : states.back().t + 1.0;
      while (auto e = sim.next()) {
        UpdateResult r;
        try {
          r = plugin->update(e->measurement);
        } catch (const InputError&) {
          ++s.rejected;
          continue;
        }
        if (r.localization) state = r.localization->state;
        if (!r.estimate) continue;
        const double error = (r.estimate->pose.translation().head<2>() - e->truth.position).norm();
        const Eigen::Vector2d p = r.estimate->pose.translation().head<2>();
        consistency.push_back({nees({p.x(), p.y(), 0.0}, {e->truth.position.x(), e->truth.position.y(), 0.0},
                                    planar_covariance(r.estimate->covariance)),
                               state});
        states.push_back({run_offset + e->truth.time, error, state});
        const size_t bin = static_cast<size_t>(e->truth.time / options.bin_s);
        if (per_bin.size() <= bin) {
          per_bin.resize(bin + 1);
          bin_wrong.resize(bin + 1, 0);
          bin_detections.resize(bin + 1, 0);
        }
        per_bin[bin].push_back(error);
        pooled.push_back(error);
        s.max_error_m = std::max(s.max_error_m, error);
        for (const AssociationRecord& a : r.diagnostics.associations) {
          const int truth = a.measurement < e->true_signs.size() ? e->true_signs[a.measurement] : -1;
          ++s.detections;
          ++bin_detections[bin];
          if (truth < 0) ++s.false_detections;
          const bool wrong = !a.feature_id.empty() && (truth < 0 || a.feature_id != world.signs()[truth].id);
          if (wrong) {
            ++s.wrong;
            ++bin_wrong[bin];
            if (truth < 0) ++s.false_associated;
          }
        }
      }
    }
    s.consistency = summarize_consistency(consistency);
    s.localization = evaluate_states(states, {options.error_threshold_m, std::nullopt});
    s.cep50_m = percentile(pooled, 0.5);
    s.cep95_m = percentile(pooled, 0.95);
    s.wrong_association_rate = s.detections ? static_cast<double>(s.wrong) / static_cast<double>(s.detections) : 0.0;
    for (size_t b = 0; b < per_bin.size(); ++b) {
      s.cep50_over_time.push_back(percentile(per_bin[b], 0.5));
      s.cep95_over_time.push_back(percentile(per_bin[b], 0.95));
      s.wrong_over_time.push_back(bin_detections[b] ? static_cast<double>(bin_wrong[b]) / static_cast<double>(bin_detections[b]) : 0.0);
    }
    result.strategies.push_back(std::move(s));
  }
  return result;
}

// One JSON object, indented (nlohmann-json: strings escaped, a non-finite number written as null).
void write_montecarlo_json(std::ostream& out, const MonteCarloResult& result) {
  nlohmann::ordered_json strategies = nlohmann::ordered_json::object();
  for (const StrategyResult& s : result.strategies) {
    strategies[s.strategy] = {{"cep50_m", s.cep50_m},
                              {"cep95_m", s.cep95_m},
                              {"max_error_m", s.max_error_m},
                              {"wrong_association_rate", s.wrong_association_rate},
                              {"detections", s.detections},
                              {"false_detections", s.false_detections},
                              {"wrong_associations", s.wrong},
                              {"false_detections_associated", s.false_associated},
                              {"rejected", s.rejected},
                              {"cep50_over_time_m", s.cep50_over_time},
                              {"cep95_over_time_m", s.cep95_over_time},
                              {"wrong_association_probability_over_time", s.wrong_over_time},
                              {"consistency", consistency_json(s.consistency)},
                              {"localization", state_json(s.localization)}};
  }
  const nlohmann::ordered_json json = {
      {"scenario", result.scenario}, {"runs", result.runs}, {"bin_s", result.bin_s}, {"strategies", strategies}};
  out << json.dump(2) << "\n";
}

void write_montecarlo_summary(std::ostream& out, const MonteCarloResult& result) {
  out << result.scenario << ": " << result.runs << " runs per strategy\n" << std::fixed << std::setprecision(3);
  out << std::left << std::setw(18) << "strategy" << std::setw(10) << "CEP50 m" << std::setw(10) << "CEP95 m" << std::setw(12)
      << "max m" << "wrong association\n";
  for (const StrategyResult& s : result.strategies) {
    out << std::setw(18) << s.strategy << std::setw(10) << s.cep50_m << std::setw(10) << s.cep95_m << std::setw(12)
        << s.max_error_m << s.wrong_association_rate << " (" << s.wrong << " of " << s.detections << ")\n";
  }
  for (const StrategyResult& s : result.strategies) {
    out << s.strategy << ":\n";
    write_consistency_summary(out, s.consistency);
    write_state_summary(out, s.localization);
  }
}

// Two panels like the paper's Fig. 8 (CEP over time; CEP50 solid, CEP95 thin) and Fig. 9 (wrong
// association probability over time), one colour per strategy.
void plot_montecarlo(const std::string& png_file, const MonteCarloResult& result) {
  const int width = 1000, panel = 330, margin = 60;
  cv::Mat image(2 * panel + 3 * margin / 2, width, CV_8UC3, cv::Scalar(255, 255, 255));
  const cv::Scalar colours[] = {{0, 0, 0}, {0, 0, 220}, {0, 150, 0}, {220, 80, 0}, {150, 0, 150}};
  size_t bins = 0;
  double max_cep = 1.0, max_wrong = 0.01;
  for (const StrategyResult& s : result.strategies) {
    bins = std::max(bins, s.cep50_over_time.size());
    for (double v : s.cep95_over_time) max_cep = std::max(max_cep, v);
    for (double v : s.wrong_over_time) max_wrong = std::max(max_wrong, v);
  }
  max_cep = std::min(max_cep, 50.0);
  const double t_max = std::max<double>(1.0, static_cast<double>(bins) * result.bin_s);
  auto draw_panel = [&](int top, double y_max, const char* label, auto&& series) {
    cv::rectangle(image, {margin, top}, {width - 20, top + panel}, {0, 0, 0});
    cv::putText(image, label, {margin + 5, top - 8}, cv::FONT_HERSHEY_SIMPLEX, 0.5, {0, 0, 0});
    cv::putText(image, std::to_string(y_max).substr(0, 5), {5, top + 12}, cv::FONT_HERSHEY_SIMPLEX, 0.4, {0, 0, 0});
    cv::putText(image, "0", {40, top + panel}, cv::FONT_HERSHEY_SIMPLEX, 0.4, {0, 0, 0});
    cv::putText(image, std::to_string(static_cast<int>(t_max)) + " s", {width - 70, top + panel + 15},
                cv::FONT_HERSHEY_SIMPLEX, 0.4, {0, 0, 0});
    auto to_pixel = [&](double t, double v) {
      return cv::Point(margin + static_cast<int>((width - 20 - margin) * t / t_max),
                       top + panel - static_cast<int>(panel * std::min(v, y_max) / y_max));
    };
    for (size_t i = 0; i < result.strategies.size(); ++i) series(result.strategies[i], colours[i % 5], to_pixel);
  };
  draw_panel(margin / 2 + 10, max_cep, "CEP50 (thick) and CEP95 (thin) of the horizontal position, m",
             [&](const StrategyResult& s, const cv::Scalar& c, auto&& to_pixel) {
               for (size_t b = 1; b < s.cep50_over_time.size(); ++b) {
                 const double t0 = (b - 0.5) * result.bin_s, t1 = (b + 0.5) * result.bin_s;
                 cv::line(image, to_pixel(t0, s.cep50_over_time[b - 1]), to_pixel(t1, s.cep50_over_time[b]), c, 2);
                 cv::line(image, to_pixel(t0, s.cep95_over_time[b - 1]), to_pixel(t1, s.cep95_over_time[b]), c, 1);
               }
             });
  draw_panel(panel + margin + 20, max_wrong, "probability of a wrong association",
             [&](const StrategyResult& s, const cv::Scalar& c, auto&& to_pixel) {
               for (size_t b = 1; b < s.wrong_over_time.size(); ++b) {
                 cv::line(image, to_pixel((b - 0.5) * result.bin_s, s.wrong_over_time[b - 1]),
                          to_pixel((b + 0.5) * result.bin_s, s.wrong_over_time[b]), c, 2);
               }
             });
  for (size_t i = 0; i < result.strategies.size(); ++i) {
    cv::putText(image, result.strategies[i].strategy, {width - 200, margin / 2 + 35 + 18 * static_cast<int>(i)},
                cv::FONT_HERSHEY_SIMPLEX, 0.5, colours[i % 5], 2);
  }
  if (!cv::imwrite(png_file, image)) throw std::runtime_error("cannot write plot " + png_file);
}

}  // namespace locd::sim::road_signs

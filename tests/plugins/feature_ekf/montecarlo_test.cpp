// `locsim montecarlo` on the road_signs scenario, shortened: every strategy side by side through
// the built plugin, JSON with cep50_m, cep95_m and wrong_association_rate per strategy, a PNG.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <sstream>

#include "locd/sdk/errors.hpp"
#include "locd/sim_feature_ekf/montecarlo.hpp"
#include "test_env.hpp"

namespace rs = locd::sim::road_signs;

TEST(FeatureEkfLandmarkMonteCarlo, EveryStrategySideBySide) {
  rs::MonteCarloOptions options;
  options.scenario_file = locd::test::source_dir() + "/config/scenarios/road_signs.yaml";
  options.plugin_directories = {locd::test::plugin_dir()};
  options.runs = 2;
  options.duration_s = 60.0;
  ASSERT_TRUE(rs::is_road_signs_scenario(options.scenario_file));
  EXPECT_FALSE(rs::is_road_signs_scenario(locd::test::source_dir() + "/config/scenarios/corridor.yaml"));
  const rs::MonteCarloResult result = rs::run_montecarlo(options);
  ASSERT_EQ(result.strategies.size(), 4u);
  for (const rs::StrategyResult& s : result.strategies) {
    EXPECT_GT(s.detections, 10u) << s.strategy;
    EXPECT_GT(s.cep50_m, 0.0) << s.strategy;
    EXPECT_LT(s.cep50_m, 6.0) << s.strategy;
    EXPECT_GE(s.cep95_m, s.cep50_m) << s.strategy;
    EXPECT_EQ(s.cep50_over_time.size(), 7u) << s.strategy;  // 10 s bins over 60 s (+ the last sample)
  }
  EXPECT_EQ(result.strategies[0].strategy, "known_id");
  EXPECT_EQ(result.strategies[0].wrong, 0u);
  std::ostringstream json;
  rs::write_montecarlo_json(json, result);
  const nlohmann::json parsed = nlohmann::json::parse(json.str());
  EXPECT_TRUE(parsed["strategies"]["pda"]["cep50_m"].is_number()) << json.str();
  for (const char* key : {"cep95_m", "wrong_association_rate"}) {
    EXPECT_TRUE(parsed["strategies"]["pda"][key].is_number()) << key << "\n" << json.str();
  }
  for (const char* strategy : {"nearest_neighbor", "jcbb"}) {
    EXPECT_TRUE(parsed["strategies"].contains(strategy)) << strategy << "\n" << json.str();
  }
  const std::filesystem::path png = std::filesystem::temp_directory_path() / ("feature_ekf_mc_" + std::to_string(::getpid()) + ".png");
  rs::plot_montecarlo(png.string(), result);
  EXPECT_GT(std::filesystem::file_size(png), 1000u);
  std::filesystem::remove(png);

  options.strategies = {"greedy"};
  try {
    rs::run_montecarlo(options);
    FAIL() << "an unknown strategy was accepted";
  } catch (const locd::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("feature_ekf.association"), std::string::npos) << e.what();
  }
}

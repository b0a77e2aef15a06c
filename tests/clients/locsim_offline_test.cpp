// The corridor scenario offline through the real feature_ekf plugin (built in build/plugins).
#include <gtest/gtest.h>

#include <filesystem>

#include "locd/sim/offline_runner.hpp"
#include "locsim_paths.hpp"

namespace fs = std::filesystem;

TEST(LocsimOffline, CorridorThroughFeatureEkfIsAccurate) {
  const auto scenario = locd::sim::load_scenario(locd::sim::test::source_dir() + "/config/scenarios/corridor.yaml");
  locd::sim::OfflineRunOptions options;
  options.plugin_directories = {locd::sim::test::plugin_dir()};
  options.duration_s = 30.0;
  const auto result = locd::sim::run_offline(scenario, options);
  EXPECT_EQ(result.plugin, "feature_ekf");
  EXPECT_EQ(result.rejected, 0u) << result.last_rejection;
  EXPECT_GT(result.summary.updates, 700u);  // 30 s of 25 Hz scans at least
  EXPECT_LT(result.summary.rmse_m, 0.05);
  EXPECT_TRUE(result.summary.converged);
  EXPECT_LT(result.summary.final_error_m, 0.1);
}

TEST(LocsimOffline, UnknownPluginListsTheKnownOnes) {
  auto scenario = locd::sim::load_scenario(locd::sim::test::source_dir() + "/config/scenarios/corridor.yaml");
  scenario.localizer.plugin = "no_such_plugin";
  locd::sim::OfflineRunOptions options;
  options.plugin_directories = {locd::sim::test::plugin_dir()};
  try {
    locd::sim::run_offline(scenario, options);
    FAIL() << "ran an unknown plugin";
  } catch (const locd::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_plugin"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("feature_ekf"), std::string::npos) << e.what();
  }
}

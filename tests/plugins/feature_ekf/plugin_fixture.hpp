// The built feature_ekf plugin, loaded like the server loads it (catalog, map folder, context),
// for the plugin tests of both models. A derived fixture puts its map files into map_dir_.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "locd/sdk/plugin_config.hpp"
#include "locd/sdk/plugin_loader.hpp"
#include "test_env.hpp"

namespace locd::test {

class FeatureEkfPluginFixture : public ::testing::Test {
 protected:
  FeatureEkfPluginFixture(const std::string& robot_id, const std::string& map_file, const std::string& map_text)
      : map_dir_(std::filesystem::temp_directory_path() /
                 (std::string(::testing::UnitTest::GetInstance()->current_test_suite()->name()) + "_" +
                  std::to_string(::getpid()))) {
    std::filesystem::create_directories(map_dir_);
    std::ofstream(map_dir_ / map_file) << map_text;
    catalog_ = PluginCatalog({plugin_dir()});
    context_.robot_id = robot_id;
    context_.maps = MapResolver({map_dir_});
  }
  ~FeatureEkfPluginFixture() override {
    std::error_code ec;
    std::filesystem::remove_all(map_dir_, ec);
  }

  // `params_yaml` is the body of `params:` (indented two spaces).
  LocalizerPtr configured(const std::string& params_yaml) {
    const PluginConfig config = split_plugin_config("plugin: feature_ekf\nparams:\n" + params_yaml, "test config");
    return create_configured(catalog_, config.plugin, context_, config.params);
  }
  std::string config_error(const std::string& params_yaml) {
    try {
      configured(params_yaml);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "no ConfigError";
  }

  std::filesystem::path map_dir_;
  PluginCatalog catalog_;
  PluginContext context_;
};

}  // namespace locd::test

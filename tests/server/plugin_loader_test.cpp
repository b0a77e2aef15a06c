// The loader refuses each deliberately broken plugin with a message naming the file and the
// cause, and still loads the good plugin next to them.
#include <gtest/gtest.h>

#include <algorithm>

#include "locd/sdk/plugin_loader.hpp"

namespace {

namespace fs = std::filesystem;
using locd::ConfigError;
using locd::PluginCatalog;
using locd::PluginLoadError;

const fs::path kDir = LOCD_BROKEN_PLUGIN_DIR;

std::string file_of(const std::string& name) { return (kDir / ("liblocd_" + name + ".so")).string(); }

// The rejected entry for a file ("<file>: <cause>"), or "" when the file was not refused.
std::string refusal(const PluginCatalog& catalog, const std::string& name) {
  for (const auto& r : catalog.rejected()) {
    if (r.rfind(file_of(name) + ":", 0) == 0) return r;
  }
  return "";
}

TEST(PluginLoader, RefusesEachBrokenFileNamingFileAndCause) {
  const PluginCatalog catalog({kDir});
  EXPECT_NE(refusal(catalog, "broken_no_entry").find("no entry point 'locd_plugin_descriptor'"), std::string::npos)
      << refusal(catalog, "broken_no_entry");
  EXPECT_NE(refusal(catalog, "broken_abi_version").find("ABI version 999"), std::string::npos)
      << refusal(catalog, "broken_abi_version");
  EXPECT_NE(refusal(catalog, "broken_invalid_name").find("invalid plugin name '../Evil.so'"), std::string::npos)
      << refusal(catalog, "broken_invalid_name");
  EXPECT_NE(refusal(catalog, "broken_needs_input").find("needs inputs this server cannot give"), std::string::npos)
      << refusal(catalog, "broken_needs_input");
  EXPECT_EQ(catalog.rejected().size(), 4u);
}

TEST(PluginLoader, GoodPluginsNextToBrokenOnesStillLoad) {
  const PluginCatalog catalog({kDir});
  const std::vector<std::string> expected{"broken_configure_throws", "broken_factory_throws", "faulty",
                                         "fixture_odometry"};
  EXPECT_EQ(catalog.names(), expected);
  ASSERT_NE(catalog.find("fixture_odometry"), nullptr);
  EXPECT_EQ(catalog.find("fixture_odometry")->file(), fs::path(file_of("fixture_odometry")));

  locd::PluginContext context;
  context.robot_id = "loader";
  auto localizer = locd::create_configured(catalog, "fixture_odometry", context, locd::Params());
  locd::Odometry odometry;
  odometry.header.stamp_ns = 5;
  odometry.pose.translation() = Eigen::Vector3d(1.0, 2.0, 0.0);
  const auto result = localizer->update(odometry);
  ASSERT_TRUE(result.estimate.has_value());
  EXPECT_EQ(result.estimate->header.stamp_ns, 5);
}

TEST(PluginLoader, FactoryThatThrowsIsRefusedNamingFileAndCause) {
  const PluginCatalog catalog({kDir});
  try {
    catalog.create("broken_factory_throws");
    FAIL() << "a throwing factory must be refused";
  } catch (const PluginLoadError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(file_of("broken_factory_throws")), std::string::npos) << what;
    EXPECT_NE(what.find("constructor of broken_factory_throws failed on purpose"), std::string::npos) << what;
  }
}

TEST(PluginLoader, ConfigureThatThrowsBecomesConfigErrorNamingFileAndCause) {
  const PluginCatalog catalog({kDir});
  try {
    locd::create_configured(catalog, "broken_configure_throws", locd::PluginContext{}, locd::Params());
    FAIL() << "a throwing configure must be refused";
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(file_of("broken_configure_throws")), std::string::npos) << what;
    EXPECT_NE(what.find("configure of broken_configure_throws failed on purpose"), std::string::npos) << what;
  }
}

TEST(PluginLoader, OpeningABrokenFileDirectlyNamesIt) {
  try {
    locd::PluginLibrary::open(file_of("broken_abi_version"));
    FAIL() << "wrong ABI must be refused";
  } catch (const PluginLoadError& e) {
    EXPECT_NE(std::string(e.what()).find(file_of("broken_abi_version") + ": ABI version 999"), std::string::npos)
        << e.what();
  }
}

TEST(PluginLoader, KindTheServerCannotGiveIsNamed) {
  const uint32_t odometry_only = static_cast<uint32_t>(locd::MeasurementKind::kOdometry);
  const PluginCatalog catalog({kDir}, odometry_only);
  EXPECT_EQ(catalog.find("fixture_odometry"), nullptr);
  EXPECT_NE(refusal(catalog, "fixture_odometry").find("needs inputs this server cannot give: scan"), std::string::npos)
      << refusal(catalog, "fixture_odometry");
}

TEST(PluginLoader, UnknownPluginListsTheKnownOnes) {
  const PluginCatalog catalog({kDir});
  try {
    catalog.create("no_such_plugin");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown plugin 'no_such_plugin'; known plugins: broken_configure_throws, "
                                         "broken_factory_throws, faulty, fixture_odometry"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace

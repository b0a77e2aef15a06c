#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "error_of.hpp"
#include "locd/sdk/feature_map.hpp"
#include "locd/sdk/plugin_loader.hpp"

namespace fs = std::filesystem;
using namespace locd;

namespace {

struct TempTree {
  fs::path root = fs::temp_directory_path() / ("locd_map_test_" + std::to_string(::getpid()));
  TempTree() {
    fs::create_directories(root / "maps" / "sub");
    fs::create_directories(root / "secret");
    std::ofstream(root / "maps" / "a.yaml") << "walls: [[[0, 0], [1, 0]]]\n";
    std::ofstream(root / "maps" / "sub" / "b.yaml") << "walls: [[[0, 0], [1, 0]]]\n";
    std::ofstream(root / "secret" / "key.yaml") << "x: 1\n";
    fs::create_symlink(root / "secret" / "key.yaml", root / "maps" / "escape.yaml");
  }
  ~TempTree() { fs::remove_all(root); }
};


}  // namespace

using locd::test::error_of;

TEST(MapResolver, ResolvesOnlyInsideMapDirectories) {
  TempTree t;
  const MapResolver maps({t.root / "maps"});
  EXPECT_EQ(maps.resolve("a.yaml"), fs::canonical(t.root / "maps" / "a.yaml"));
  EXPECT_EQ(maps.resolve("sub/b.yaml"), fs::canonical(t.root / "maps" / "sub" / "b.yaml"));
  EXPECT_NE(error_of([&] { maps.resolve((t.root / "secret" / "key.yaml").string()); }).find("absolute"),
            std::string::npos);
  EXPECT_NE(error_of([&] { maps.resolve("../secret/key.yaml"); }).find("'..'"), std::string::npos);
  EXPECT_NE(error_of([&] { maps.resolve("escape.yaml"); }).find("outside the map directory"), std::string::npos);
  const std::string missing = error_of([&] { maps.resolve("nope.yaml"); });
  EXPECT_NE(missing.find("'nope.yaml' not found"), std::string::npos) << missing;
  EXPECT_NE(error_of([&] { maps.resolve(""); }).find("empty"), std::string::npos);
}

TEST(FeatureMap, WallsExpandToLinesCornersEdges) {
  const Params p = Params::parse("walls:\n  - [[0, 0], [4, 0], [4, 3]]\n  - [[0, 5], [2, 5], [2, 7], [0, 7]]\nclosed: [false, true]\n", "m.yaml");
  const FeatureMap2D map = parse_feature_map(p, 100);
  // Open wall: 2 lines, 1 corner, 2 edges. Closed square-ish wall: 4 lines, 4 corners.
  EXPECT_EQ(map.lines.size(), 6u);
  EXPECT_EQ(map.corners.size(), 5u);
  EXPECT_EQ(map.edges.size(), 2u);
  // Line (0,0)-(4,0): normal form rho = 0 ... use the second: x = 4 -> alpha 0, rho 4.
  EXPECT_NEAR(map.lines[1].rho(), 4.0, 1e-12);
  EXPECT_NEAR(map.lines[1].alpha(), 0.0, 1e-12);
  // Line y = 5 -> alpha pi/2, rho 5.
  EXPECT_NEAR(map.lines[2].rho(), 5.0, 1e-12);
  EXPECT_NEAR(map.lines[2].alpha(), M_PI / 2, 1e-12);
}

TEST(FeatureMap, ErrorsNameTheKeyAndTheLimit) {
  EXPECT_NE(error_of([] { parse_feature_map(Params::parse("walls: [[[0, 0]]]\n", "m"), 100); }).find("at least 2 points"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_feature_map(Params::parse("walls: [[[0, 0], [1, x]]]\n", "m"), 100); }).find("'walls'"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_feature_map(Params::parse("walls: [[[0, 0], [1, 0], [2, 0]]]\n", "m"), 3); }).find("limit"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_feature_map(Params::parse("wals: []\n", "m"), 10); }).find("unknown parameter 'wals'"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_feature_map(Params::parse("frame_id: map\n", "m"), 10); }).find("no features"),
            std::string::npos);
}

TEST(PluginLoader, MissingFileNamesTheFile) {
  try {
    PluginLibrary::open("/nonexistent/liblocd_x.so");
    FAIL();
  } catch (const PluginLoadError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/liblocd_x.so"), std::string::npos);
  }
}

TEST(PluginLoader, UnknownPluginListsKnownOnes) {
  const PluginCatalog empty;
  const std::string msg = error_of([&] { empty.create("nope"); });
  EXPECT_NE(msg.find("unknown plugin 'nope'"), std::string::npos) << msg;
  const PluginCatalog missing_dir({"/nonexistent/plugins"});
  ASSERT_EQ(missing_dir.rejected().size(), 1u);
  EXPECT_NE(missing_dir.rejected()[0].find("/nonexistent/plugins"), std::string::npos);
}

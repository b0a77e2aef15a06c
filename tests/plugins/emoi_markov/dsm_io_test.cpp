// DSM files: GeoTIFF and 16-bit PNG with a YAML sidecar, nodata, and clear errors.
#include <gtest/gtest.h>

#include <fstream>
#include <unistd.h>

#include "locd/emoi_markov/dsm_io.hpp"
#include "locd/emoi_markov/dsm_writer.hpp"
#include "locd/sdk/errors.hpp"

namespace {

namespace fs = std::filesystem;
using namespace locd::emoi;

struct TempDirectory {
  fs::path path = fs::temp_directory_path() / ("emoi_dsm_test_" + std::to_string(::getpid()));
  TempDirectory() { fs::create_directories(path); }
  ~TempDirectory() { fs::remove_all(path); }
};

ElevationMap sample_map() {
  ElevationMap map;
  map.geometry.resolution = 0.25;
  map.geometry.origin = {10.0, -4.0};
  map.geometry.width = 30;
  map.geometry.height = 20;
  map.elevation = cv::Mat_<float>(20, 30);
  for (int r = 0; r < 20; ++r) {
    for (int c = 0; c < 30; ++c) map.elevation(r, c) = 100.0f + 0.5f * r + 0.01f * c;
  }
  map.elevation(3, 4) = std::numeric_limits<float>::quiet_NaN();
  return map;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const locd::ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(DsmIo, GeoTiffRoundTripKeepsGeometryElevationAndNodata) {
  TempDirectory dir;
  const ElevationMap map = sample_map();
  write_dsm_geotiff(map, dir.path / "dsm.tif");
  const ElevationMap loaded = load_dsm(dir.path / "dsm.tif", 1000);
  EXPECT_EQ(loaded.geometry.width, 30);
  EXPECT_EQ(loaded.geometry.height, 20);
  EXPECT_DOUBLE_EQ(loaded.geometry.resolution, 0.25);
  EXPECT_NEAR(loaded.geometry.origin.x(), 10.0, 1e-9);
  EXPECT_NEAR(loaded.geometry.origin.y(), -4.0, 1e-9);
  EXPECT_TRUE(std::isnan(loaded.elevation(3, 4)));  // row 3 stays row 3 (south first)
  EXPECT_FLOAT_EQ(loaded.elevation(19, 29), map.elevation(19, 29));
  EXPECT_FLOAT_EQ(loaded.elevation(0, 0), map.elevation(0, 0));
  EXPECT_EQ(loaded.valid_cells(), 599u);
}

TEST(DsmIo, PngWithSidecarRoundTripQuantisesToTheScale) {
  TempDirectory dir;
  const ElevationMap map = sample_map();
  write_dsm_png_with_sidecar(map, dir.path / "dsm.yaml", 0.01, 90.0);
  const ElevationMap loaded = load_dsm(dir.path / "dsm.yaml", 1000);
  EXPECT_EQ(loaded.geometry.width, 30);
  EXPECT_NEAR(loaded.geometry.origin.y(), -4.0, 1e-9);
  EXPECT_TRUE(std::isnan(loaded.elevation(3, 4)));
  for (int r = 0; r < 20; ++r) {
    for (int c = 0; c < 30; ++c) {
      if (std::isfinite(map.elevation(r, c))) ASSERT_NEAR(loaded.elevation(r, c), map.elevation(r, c), 0.0051);
    }
  }
}

TEST(DsmIo, BadFilesAndMetadataGiveClearErrors) {
  TempDirectory dir;
  write_dsm_png_with_sidecar(sample_map(), dir.path / "dsm.yaml", 0.01, 90.0);
  EXPECT_NE(error_of([&] { load_dsm(dir.path / "dsm.tif", 1000); }).find("cannot be opened"), std::string::npos);
  EXPECT_NE(error_of([&] { load_dsm(dir.path / "dsm.png", 1000); }).find("allowed: .tif/.tiff"), std::string::npos);
  EXPECT_NE(error_of([&] { load_dsm(dir.path / "dsm.yaml", 100); }).find("max_map_cells"), std::string::npos);

  std::ofstream(dir.path / "missing.yaml") << "image: dsm.png\norigin: [0, 0]\nelevation_scale: 0.01\n";
  const std::string missing = error_of([&] { load_dsm(dir.path / "missing.yaml", 1000); });
  EXPECT_NE(missing.find("resolution"), std::string::npos) << missing;

  std::ofstream(dir.path / "escape.yaml") << "image: ../dsm.png\nresolution: 1\norigin: [0, 0]\nelevation_scale: 1\n";
  EXPECT_NE(error_of([&] { load_dsm(dir.path / "escape.yaml", 1000); }).find("'..'"), std::string::npos);

  std::ofstream(dir.path / "typo.yaml") << "image: dsm.png\nresolution: 1\norigin: [0, 0]\nelevation_scal: 1\n";
  EXPECT_NE(error_of([&] { load_dsm(dir.path / "typo.yaml", 1000); }).find("elevation_scal"), std::string::npos);

  std::ofstream(dir.path / "negative.yaml") << "image: dsm.png\nresolution: -1\norigin: [0, 0]\nelevation_scale: 1\n";
  const std::string negative = error_of([&] { load_dsm(dir.path / "negative.yaml", 1000); });
  EXPECT_NE(negative.find("resolution"), std::string::npos) << negative;
}

TEST(DsmIo, AllNodataIsRefused) {
  TempDirectory dir;
  ElevationMap map = sample_map();
  map.elevation.setTo(std::numeric_limits<float>::quiet_NaN());
  write_dsm_geotiff(map, dir.path / "empty.tif");
  EXPECT_NE(error_of([&] { load_dsm(dir.path / "empty.tif", 1000); }).find("no cell with data"), std::string::npos);
}

}  // namespace

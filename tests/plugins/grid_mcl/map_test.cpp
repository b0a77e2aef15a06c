// grid_mcl's maps: map_server's YAML and PGM / PNG read as map_server reads them (thresholds,
// negate, modes, the row flip), bad files refused with the file and the key named and sizes bounded
// before allocation, the ray cast against a fine-stepped reference, the distance field against a
// brute-force scan, and the shared map loaded once per file version.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <thread>

#include "error_of.hpp"
#include "locd/grid_mcl/shared_map.hpp"
#include "locd/sdk/errors.hpp"
#include "locd/sdk/plugin.hpp"

namespace {

using namespace locd;
using namespace locd::grid_mcl;
namespace fs = std::filesystem;

class MapFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("grid_mcl_map_test_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path write(const std::string& name, const std::string& bytes) {
    std::ofstream(dir_ / name, std::ios::binary) << bytes;
    return dir_ / name;
  }
  fs::path yaml(const std::string& image, const std::string& extra = "") {
    return write("map.yaml", "image: " + image + "\nresolution: 0.5\norigin: [-1.0, 2.0, 0.0]\nnegate: 0\n"
                             "occupied_thresh: 0.65\nfree_thresh: 0.196\n" + extra);
  }
  ImageResolver resolver() const {
    return [this](const std::string& name) { return MapResolver({dir_}).resolve(name); };
  }
  OccupancyMap load(const fs::path& yaml_file, size_t max_cells = 1000) const {
    return load_occupancy_map(yaml_file, resolver(), max_cells);
  }

  fs::path dir_;
};

// 3 x 2 pixels, top row first: black (occupied), white (free), grey 205 (unknown) / ...
std::string pgm_3x2() { return std::string("P5\n# a comment\n3 2\n255\n") + std::string("\x00\xfe\xcd\xfe\x00\x80", 6); }

TEST_F(MapFiles, ReadsATrinaryPgmAsMapServerDoes) {
  write("map.pgm", pgm_3x2());
  const OccupancyMap map = load(yaml("map.pgm"));
  const GridGeometry& g = map.geometry();
  EXPECT_EQ(g.width, 3);
  EXPECT_EQ(g.height, 2);
  EXPECT_DOUBLE_EQ(g.resolution, 0.5);
  EXPECT_EQ(g.origin, Eigen::Vector2d(-1.0, 2.0));
  // Grid row 0 is the image's bottom row: 254 free, 0 occupied, 128 (p = 0.498) unknown.
  EXPECT_EQ(map.at(0, 0), OccupancyMap::kFree);
  EXPECT_EQ(map.at(0, 1), OccupancyMap::kOccupied);
  EXPECT_EQ(map.at(0, 2), OccupancyMap::kUnknown);
  EXPECT_EQ(map.at(1, 0), OccupancyMap::kOccupied);
  EXPECT_EQ(map.at(1, 1), OccupancyMap::kFree);
  EXPECT_EQ(map.at(1, 2), OccupancyMap::kUnknown);
  EXPECT_EQ(map.free_cells(), 2u);
  EXPECT_EQ(map.occupied_cells(), 2u);
}

TEST_F(MapFiles, NegateScaleAndRawModes) {
  write("map.pgm", pgm_3x2());
  const OccupancyMap negated = load(write("map.yaml", "image: map.pgm\nresolution: 0.5\norigin: [0, 0, 0]\nnegate: 1\n"));
  EXPECT_EQ(negated.at(1, 0), OccupancyMap::kFree) << "black is free when negated";
  EXPECT_EQ(negated.at(1, 1), OccupancyMap::kOccupied);
  // Scale: 128 -> p = 0.498, (0.498 - 0.196) / (0.65 - 0.196) * 100 = 66.5 -> 67.
  const OccupancyMap scaled = load(write("map.yaml", "image: map.pgm\nresolution: 0.5\norigin: [0, 0, 0]\nmode: scale\n"));
  EXPECT_EQ(scaled.at(0, 2), 67);
  EXPECT_EQ(scaled.at(0, 1), OccupancyMap::kOccupied);
  // Raw: the value itself, above 100 unknown (254 -> unknown, 0 -> 0).
  const OccupancyMap raw = load(write("map.yaml", "image: map.pgm\nresolution: 0.5\norigin: [0, 0, 0]\nmode: raw\n"));
  EXPECT_EQ(raw.at(0, 1), 0);
  EXPECT_EQ(raw.at(0, 0), OccupancyMap::kUnknown);
}

TEST_F(MapFiles, AsciiAndSixteenBitPgmAndPngWithAlpha) {
  write("ascii.pgm", "P2\n3 2\n15\n0 15 12\n15 0 8\n");
  const OccupancyMap ascii = load(yaml("ascii.pgm"));
  EXPECT_EQ(ascii.at(1, 0), OccupancyMap::kOccupied);
  EXPECT_EQ(ascii.at(1, 1), OccupancyMap::kFree);
  write("deep.pgm", std::string("P5 3 2 65535\n") + std::string("\x00\x00\xff\xff\xff\xff\xff\xff\x00\x00\x00\x00", 12));
  const OccupancyMap deep = load(yaml("deep.pgm"));
  EXPECT_EQ(deep.at(1, 0), OccupancyMap::kOccupied);
  EXPECT_EQ(deep.at(0, 1), OccupancyMap::kOccupied);
  EXPECT_EQ(deep.at(0, 0), OccupancyMap::kFree);
  // Grey + alpha PNG in scale mode: a transparent pixel is unknown.
  cv::Mat png(2, 3, CV_8UC4, cv::Scalar(255, 255, 255, 255));
  png.at<cv::Vec4b>(0, 0) = cv::Vec4b(0, 0, 0, 255);
  png.at<cv::Vec4b>(1, 2) = cv::Vec4b(255, 255, 255, 0);
  ASSERT_TRUE(cv::imwrite((dir_ / "map.png").string(), png));
  const OccupancyMap from_png = load(write("map.yaml", "image: map.png\nresolution: 0.5\norigin: [0, 0, 0]\nmode: scale\n"));
  EXPECT_EQ(from_png.at(1, 0), OccupancyMap::kOccupied);
  EXPECT_EQ(from_png.at(0, 2), OccupancyMap::kUnknown);
  EXPECT_EQ(from_png.at(0, 0), OccupancyMap::kFree);
}

TEST_F(MapFiles, SaveAndLoadRoundTrip) {
  write("map.pgm", pgm_3x2());
  const OccupancyMap original = load(yaml("map.pgm"));
  for (const char* extension : {".pgm", ".png"}) {
    save_occupancy_map(original, dir_ / "copy.yaml", extension);
    const OccupancyMap copy = load(dir_ / "copy.yaml");
    EXPECT_EQ(copy.cells(), original.cells()) << extension;
    EXPECT_EQ(copy.geometry().origin, original.geometry().origin);
  }
}

TEST_F(MapFiles, BadFilesAreRefusedWithFileAndKeyNamed) {
  write("map.pgm", pgm_3x2());
  const auto error = [&](const fs::path& yaml_file, size_t max_cells = 1000) {
    return test::error_of<ConfigError>([&] { load(yaml_file, max_cells); });
  };
  // A header that is not PGM or PNG.
  write("bad.pgm", "P7\n3 2\n255\n......");
  EXPECT_NE(error(yaml("bad.pgm")).find("'bad.pgm': is neither a PGM"), std::string::npos) << error(yaml("bad.pgm"));
  write("bad.pgm", "P5\n3 x\n255\n......");
  EXPECT_NE(error(yaml("bad.pgm")).find("expected the height"), std::string::npos);
  // Data shorter or longer than the header says.
  write("short.pgm", std::string("P5\n3 2\n255\n") + std::string(5, '\0'));
  EXPECT_NE(error(yaml("short.pgm")).find("'short.pgm': has 5 bytes of pixel data, but its header says 3 x 2 = 6 cells"),
            std::string::npos)
      << error(yaml("short.pgm"));
  write("long.pgm", std::string("P5\n3 2\n255\n") + std::string(7, '\0'));
  EXPECT_NE(error(yaml("long.pgm")).find("7 bytes of pixel data"), std::string::npos);
  // Bounded before allocation: a header claiming 100000 x 100000 pixels over a few bytes.
  write("huge.pgm", "P5\n100000 100000\n255\nxx");
  EXPECT_NE(error(yaml("huge.pgm")).find("100000 x 100000 = 10000000000 cells, more than limits.max_map_cells = 1000"),
            std::string::npos)
      << error(yaml("huge.pgm"));
  EXPECT_NE(error(yaml("map.pgm"), 5).find("limits.max_map_cells = 5"), std::string::npos);
  // The image missing, outside the map directories, or absolute.
  EXPECT_NE(error(yaml("gone.pgm")).find("map 'map.yaml': parameter 'image'"), std::string::npos) << error(yaml("gone.pgm"));
  EXPECT_NE(error(yaml("gone.pgm")).find("gone.pgm"), std::string::npos);
  EXPECT_NE(error(yaml("../map.pgm")).find("parameter 'image'"), std::string::npos) << error(yaml("../map.pgm"));
  EXPECT_NE(error(yaml("/etc/passwd")).find("parameter 'image'"), std::string::npos) << error(yaml("/etc/passwd"));
  // Thresholds out of order, a rotated origin, a missing origin, an unknown key, a bad mode.
  const std::string free_error = error(
      write("map.yaml", "image: map.pgm\nresolution: 0.5\norigin: [0, 0, 0]\noccupied_thresh: 0.6\nfree_thresh: 0.7\n"));
  EXPECT_NE(free_error.find("parameter 'free_thresh' (line 5"), std::string::npos) << free_error;
  EXPECT_NE(free_error.find("must be below occupied_thresh"), std::string::npos) << free_error;
  EXPECT_NE(error(write("map.yaml", "image: map.pgm\nresolution: 0.5\norigin: [0, 0, 0.3]\n")).find("rotated maps"),
            std::string::npos);
  EXPECT_NE(error(write("map.yaml", "image: map.pgm\nresolution: 0.5\n")).find("parameter 'origin'"), std::string::npos);
  EXPECT_NE(error(write("map.yaml", "image: map.pgm\nresolution: 0.5\norigin: [0, 0, 0]\nnegat: 1\n"))
                .find("unknown parameter 'negat'"),
            std::string::npos);
  EXPECT_NE(error(write("map.yaml", "image: map.pgm\nresolution: 0.5\norigin: [0, 0, 0]\nmode: fancy\n"))
                .find("parameter 'mode'"),
            std::string::npos);
  EXPECT_NE(error(write("map.yaml", "image: map.pgm\nresolution: -1\norigin: [0, 0, 0]\n")).find("parameter 'resolution'"),
            std::string::npos);
}

OccupancyMap random_map(uint64_t seed, int width, int height, double occupied_share) {
  std::mt19937_64 rng(seed);
  std::bernoulli_distribution occupied(occupied_share), unknown(0.05);
  GridGeometry g;
  g.resolution = 0.1;
  g.origin = Eigen::Vector2d(-2.0, 1.0);
  g.width = width;
  g.height = height;
  std::vector<int8_t> cells(g.size());
  for (int8_t& c : cells) c = occupied(rng) ? OccupancyMap::kOccupied : unknown(rng) ? OccupancyMap::kUnknown : OccupancyMap::kFree;
  return OccupancyMap(g, std::move(cells));
}

TEST(OccupancyMapCast, AgreesWithAFineSteppedReference) {
  const OccupancyMap map = random_map(3, 60, 40, 0.02);
  const GridGeometry& g = map.geometry();
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> x(g.origin.x() - 1.0, g.origin.x() + g.width * g.resolution + 1.0);
  std::uniform_real_distribution<double> y(g.origin.y() - 1.0, g.origin.y() + g.height * g.resolution + 1.0);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  int hits = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const Eigen::Vector2d origin(x(rng), y(rng));
    const double a = angle(rng);
    const Eigen::Vector2d dir(std::cos(a), std::sin(a));
    for (bool stop_at_unknown : {false, true}) {
      // Reference: the first occupied (or, with stop_at_unknown, non-free or off-map) cell met in
      // 1e-4 m steps, and the range to the ray's point nearest that cell's centre.
      std::optional<double> expected;
      int row = 0, col = 0;
      for (double t = 0.0; t <= 8.0; t += 1e-4) {
        const bool inside = g.index_of(origin + t * dir, row, col);
        if (!inside) {
          if (stop_at_unknown) {
            // leaving (or never entering) the map ends an AMCL beam
            bool ever_inside = false;
            for (double s = 0.0; s < t && !ever_inside; s += 1e-3) ever_inside = g.index_of(origin + s * dir, row, col);
            if (ever_inside || t == 0.0) {
              expected = t;
              break;
            }
          }
          continue;
        }
        const int8_t cell = map.at(row, col);
        if (cell == OccupancyMap::kOccupied || (stop_at_unknown && cell != OccupancyMap::kFree)) {
          const double centre = (g.center_of(row, col) - origin).dot(dir);
          double exit = t;
          int r2 = row, c2 = col;
          while (g.index_of(origin + exit * dir, r2, c2) && r2 == row && c2 == col) exit += 1e-4;
          expected = std::clamp(centre, t, exit);
          break;
        }
      }
      if (expected && *expected > 8.0) expected.reset();
      const auto got = cast(map, origin, a, 8.0, stop_at_unknown);
      ASSERT_EQ(got.has_value(), expected.has_value()) << trial << " " << stop_at_unknown;
      if (got) {
        EXPECT_NEAR(*got, *expected, 3e-4) << trial;
        ++hits;
      }
    }
  }
  EXPECT_GT(hits, 1000);
}

TEST(DistanceField, MatchesBruteForceWithinItsQuantum) {
  const OccupancyMap map = random_map(5, 70, 50, 0.01);
  const DistanceField field(map);
  const double quantum = map.geometry().resolution / DistanceField::kSubdivision;
  for (int r = 0; r < map.geometry().height; ++r) {
    for (int c = 0; c < map.geometry().width; ++c) {
      EXPECT_NEAR(field.distance(r, c), brute_force_distance(map, r, c), 0.5 * quantum + 1e-12) << r << " " << c;
      // The raw cell carries whether the map's cell is unknown beside the distance.
      const uint16_t code = field.cells()[static_cast<size_t>(r) * map.geometry().width + c];
      EXPECT_EQ((code & DistanceField::kUnknownBit) != 0, map.at(r, c) == OccupancyMap::kUnknown) << r << " " << c;
      EXPECT_EQ(code & DistanceField::kSaturated, field.at(r, c));
    }
  }
  // No occupied cell at all: saturated everywhere.
  GridGeometry g;
  g.width = 4;
  g.height = 3;
  const DistanceField empty(OccupancyMap(g, std::vector<int8_t>(12, OccupancyMap::kFree)));
  EXPECT_EQ(empty.at(1, 2), DistanceField::kSaturated);
}

TEST_F(MapFiles, SessionsShareOneMapPerFileVersion) {
  write("map.pgm", pgm_3x2());
  const fs::path file = yaml("map.pgm");
  const size_t before = shared_maps_alive();
  auto first = load_shared_map(file, resolver(), 1000);
  auto second = load_shared_map(file, resolver(), 1000);
  EXPECT_EQ(first.get(), second.get()) << "one copy for every session on the map";
  EXPECT_EQ(shared_maps_alive(), before + 1);
  // Concurrent loads of one file also end with one copy.
  std::vector<std::shared_ptr<const SharedMap>> loaded(4);
  std::vector<std::thread> threads;
  for (auto& slot : loaded) threads.emplace_back([&] { slot = load_shared_map(file, resolver(), 1000); });
  for (auto& t : threads) t.join();
  for (const auto& m : loaded) EXPECT_EQ(m.get(), first.get());
  // A changed image is loaded afresh; the old version lives while someone holds it.
  write("map.pgm", std::string("P5\n3 2\n255\n") + std::string(6, '\xfe'));
  fs::last_write_time(dir_ / "map.pgm", fs::last_write_time(dir_ / "map.pgm") + std::chrono::seconds(5));
  auto changed = load_shared_map(file, resolver(), 1000);
  EXPECT_NE(changed.get(), first.get());
  EXPECT_EQ(changed->map.occupied_cells(), 0u);
  EXPECT_EQ(first->map.occupied_cells(), 2u);
  // Released by every holder: gone.
  first.reset();
  second.reset();
  loaded.clear();
  changed.reset();
  EXPECT_EQ(shared_maps_alive(), before);
  // A load that fails leaves nothing behind and the next one tries again.
  write("map.pgm", "P5\n3 2\n255\nxx");
  EXPECT_THROW(load_shared_map(file, resolver(), 1000), ConfigError);
  write("map.pgm", pgm_3x2());
  EXPECT_EQ(load_shared_map(file, resolver(), 1000)->map.occupied_cells(), 2u);
}

}  // namespace

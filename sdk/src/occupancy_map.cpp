#include "locd/sdk/occupancy_map.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "locd/sdk/errors.hpp"
#include "locd/sdk/params.hpp"

namespace locd {

namespace fs = std::filesystem;

namespace {

[[noreturn]] void fail(const fs::path& file, const std::string& what) {
  throw ConfigError("map image '" + file.filename().string() + "': " + what);
}

std::string cells_text(uint64_t width, uint64_t height) {
  return std::to_string(width) + " x " + std::to_string(height) + " = " + std::to_string(width * height) + " cells";
}

void check_size(const fs::path& file, uint64_t width, uint64_t height, size_t max_cells) {
  if (width == 0 || height == 0) fail(file, "has size " + cells_text(width, height) + "; expected at least 1 x 1");
  if (width > (1u << 24) || height > (1u << 24) || width * height > max_cells) {
    fail(file, "has " + cells_text(width, height) + ", more than limits.max_map_cells = " + std::to_string(max_cells));
  }
}

// PGM header token: skips whitespace and '#' comments, reads one unsigned decimal.
uint64_t pgm_number(std::istream& in, const fs::path& file, const char* what) {
  int c = in.get();
  while (c != EOF) {
    if (c == '#') {
      while (c != EOF && c != '\n' && c != '\r') c = in.get();
    } else if (std::isspace(c)) {
      c = in.get();
    } else {
      break;
    }
  }
  if (c == EOF || !std::isdigit(c)) fail(file, std::string("PGM header: expected the ") + what + " as a number");
  uint64_t v = 0;
  while (c != EOF && std::isdigit(c)) {
    v = v * 10 + static_cast<uint64_t>(c - '0');
    if (v > (1ull << 32)) fail(file, std::string("PGM header: the ") + what + " is too large");
    c = in.get();
  }
  if (c != EOF && !std::isspace(c)) fail(file, std::string("PGM header: the ") + what + " is followed by '" + char(c) + "'");
  if (c != EOF) in.unget();
  return v;
}

MapImage read_pgm(std::istream& in, const fs::path& file, size_t max_cells) {
  char magic[2] = {0, 0};
  in.read(magic, 2);
  const bool binary = magic[1] == '5';
  const uint64_t width = pgm_number(in, file, "width");
  const uint64_t height = pgm_number(in, file, "height");
  const uint64_t maxval = pgm_number(in, file, "maxval");
  if (maxval == 0 || maxval > 65535) fail(file, "PGM header: maxval " + std::to_string(maxval) + " is outside [1, 65535]");
  check_size(file, width, height, max_cells);
  MapImage image;
  image.width = static_cast<int>(width);
  image.height = static_cast<int>(height);
  const size_t count = static_cast<size_t>(width * height);
  const auto scale = [&](uint64_t v) {
    if (v > maxval) fail(file, "a pixel value " + std::to_string(v) + " exceeds maxval " + std::to_string(maxval));
    return static_cast<uint8_t>(maxval == 255 ? v : (v * 255 + maxval / 2) / maxval);
  };
  if (!binary) {
    image.pixels.resize(count);
    for (size_t i = 0; i < count; ++i) image.pixels[i] = scale(pgm_number(in, file, "pixel value"));
    return image;
  }
  in.get();  // the single whitespace that ends the header
  const size_t bytes_per_pixel = maxval > 255 ? 2 : 1;
  const std::streampos data_start = in.tellg();
  in.seekg(0, std::ios::end);
  const std::streamoff data_bytes = in.tellg() - data_start;
  if (data_bytes != static_cast<std::streamoff>(count * bytes_per_pixel)) {
    fail(file, "has " + std::to_string(data_bytes) + " bytes of pixel data, but its header says " +
                   cells_text(width, height) + (bytes_per_pixel == 2 ? " of 2 bytes" : "") + " (" +
                   std::to_string(count * bytes_per_pixel) + " bytes)");
  }
  in.seekg(data_start);
  std::vector<uint8_t> raw(count * bytes_per_pixel);
  in.read(reinterpret_cast<char*>(raw.data()), static_cast<std::streamsize>(raw.size()));
  if (!in) fail(file, "cannot read its pixel data");
  if (bytes_per_pixel == 1 && maxval == 255) {
    image.pixels = std::move(raw);
    return image;
  }
  image.pixels.resize(count);
  for (size_t i = 0; i < count; ++i) {
    const uint64_t v = bytes_per_pixel == 2 ? (uint64_t{raw[2 * i]} << 8) | raw[2 * i + 1] : raw[i];
    image.pixels[i] = scale(v);
  }
  return image;
}

uint32_t big_endian(const unsigned char* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | uint32_t{p[3]};
}

MapImage read_png(std::istream& in, const fs::path& file, size_t max_cells) {
  unsigned char header[26];
  in.read(reinterpret_cast<char*>(header), sizeof header);
  if (!in || std::string(reinterpret_cast<const char*>(header + 12), 4) != "IHDR") {
    fail(file, "PNG without an IHDR header chunk");
  }
  check_size(file, big_endian(header + 16), big_endian(header + 20), max_cells);
  if (header[24] != 8 && header[24] != 16) {
    fail(file, "PNG bit depth " + std::to_string(header[24]) + " is not supported; allowed: 8 or 16 bits per channel");
  }
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  in.seekg(0);
  std::vector<uint8_t> bytes(static_cast<size_t>(size));
  in.read(reinterpret_cast<char*>(bytes.data()), size);
  cv::Mat decoded = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  if (decoded.empty()) fail(file, "PNG data cannot be decoded (truncated or corrupt)");
  if (decoded.depth() == CV_16U) decoded.convertTo(decoded, CV_8U, 1.0 / 257.0);
  if (decoded.cols != static_cast<int>(big_endian(header + 16)) || decoded.rows != static_cast<int>(big_endian(header + 20))) {
    fail(file, "PNG decodes to a size other than its header's");
  }
  MapImage image;
  image.width = decoded.cols;
  image.height = decoded.rows;
  image.channels = decoded.channels();
  image.pixels.resize(static_cast<size_t>(image.width) * image.height * image.channels);
  for (int r = 0; r < image.height; ++r) {
    std::copy(decoded.ptr<uint8_t>(r), decoded.ptr<uint8_t>(r) + static_cast<size_t>(image.width) * image.channels,
              image.pixels.begin() + static_cast<std::ptrdiff_t>(static_cast<size_t>(r) * image.width * image.channels));
  }
  return image;
}

}  // namespace

MapYaml read_map_yaml(const fs::path& yaml_file, const ImageResolver& resolve_image) {
  const std::string name = yaml_file.filename().string();
  try {
    const Params p = Params::load_file(yaml_file.string());
    p.expect_only({"image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode"});
    MapYaml m;
    m.yaml_file = yaml_file;
    m.image = p.required_text("image");
    m.resolution = p.required_number("resolution", Range{0.0, 100.0, true, false});
    if (!p.has("origin")) p.fail("origin", "is missing; expected [x, y, yaw] of the lower-left pixel");
    const std::vector<double> origin = p.numbers("origin", {}, 3, Range::closed(-1e7, 1e7));
    if (origin[2] != 0.0) p.fail("origin", "has yaw " + std::to_string(origin[2]) + "; rotated maps are not supported, allowed: 0");
    m.origin = Eigen::Vector2d(origin[0], origin[1]);
    m.negate = p.integer("negate", 0, 0, 1) == 1;
    m.occupied_thresh = p.number("occupied_thresh", m.occupied_thresh, Range::closed(0.0, 1.0));
    m.free_thresh = p.number("free_thresh", m.free_thresh, Range::closed(0.0, 1.0));
    if (!(m.free_thresh < m.occupied_thresh)) {
      p.fail("free_thresh", "= " + std::to_string(m.free_thresh) + " must be below occupied_thresh = " +
                                std::to_string(m.occupied_thresh));
    }
    const std::string mode = p.text("mode", "trinary", {"trinary", "scale", "raw"});
    m.mode = mode == "scale" ? MapMode::kScale : mode == "raw" ? MapMode::kRaw : MapMode::kTrinary;
    try {
      m.image_file = resolve_image(m.image);
    } catch (const ConfigError& e) {
      p.fail("image", "= '" + m.image + "' cannot be used: " + e.what());
    }
    return m;
  } catch (const ConfigError& e) {
    throw ConfigError("map '" + name + "': " + e.what());
  }
}

MapImage read_map_image(const fs::path& file, size_t max_cells) {
  std::ifstream in(file, std::ios::binary);
  if (!in) fail(file, "cannot be read");
  char magic[8] = {0};
  in.read(magic, sizeof magic);
  in.clear();
  in.seekg(0);
  if (magic[0] == 'P' && (magic[1] == '5' || magic[1] == '2')) return read_pgm(in, file, max_cells);
  if (std::string(magic, 8) == std::string("\x89PNG\r\n\x1a\n", 8)) return read_png(in, file, max_cells);
  fail(file, "is neither a PGM (P5 or P2 header) nor a PNG");
}

OccupancyMap::OccupancyMap(GridGeometry geometry, std::vector<int8_t> cells)
    : geometry_(geometry), cells_(std::move(cells)) {
  if (cells_.size() != geometry_.size()) throw ConfigError("occupancy map: cell count does not match its geometry");
  for (int8_t c : cells_) {
    free_cells_ += c == kFree;
    occupied_cells_ += c == kOccupied;
  }
}

OccupancyMap occupancy_from_image(const MapYaml& yaml, const MapImage& image) {
  GridGeometry g;
  g.resolution = yaml.resolution;
  g.origin = yaml.origin;
  g.width = image.width;
  g.height = image.height;
  std::vector<int8_t> cells(g.size());
  const int colour_channels = image.channels == 2 || image.channels == 4 ? image.channels - 1 : image.channels;
  const bool has_alpha = colour_channels != image.channels;
  for (int r = 0; r < image.height; ++r) {
    const uint8_t* row = image.pixels.data() + static_cast<size_t>(r) * image.width * image.channels;
    int8_t* out = cells.data() + static_cast<size_t>(image.height - 1 - r) * image.width;
    for (int c = 0; c < image.width; ++c) {
      const uint8_t* px = row + static_cast<size_t>(c) * image.channels;
      int sum = 0;
      for (int k = 0; k < colour_channels; ++k) sum += px[k];
      const double shade = static_cast<double>(sum) / (255.0 * colour_channels);
      const double occupancy = yaml.negate ? shade : 1.0 - shade;
      int8_t cell = OccupancyMap::kUnknown;
      switch (yaml.mode) {
        case MapMode::kTrinary:
          cell = occupancy > yaml.occupied_thresh ? OccupancyMap::kOccupied
                 : occupancy < yaml.free_thresh   ? OccupancyMap::kFree
                                                  : OccupancyMap::kUnknown;
          break;
        case MapMode::kScale:
          if (has_alpha && px[image.channels - 1] != 255) {
            cell = OccupancyMap::kUnknown;
          } else if (occupancy > yaml.occupied_thresh) {
            cell = OccupancyMap::kOccupied;
          } else if (occupancy < yaml.free_thresh) {
            cell = OccupancyMap::kFree;
          } else {
            cell = static_cast<int8_t>(
                std::lround((occupancy - yaml.free_thresh) / (yaml.occupied_thresh - yaml.free_thresh) * 100.0));
          }
          break;
        case MapMode::kRaw: {
          const long value = std::lround(shade * 255.0);
          cell = value <= 100 ? static_cast<int8_t>(value) : OccupancyMap::kUnknown;
          break;
        }
      }
      out[c] = cell;
    }
  }
  return OccupancyMap(g, std::move(cells));
}

OccupancyMap load_occupancy_map(const fs::path& yaml_file, const ImageResolver& resolve_image, size_t max_cells) {
  const MapYaml yaml = read_map_yaml(yaml_file, resolve_image);
  return occupancy_from_image(yaml, read_map_image(yaml.image_file, max_cells));
}

void save_occupancy_map(const OccupancyMap& map, const fs::path& yaml_file, const std::string& image_extension) {
  const GridGeometry& g = map.geometry();
  fs::path image_file = yaml_file;
  image_file.replace_extension(image_extension);
  cv::Mat image(g.height, g.width, CV_8UC1);
  for (int r = 0; r < g.height; ++r) {
    uint8_t* out = image.ptr<uint8_t>(g.height - 1 - r);
    for (int c = 0; c < g.width; ++c) {
      const int8_t v = map.at(r, c);
      out[c] = v == OccupancyMap::kOccupied ? 0 : v == OccupancyMap::kFree ? 254 : 205;
    }
  }
  if (image_extension == ".pgm") {
    std::ofstream out(image_file, std::ios::binary);
    out << "P5\n# CREATOR: locd " << g.resolution << " m/pix\n" << g.width << " " << g.height << "\n255\n";
    out.write(reinterpret_cast<const char*>(image.data), static_cast<std::streamsize>(g.size()));
    if (!out) throw ConfigError("cannot write '" + image_file.string() + "'");
  } else if (!cv::imwrite(image_file.string(), image)) {
    throw ConfigError("cannot write '" + image_file.string() + "'");
  }
  std::ofstream yaml(yaml_file);
  yaml << "image: " << image_file.filename().string() << "\nresolution: " << g.resolution << "\norigin: ["
       << g.origin.x() << ", " << g.origin.y() << ", 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
       << "mode: trinary\n";
  if (!yaml) throw ConfigError("cannot write '" + yaml_file.string() + "'");
}

}  // namespace locd

// MCAP written from the specification: round trips through our reader and through the npm MCAP
// reader (@mcap/core, with Foxglove's OMG IDL deserializer), recovery of a file whose writer never
// closed it, and clear errors for truncated, corrupted and foreign files.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <unistd.h>

#include <fstream>
#include <random>

#include "locd/mcap/mcap.hpp"
#include "locd/mcap/wire_codec.hpp"
#include "node_client.hpp"
#include "test_env.hpp"

namespace fs = std::filesystem;
using namespace locd::mcap;

namespace {

fs::path out_dir() {
  const fs::path dir = fs::path(locd::test::binary_dir()) / "test_output" / "mcap";
  fs::create_directories(dir);
  return dir;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}
void spit(const fs::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

locd_msg_PoseEstimate pose_sample(const std::string& robot, int i) {
  locd_msg_PoseEstimate m{};
  locd::dds::copy_string(m.robot_id, robot);
  locd::dds::copy_string(m.header.frame_id, "map");
  m.header.stamp_ns = 1'000'000'000LL + i * 100'000'000LL;
  m.pose.position.x = 0.5 * i;
  m.pose.position.y = -0.25 * i;
  m.pose.orientation.w = 1.0;
  for (int k = 0; k < 36; ++k) m.covariance[k] = k % 7 == 0 ? 0.01 : 0.0;
  locd::dds::copy_string(m.plugin, "feature_ekf");
  m.update_ms = 0.1 * i;
  return m;
}

struct Written {
  std::vector<std::pair<uint16_t, std::vector<uint8_t>>> messages;  // channel, bytes
};

// Two robots' poses and a status-less scan channel, `count` messages each, small chunks.
Written write_file(const fs::path& path, Compression compression, int count, bool close = true) {
  WriterOptions options;
  options.compression = compression;
  options.chunk_bytes = 4096;
  Writer writer(path.string(), options);
  const uint16_t schema = writer.add_schema("locd::msg::PoseEstimate", kSchemaEncoding, locd_idl());
  const uint16_t a = writer.add_channel(schema, "robot_a/locd/pose", kMessageEncoding, {{kMetaDdsTopic, "locd/pose"}});
  const uint16_t b = writer.add_channel(schema, "robot_b/locd/pose", kMessageEncoding, {{kMetaDdsTopic, "locd/pose"}});
  Written w;
  for (int i = 0; i < count; ++i) {
    for (uint16_t channel : {a, b}) {
      const auto bytes = encode(pose_sample(channel == a ? "robot_a" : "robot_b", i));
      const uint64_t t = 1'000'000'000ull + static_cast<uint64_t>(i) * 100'000'000ull + channel;
      writer.write(channel, t, t, bytes.data(), bytes.size());
      w.messages.emplace_back(channel, bytes);
    }
  }
  if (close) {
    writer.close();
  } else {
    writer.close_chunk();  // as the recorder does every second; then the process "dies"
    spit(path.string() + ".killed", slurp(path));
  }
  return w;
}

std::vector<std::pair<uint16_t, std::vector<uint8_t>>> read_all(const fs::path& path, ReadSummary* summary = nullptr) {
  std::vector<std::pair<uint16_t, std::vector<uint8_t>>> got;
  Reader reader(path.string());
  const ReadSummary s = reader.read([&](const Message& m) {
    got.emplace_back(m.channel->id, std::vector<uint8_t>(m.data, m.data + m.size));
  });
  if (summary) *summary = s;
  return got;
}

}  // namespace

TEST(Mcap, Crc32IsTheStandardOneAndChains) {
  const std::string check = "123456789";
  EXPECT_EQ(locd::mcap::crc32(check.data(), check.size()), 0xCBF43926u);  // CRC-32/ISO-HDLC check value
  EXPECT_EQ(locd::mcap::crc32(check.data() + 4, 5, locd::mcap::crc32(check.data(), 4)), 0xCBF43926u);
  EXPECT_EQ(locd::mcap::crc32(nullptr, 0), 0u);
}

TEST(Mcap, RecordingsAreReadableByTheirOwnerOnly) {
  const fs::path path = fs::temp_directory_path() / ("mcap_mode_" + std::to_string(::getpid()) + ".mcap");
  { std::ofstream(path) << "old"; }
  fs::permissions(path, fs::perms::all);  // an existing world-readable file is overwritten 0600 too
  write_file(path, Compression::kNone, 5);
  EXPECT_EQ(fs::status(path).permissions() & fs::perms::all, fs::perms::owner_read | fs::perms::owner_write);
  fs::remove(path);
}

TEST(Mcap, RoundTripEveryCompression) {
  for (Compression c : {Compression::kNone, Compression::kZstd, Compression::kLz4}) {
    const fs::path path = out_dir() / (std::string("roundtrip_") + (c == Compression::kNone ? "none" : compression_name(c)) + ".mcap");
    const Written w = write_file(path, c, 200);
    ReadSummary summary;
    const auto got = read_all(path, &summary);
    EXPECT_TRUE(summary.complete) << summary.incomplete_reason;
    EXPECT_EQ(summary.summary_message_count, 400u);
    EXPECT_GT(summary.chunks, 3u);
    ASSERT_EQ(got.size(), w.messages.size());
    for (size_t i = 0; i < got.size(); ++i) ASSERT_EQ(got[i], w.messages[i]) << "message " << i;
    // Decoding the bytes gives the sample back.
    const SamplePtr sample = decode(locd_msg_PoseEstimate_desc, got[10].second.data(), got[10].second.size());
    const auto* pose = static_cast<const locd_msg_PoseEstimate*>(sample.get());
    EXPECT_EQ(std::string(pose->robot_id), "robot_a");
    EXPECT_DOUBLE_EQ(pose->pose.position.x, 2.5);
    EXPECT_DOUBLE_EQ(pose->covariance[7], 0.01);
  }
}

TEST(Mcap, NpmReaderOpensIndexesAndDecodesEveryFile) {
  std::vector<std::string> files;
  for (Compression c : {Compression::kNone, Compression::kZstd, Compression::kLz4}) {
    const fs::path path = out_dir() / (std::string("npm_") + (c == Compression::kNone ? "none" : compression_name(c)) + ".mcap");
    write_file(path, c, 150);
    files.push_back(path.string());
  }
  const fs::path killed = out_dir() / "npm_killed.mcap";
  write_file(killed, Compression::kZstd, 150, false);
  files.push_back(killed.string() + ".killed");
  int exit_code = 0;
  const auto results = locd::test::json_lines(locd::test::run_node("read_mcap.mjs", files, exit_code));
  ASSERT_EQ(exit_code, 0);
  ASSERT_EQ(results.size(), files.size());
  for (size_t i = 0; i + 1 < results.size(); ++i) {
    const auto& r = results[i];
    ASSERT_TRUE(r["ok"].get<bool>()) << r.dump();
    EXPECT_EQ(r["reader"], "indexed") << r.dump();
    EXPECT_EQ(r["messages"], 300) << r.dump();
    EXPECT_EQ(r["statistics_messages"], 300);
    EXPECT_EQ(r["decoded"], 300);
    EXPECT_GT(r["chunks"].get<int>(), 3);
    EXPECT_EQ(r["topics"]["robot_b/locd/pose"], 150);
    // Foxglove's deserializer, given only the IDL in the file, reads the values written.
    const auto& pose = r["poses"][20];  // robot_a's 11th pose
    EXPECT_EQ(pose["robot_id"], "robot_a");
    EXPECT_DOUBLE_EQ(pose["x"].get<double>(), 5.0);
    EXPECT_DOUBLE_EQ(pose["y"].get<double>(), -2.5);
  }
  // The unclosed file: no footer, the streaming reader reads every closed chunk.
  const auto& k = results.back();
  ASSERT_TRUE(k["ok"].get<bool>()) << k.dump();
  EXPECT_EQ(k["reader"], "stream");
  EXPECT_EQ(k["messages"], 300) << k.dump();
  EXPECT_EQ(k["decoded"], 300);
}

TEST(Mcap, UnclosedFileIsRecoverable) {
  const fs::path path = out_dir() / "unclosed.mcap";
  const Written w = write_file(path, Compression::kLz4, 100, false);
  ReadSummary summary;
  const auto got = read_all(path.string() + ".killed", &summary);
  EXPECT_FALSE(summary.complete);
  EXPECT_NE(summary.incomplete_reason.find("without a footer"), std::string::npos) << summary.incomplete_reason;
  EXPECT_EQ(got, w.messages);
}

TEST(Mcap, TruncatedAnywhereYieldsAPrefixAndSaysWhere) {
  const fs::path path = out_dir() / "truncate_source.mcap";
  const Written w = write_file(path, Compression::kZstd, 60);
  const std::string bytes = slurp(path);
  const fs::path cut = out_dir() / "truncated.mcap";
  size_t previous = 0;
  for (size_t length = 8; length < bytes.size(); length += 97) {
    spit(cut, bytes.substr(0, length));
    ReadSummary summary;
    std::vector<std::pair<uint16_t, std::vector<uint8_t>>> got;
    ASSERT_NO_THROW(got = read_all(cut, &summary)) << "cut at " << length;
    EXPECT_FALSE(summary.complete);
    EXPECT_FALSE(summary.incomplete_reason.empty());
    ASSERT_LE(got.size(), w.messages.size());
    EXPECT_TRUE(std::equal(got.begin(), got.end(), w.messages.begin())) << "cut at " << length;
    EXPECT_GE(got.size(), previous);  // more file, never fewer messages
    previous = got.size();
  }
  EXPECT_GT(previous, w.messages.size() / 2);
  // Cut inside the closing magic bytes: every message, and the file said truncated.
  for (size_t missing = 1; missing < 8; ++missing) {
    spit(cut, bytes.substr(0, bytes.size() - missing));
    ReadSummary summary;
    std::vector<std::pair<uint16_t, std::vector<uint8_t>>> got;
    ASSERT_NO_THROW(got = read_all(cut, &summary)) << missing << " bytes missing";
    EXPECT_FALSE(summary.complete);
    EXPECT_NE(summary.incomplete_reason.find("inside its closing magic bytes"), std::string::npos)
        << summary.incomplete_reason;
    EXPECT_EQ(got, w.messages);
  }
}

TEST(Mcap, ForeignFileIsRefusedByName) {
  const fs::path path = out_dir() / "not_mcap.mcap";
  spit(path, "%YAML 1.2\nplugin: feature_ekf\n");
  try {
    Reader reader(path.string());
    FAIL() << "a YAML file was opened as MCAP";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("not_mcap.mcap' is not an MCAP file"), std::string::npos) << e.what();
  }
  EXPECT_THROW(Reader((out_dir() / "does_not_exist.mcap").string()), FormatError);
}

TEST(Mcap, CorruptedChunkIsAnErrorNamingTheOffset) {
  const fs::path path = out_dir() / "corrupt_source.mcap";
  write_file(path, Compression::kNone, 40);
  std::string bytes = slurp(path);
  // Flip a byte inside the first chunk's records (the chunk follows the magic and the header).
  const size_t chunk = bytes.find('\x06', 8 + 9);
  ASSERT_NE(chunk, std::string::npos);
  bytes[chunk + 200] ^= 0x5a;
  const fs::path bad = out_dir() / "corrupt.mcap";
  spit(bad, bytes);
  try {
    read_all(bad);
    FAIL() << "a corrupted chunk was read";
  } catch (const FormatError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("corrupt.mcap' at byte " + std::to_string(chunk)), std::string::npos) << what;
    EXPECT_NE(what.find("CRC"), std::string::npos) << what;
  }
}

TEST(Mcap, HugeSizesAreRefusedBeforeAllocating) {
  const fs::path path = out_dir() / "huge_source.mcap";
  write_file(path, Compression::kZstd, 20);
  std::string bytes = slurp(path);
  const size_t chunk = bytes.find('\x06', 8 + 9);
  // uncompressed_size sits after opcode, length, start and end time.
  const uint64_t huge = 1ull << 60;
  std::memcpy(bytes.data() + chunk + 9 + 16, &huge, 8);
  const fs::path bad = out_dir() / "huge.mcap";
  spit(bad, bytes);
  try {
    read_all(bad);
    FAIL();
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("exceeds the limit"), std::string::npos) << e.what();
  }
}

TEST(Mcap, RandomDamageNeverCrashes) {
  const fs::path path = out_dir() / "damage_source.mcap";
  write_file(path, Compression::kLz4, 30);
  const std::string clean = slurp(path);
  std::mt19937 rng(17);
  const fs::path bad = out_dir() / "damaged.mcap";
  int errors = 0;
  for (int trial = 0; trial < 300; ++trial) {
    std::string bytes = clean;
    for (int k = 0; k < 1 + trial % 4; ++k) bytes[8 + rng() % (bytes.size() - 8)] = static_cast<char>(rng());
    spit(bad, bytes);
    try {
      read_all(bad);
    } catch (const FormatError&) {
      ++errors;
    }
  }
  EXPECT_GT(errors, 0);
}

TEST(WireCodec, DecodeRefusesBadBytes) {
  const auto bytes = encode(pose_sample("robot_a", 3));
  EXPECT_EQ(robot_id_of(bytes.data(), bytes.size()), "robot_a");
  EXPECT_THROW(decode(locd_msg_PoseEstimate_desc, bytes.data(), bytes.size() / 2), std::invalid_argument);
  EXPECT_THROW(decode(locd_msg_PoseEstimate_desc, bytes.data(), 3), std::invalid_argument);
  auto bad_header = bytes;
  bad_header[1] = 0x0a;  // PL_CDR2: not a plain encoding
  EXPECT_THROW(decode(locd_msg_PoseEstimate_desc, bad_header.data(), bad_header.size()), std::invalid_argument);
  // A scan whose ranges claim 2^31 floats in a few bytes: refused before any allocation.
  locd_msg_LaserScan scan{};
  locd::dds::copy_string(scan.robot_id, "r");
  float ranges[3] = {1, 2, 3};
  scan.ranges._buffer = ranges;
  scan.ranges._length = scan.ranges._maximum = 3;
  auto scan_bytes = encode(scan);
  const SamplePtr ok = decode(locd_msg_LaserScan_desc, scan_bytes.data(), scan_bytes.size());
  EXPECT_EQ(static_cast<const locd_msg_LaserScan*>(ok.get())->ranges._length, 3u);
  // The ranges length follows the header, the robot id, the message header, the pose and 4 floats.
  const std::vector<uint8_t> three = {3, 0, 0, 0};
  auto it = std::search(scan_bytes.begin() + 4 + 8, scan_bytes.end(), three.begin(), three.end());
  ASSERT_NE(it, scan_bytes.end());
  const uint32_t huge = 0x7fffffff;
  std::memcpy(&*it, &huge, 4);
  try {
    decode(locd_msg_LaserScan_desc, scan_bytes.data(), scan_bytes.size());
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("LaserScan"), std::string::npos) << e.what();
  }
}

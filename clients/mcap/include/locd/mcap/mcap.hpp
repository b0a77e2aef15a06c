// MCAP (https://mcap.dev/spec, format version 0) written and read from the specification: the
// subset a recorder and a replayer need, no DDS in here.
//
// Writer: Header, then chunks (zstd, lz4 frame or none) each followed by its Message Index
// records, then Data End and the summary section (Schema, Channel, Statistics, Chunk Index, each
// group listed by a Summary Offset) and the Footer. A chunk is closed when it reaches
// chunk_bytes or when the caller asks (close_chunk, close_chunk_if_older); every closed chunk is
// handed to the kernel at once, so a recorder killed at any moment leaves a file whose closed
// chunks a streaming reader (or Reader below) still reads: only the open chunk is lost.
//
// Reader: reads the records in file order (a linear scan, so it also reads a file whose summary
// and footer never got written), checks every length against what is left of its record, chunk
// and file and every chunk's size against ReadLimits before allocating, checks CRCs, and says in
// the error which file, which byte offset and what was wrong.
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace locd::mcap {

// A malformed, truncated or foreign file; the message names the file, the offset and the cause.
class FormatError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class Compression { kNone, kZstd, kLz4 };
// "", "zstd", "lz4" (the names MCAP uses); parse throws std::invalid_argument naming the allowed ones.
const char* compression_name(Compression c);
Compression parse_compression(const std::string& name);

using Metadata = std::map<std::string, std::string>;

struct WriterOptions {
  Compression compression = Compression::kZstd;
  size_t chunk_bytes = 1 << 20;      // close a chunk when its records reach this size
  int zstd_level = 1;                // fast: a recorder must keep up with a fleet
  std::string profile;               // MCAP profile ("" = none; locd's types are not ROS 2 messages)
  std::string library = "locd";
};

class Writer {
 public:
  // Creates (truncates) path and writes the magic and the Header. Throws std::runtime_error
  // naming the file when it cannot be written.
  Writer(const std::string& path, const WriterOptions& options = {});
  ~Writer();  // close()s; errors are swallowed here, call close() to see them
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  uint16_t add_schema(const std::string& name, const std::string& encoding, const std::string& data);
  uint16_t add_channel(uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                       const Metadata& metadata = {});
  // Times in nanoseconds. data is copied into the open chunk.
  void write(uint16_t channel_id, uint64_t log_time, uint64_t publish_time, const void* data, size_t size);
  // Writes the open chunk (if it holds anything) and its message indexes, and flushes to the kernel.
  void close_chunk();
  // close_chunk() when the open chunk's first record is older than age (a recorder calls this
  // periodically so a kill loses at most `age` of data).
  void close_chunk_if_older(std::chrono::steady_clock::duration age);
  // Closes the last chunk, writes Data End, the summary section and the footer, closes the file.
  void close();

  uint64_t messages() const { return message_count_; }
  uint64_t bytes_written() const { return offset_; }

 private:
  struct ChannelInfo { uint16_t schema_id; std::string topic, encoding; Metadata metadata; };
  struct SchemaInfo { std::string name, encoding, data; };
  struct ChunkIndex {
    uint64_t start_time, end_time, chunk_offset, chunk_length, message_index_length;
    std::map<uint16_t, uint64_t> message_index_offsets;
    uint64_t compressed_size, uncompressed_size;
  };
  void put(const std::string& bytes);  // to the file, with the data-section CRC
  void append_to_chunk(const std::string& record);

  std::FILE* file_ = nullptr;
  std::string path_;
  WriterOptions options_;
  uint64_t offset_ = 0;
  uint32_t data_crc_ = 0;
  bool closed_ = false;
  std::vector<SchemaInfo> schemas_;    // id = index + 1
  std::vector<ChannelInfo> channels_;  // id = index
  std::vector<bool> schema_in_chunk_, channel_in_chunk_;  // written into the open chunk already
  std::vector<bool> schema_written_, channel_written_;    // written into some chunk
  std::vector<ChunkIndex> chunk_indexes_;
  // The open chunk.
  std::string chunk_;
  uint64_t chunk_start_time_ = 0, chunk_end_time_ = 0;
  bool chunk_has_messages_ = false;
  std::chrono::steady_clock::time_point chunk_opened_;
  std::map<uint16_t, std::vector<std::pair<uint64_t, uint64_t>>> chunk_message_index_;  // channel -> (time, offset)
  // Statistics.
  uint64_t message_count_ = 0, message_start_ = 0, message_end_ = 0;
  std::map<uint16_t, uint64_t> channel_message_counts_;
};

struct Schema {
  uint16_t id = 0;
  std::string name, encoding, data;
};

struct Channel {
  uint16_t id = 0;
  uint16_t schema_id = 0;
  std::string topic, message_encoding;
  Metadata metadata;
};

struct Message {
  const Channel* channel = nullptr;
  const Schema* schema = nullptr;  // nullptr for schema id 0 (no schema)
  uint32_t sequence = 0;
  uint64_t log_time = 0, publish_time = 0;
  const uint8_t* data = nullptr;  // valid during the callback only
  size_t size = 0;
};

struct ReadLimits {
  uint64_t max_chunk_bytes = 512ull << 20;   // uncompressed size of one chunk
  uint64_t max_record_bytes = 512ull << 20;  // one record outside a chunk (a chunk's compressed size)
};

// What a read found besides the messages.
struct ReadSummary {
  uint64_t messages = 0;
  uint64_t chunks = 0;
  bool complete = false;        // Data End, summary and footer present and consistent
  std::string incomplete_reason;  // why not: e.g. "the file ends inside a chunk at byte 1234 (truncated)"
  uint64_t summary_message_count = 0;  // from the Statistics record, when complete
};

class Reader {
 public:
  // Throws FormatError unless the file starts with MCAP's magic.
  explicit Reader(const std::string& path, const ReadLimits& limits = {});
  ~Reader();
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  // Reads every record in file order and hands each message to `on_message`. A file cut short
  // (a killed recorder) yields every message of its complete chunks and a summary that says
  // where it ends (complete = false); a corrupt record (bad length, CRC, compression, unknown
  // channel) throws FormatError after the messages before it were delivered.
  ReadSummary read(const std::function<void(const Message&)>& on_message);

  const std::map<uint16_t, Schema>& schemas() const { return schemas_; }
  const std::map<uint16_t, Channel>& channels() const { return channels_; }

 private:
  struct Cursor;
  void record(uint8_t opcode, Cursor content, uint64_t offset, bool in_chunk,
              const std::function<void(const Message&)>& on_message, ReadSummary& summary);
  [[noreturn]] void fail(uint64_t offset, const std::string& what) const;

  std::string path_;
  ReadLimits limits_;
  std::FILE* file_ = nullptr;
  uint64_t file_size_ = 0;
  std::map<uint16_t, Schema> schemas_;
  std::map<uint16_t, Channel> channels_;
};

// CRC-32 (ISO-HDLC, as zlib), the checksum MCAP uses. crc = previous value for a running CRC.
uint32_t crc32(const void* data, size_t size, uint32_t crc = 0);

}  // namespace locd::mcap

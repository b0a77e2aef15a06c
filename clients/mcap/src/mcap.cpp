#include "locd/mcap/mcap.hpp"

#include <fcntl.h>
#include <lz4frame.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <memory>

namespace locd::mcap {
namespace {

constexpr char kMagic[] = "\x89MCAP0\r\n";
constexpr size_t kMagicSize = 8;
constexpr size_t kRecordPrefix = 9;  // opcode + uint64 length

enum Opcode : uint8_t {
  kHeader = 0x01, kFooter = 0x02, kSchema = 0x03, kChannel = 0x04, kMessage = 0x05, kChunk = 0x06,
  kMessageIndex = 0x07, kChunkIndex = 0x08, kStatistics = 0x0B, kSummaryOffset = 0x0E, kDataEnd = 0x0F,
};

// Little-endian serialization of MCAP's primitive types.
struct Out {
  std::string bytes;
  Out& u8(uint8_t v) { bytes.push_back(static_cast<char>(v)); return *this; }
  template <typename T>
  Out& le(T v) {
    for (size_t i = 0; i < sizeof(T); ++i) bytes.push_back(static_cast<char>((static_cast<uint64_t>(v) >> (8 * i)) & 0xff));
    return *this;
  }
  Out& u16(uint16_t v) { return le(v); }
  Out& u32(uint32_t v) { return le(v); }
  Out& u64(uint64_t v) { return le(v); }
  Out& str(const std::string& s) { u32(static_cast<uint32_t>(s.size())); bytes += s; return *this; }
  Out& raw(const std::string& s) { bytes += s; return *this; }
};

std::string record(Opcode op, const std::string& content) {
  Out out;
  out.u8(op).u64(content.size()).raw(content);
  return std::move(out.bytes);
}

std::string compress(Compression c, const std::string& in, int zstd_level) {
  std::string out;
  if (c == Compression::kZstd) {
    out.resize(ZSTD_compressBound(in.size()));
    const size_t n = ZSTD_compress(out.data(), out.size(), in.data(), in.size(), zstd_level);
    if (ZSTD_isError(n)) throw std::runtime_error(std::string("zstd compression failed: ") + ZSTD_getErrorName(n));
    out.resize(n);
  } else if (c == Compression::kLz4) {
    LZ4F_preferences_t prefs{};
    prefs.frameInfo.contentSize = in.size();
    out.resize(LZ4F_compressFrameBound(in.size(), &prefs));
    const size_t n = LZ4F_compressFrame(out.data(), out.size(), in.data(), in.size(), &prefs);
    if (LZ4F_isError(n)) throw std::runtime_error(std::string("lz4 compression failed: ") + LZ4F_getErrorName(n));
    out.resize(n);
  } else {
    out = in;
  }
  return out;
}

// Decompresses into exactly `size` bytes; an error message (empty = ok).
std::string decompress(const std::string& compression, const uint8_t* in, size_t in_size, std::string& out,
                       uint64_t size) {
  out.resize(size);
  if (compression.empty()) {
    if (in_size != size) return "uncompressed chunk holds " + std::to_string(in_size) + " bytes, its header says " + std::to_string(size);
    std::memcpy(out.data(), in, size);
    return "";
  }
  if (compression == "zstd") {
    const size_t n = ZSTD_decompress(out.data(), size, in, in_size);
    if (ZSTD_isError(n)) return std::string("zstd: ") + ZSTD_getErrorName(n);
    if (n != size) return "zstd: " + std::to_string(n) + " bytes decompressed, the header says " + std::to_string(size);
    return "";
  }
  if (compression == "lz4") {
    LZ4F_dctx* raw = nullptr;
    if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION))) return "lz4: no decompression context";
    std::unique_ptr<LZ4F_dctx, size_t (*)(LZ4F_dctx*)> ctx(raw, LZ4F_freeDecompressionContext);
    size_t done_in = 0, done_out = 0, hint = 1;
    while (done_in < in_size && hint != 0) {
      size_t src = in_size - done_in, dst = size - done_out;
      hint = LZ4F_decompress(ctx.get(), out.data() + done_out, &dst, in + done_in, &src, nullptr);
      if (LZ4F_isError(hint)) return std::string("lz4: ") + LZ4F_getErrorName(hint);
      done_in += src;
      done_out += dst;
      if (src == 0 && dst == 0) break;  // no progress: output full or input exhausted
    }
    if (hint != 0 || done_out != size) {
      return "lz4: frame incomplete or not " + std::to_string(size) + " bytes (" + std::to_string(done_out) + " decompressed)";
    }
    return "";
  }
  return "unknown compression '" + compression + "' (known: none, zstd, lz4)";
}

}  // namespace

uint32_t crc32(const void* data, size_t size, uint32_t crc) {
  // zlib's CRC-32 (the one MCAP specifies), fed in pieces zlib's length type holds.
  const auto* p = static_cast<const Bytef*>(data);
  uLong c = crc;
  while (size > 0) {
    const uInt piece = static_cast<uInt>(std::min<size_t>(size, 1u << 30));
    c = ::crc32(c, p, piece);
    p += piece;
    size -= piece;
  }
  return static_cast<uint32_t>(c);
}

const char* compression_name(Compression c) {
  switch (c) {
    case Compression::kZstd: return "zstd";
    case Compression::kLz4: return "lz4";
    default: return "";
  }
}

Compression parse_compression(const std::string& name) {
  if (name == "zstd") return Compression::kZstd;
  if (name == "lz4") return Compression::kLz4;
  if (name == "none" || name.empty()) return Compression::kNone;
  throw std::invalid_argument("compression '" + name + "': allowed zstd, lz4, none");
}

// ------------------------------------------------------------------------------------ Writer

Writer::Writer(const std::string& path, const WriterOptions& options) : path_(path), options_(options) {
  // 0600: a recording holds every robot's poses and sensor data; it is its recorder's to share.
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  file_ = fd < 0 ? nullptr : ::fdopen(fd, "wb");
  if (!file_) {
    const int error = errno;
    if (fd >= 0) ::close(fd);
    throw std::runtime_error("cannot write '" + path + "': " + std::strerror(error));
  }
  ::fchmod(fd, 0600);  // an existing file overwritten keeps its old mode otherwise
  put(std::string(kMagic, kMagicSize));
  put(record(kHeader, Out().str(options_.profile).str(options_.library).bytes));
  std::fflush(file_);
}

Writer::~Writer() {
  try {
    close();
  } catch (...) {
  }
}

void Writer::put(const std::string& bytes) {
  if (std::fwrite(bytes.data(), 1, bytes.size(), file_) != bytes.size()) {
    throw std::runtime_error("cannot write '" + path_ + "': " + std::strerror(errno));
  }
  data_crc_ = crc32(bytes.data(), bytes.size(), data_crc_);
  offset_ += bytes.size();
}

uint16_t Writer::add_schema(const std::string& name, const std::string& encoding, const std::string& data) {
  if (schemas_.size() >= 0xfffe) throw std::length_error("'" + path_ + "': more than 65534 schemas");
  schemas_.push_back({name, encoding, data});
  schema_written_.push_back(false);
  return static_cast<uint16_t>(schemas_.size());
}

uint16_t Writer::add_channel(uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                             const Metadata& metadata) {
  if (schema_id > schemas_.size()) throw std::invalid_argument("unknown schema id " + std::to_string(schema_id));
  if (channels_.size() >= 0xffff) throw std::length_error("'" + path_ + "': more than 65535 channels");
  channels_.push_back({schema_id, topic, message_encoding, metadata});
  channel_written_.push_back(false);
  return static_cast<uint16_t>(channels_.size() - 1);
}

namespace {
std::string schema_record(uint16_t id, const std::string& name, const std::string& encoding, const std::string& data) {
  return record(kSchema, Out().u16(id).str(name).str(encoding).str(data).bytes);
}
std::string channel_record(uint16_t id, uint16_t schema_id, const std::string& topic, const std::string& encoding,
                           const Metadata& metadata) {
  Out map;
  for (const auto& [k, v] : metadata) map.str(k).str(v);
  return record(kChannel, Out().u16(id).u16(schema_id).str(topic).str(encoding).str(map.bytes).bytes);
}
}  // namespace

void Writer::append_to_chunk(const std::string& r) {
  if (chunk_.empty()) chunk_opened_ = std::chrono::steady_clock::now();
  chunk_ += r;
}

void Writer::write(uint16_t channel_id, uint64_t log_time, uint64_t publish_time, const void* data, size_t size) {
  if (closed_) throw std::logic_error("'" + path_ + "' is closed");
  if (channel_id >= channels_.size()) throw std::invalid_argument("unknown channel id " + std::to_string(channel_id));
  const ChannelInfo& channel = channels_[channel_id];
  if (channel.schema_id != 0 && !schema_written_[channel.schema_id - 1]) {
    const SchemaInfo& s = schemas_[channel.schema_id - 1];
    append_to_chunk(schema_record(channel.schema_id, s.name, s.encoding, s.data));
    schema_written_[channel.schema_id - 1] = true;
  }
  if (!channel_written_[channel_id]) {
    append_to_chunk(channel_record(channel_id, channel.schema_id, channel.topic, channel.encoding, channel.metadata));
    channel_written_[channel_id] = true;
  }
  const uint64_t sequence = channel_message_counts_[channel_id]++;
  chunk_message_index_[channel_id].emplace_back(log_time, chunk_.size());
  Out m;
  m.u8(kMessage).u64(2 + 4 + 8 + 8 + size).u16(channel_id).u32(static_cast<uint32_t>(sequence)).u64(log_time).u64(publish_time);
  m.bytes.append(static_cast<const char*>(data), size);
  append_to_chunk(m.bytes);
  if (!chunk_has_messages_) {
    chunk_start_time_ = chunk_end_time_ = log_time;
    chunk_has_messages_ = true;
  }
  chunk_start_time_ = std::min(chunk_start_time_, log_time);
  chunk_end_time_ = std::max(chunk_end_time_, log_time);
  if (message_count_ == 0) message_start_ = message_end_ = log_time;
  message_start_ = std::min(message_start_, log_time);
  message_end_ = std::max(message_end_, log_time);
  ++message_count_;
  if (chunk_.size() >= options_.chunk_bytes) close_chunk();
}

void Writer::close_chunk() {
  if (chunk_.empty() || closed_) return;
  const std::string compressed = compress(options_.compression, chunk_, options_.zstd_level);
  ChunkIndex index{};
  index.start_time = chunk_start_time_;
  index.end_time = chunk_end_time_;
  index.chunk_offset = offset_;
  index.compressed_size = compressed.size();
  index.uncompressed_size = chunk_.size();
  Out chunk;
  chunk.u64(chunk_start_time_).u64(chunk_end_time_).u64(chunk_.size()).u32(crc32(chunk_.data(), chunk_.size()))
      .str(compression_name(options_.compression)).u64(compressed.size()).raw(compressed);
  const std::string r = record(kChunk, chunk.bytes);
  put(r);
  index.chunk_length = r.size();
  const uint64_t indexes_start = offset_;
  for (const auto& [channel, entries] : chunk_message_index_) {
    Out body;
    body.u16(channel).u32(static_cast<uint32_t>(entries.size() * 16));
    for (const auto& [time, offset] : entries) body.u64(time).u64(offset);
    index.message_index_offsets[channel] = offset_;
    put(record(kMessageIndex, body.bytes));
  }
  index.message_index_length = offset_ - indexes_start;
  chunk_indexes_.push_back(std::move(index));
  chunk_.clear();
  chunk_message_index_.clear();
  chunk_has_messages_ = false;
  if (std::fflush(file_) != 0) throw std::runtime_error("cannot write '" + path_ + "': " + std::strerror(errno));
}

void Writer::close_chunk_if_older(std::chrono::steady_clock::duration age) {
  if (!chunk_.empty() && std::chrono::steady_clock::now() - chunk_opened_ >= age) close_chunk();
}

void Writer::close() {
  if (closed_ || !file_) return;
  close_chunk();
  closed_ = true;
  put(record(kDataEnd, Out().u32(data_crc_).bytes));
  const uint64_t summary_start = offset_;
  uint32_t summary_crc = 0;
  auto put_summary = [&](const std::string& bytes) {
    summary_crc = crc32(bytes.data(), bytes.size(), summary_crc);
    put(bytes);
  };
  struct Group { Opcode op; uint64_t start, length; };
  std::vector<Group> groups;
  auto group = [&](Opcode op, const std::vector<std::string>& records) {
    if (records.empty()) return;
    const uint64_t start = offset_;
    for (const auto& r : records) put_summary(r);
    groups.push_back({op, start, offset_ - start});
  };
  std::vector<std::string> records;
  for (size_t i = 0; i < schemas_.size(); ++i) {
    records.push_back(schema_record(static_cast<uint16_t>(i + 1), schemas_[i].name, schemas_[i].encoding, schemas_[i].data));
  }
  group(kSchema, records);
  records.clear();
  for (size_t i = 0; i < channels_.size(); ++i) {
    const ChannelInfo& c = channels_[i];
    records.push_back(channel_record(static_cast<uint16_t>(i), c.schema_id, c.topic, c.encoding, c.metadata));
  }
  group(kChannel, records);
  Out counts;
  for (const auto& [channel, count] : channel_message_counts_) counts.u16(channel).u64(count);
  Out stats;
  stats.u64(message_count_).u16(static_cast<uint16_t>(schemas_.size())).u32(static_cast<uint32_t>(channels_.size()))
      .u32(0).u32(0).u32(static_cast<uint32_t>(chunk_indexes_.size())).u64(message_start_).u64(message_end_)
      .str(counts.bytes);
  group(kStatistics, {record(kStatistics, stats.bytes)});
  records.clear();
  for (const ChunkIndex& c : chunk_indexes_) {
    Out offsets;
    for (const auto& [channel, offset] : c.message_index_offsets) offsets.u16(channel).u64(offset);
    Out body;
    body.u64(c.start_time).u64(c.end_time).u64(c.chunk_offset).u64(c.chunk_length).str(offsets.bytes)
        .u64(c.message_index_length).str(compression_name(options_.compression)).u64(c.compressed_size)
        .u64(c.uncompressed_size);
    records.push_back(record(kChunkIndex, body.bytes));
  }
  group(kChunkIndex, records);
  const uint64_t summary_offset_start = offset_;
  for (const Group& g : groups) put_summary(record(kSummaryOffset, Out().u8(g.op).u64(g.start).u64(g.length).bytes));
  Out footer;
  footer.u8(kFooter).u64(20).u64(summary_start).u64(summary_offset_start);
  summary_crc = crc32(footer.bytes.data(), footer.bytes.size(), summary_crc);
  footer.u32(summary_crc);
  put(footer.bytes);
  put(std::string(kMagic, kMagicSize));
  const bool flushed = std::fflush(file_) == 0;
  std::fclose(file_);
  file_ = nullptr;
  if (!flushed) throw std::runtime_error("cannot write '" + path_ + "': " + std::strerror(errno));
}

// ------------------------------------------------------------------------------------ Reader

// Bounds-checked little-endian reads over one record's content.
struct Reader::Cursor {
  const uint8_t* p;
  size_t n;
  struct Short : std::runtime_error { using std::runtime_error::runtime_error; };
  void need(size_t k, const char* what) const {
    if (k > n) throw Short(std::string(what) + " needs " + std::to_string(k) + " bytes, the record has " + std::to_string(n) + " left");
  }
  template <typename T>
  T le(const char* what) {
    need(sizeof(T), what);
    uint64_t v = 0;
    for (size_t i = 0; i < sizeof(T); ++i) v |= static_cast<uint64_t>(p[i]) << (8 * i);
    p += sizeof(T);
    n -= sizeof(T);
    return static_cast<T>(v);
  }
  Cursor sub(uint64_t k, const char* what) {
    need(k, what);
    Cursor c{p, static_cast<size_t>(k)};
    p += k;
    n -= k;
    return c;
  }
  std::string str(const char* what) {
    const uint32_t k = le<uint32_t>(what);
    Cursor c = sub(k, what);
    return std::string(reinterpret_cast<const char*>(c.p), c.n);
  }
};

Reader::Reader(const std::string& path, const ReadLimits& limits) : path_(path), limits_(limits) {
  file_ = std::fopen(path.c_str(), "rb");
  if (!file_) throw FormatError("cannot read '" + path + "': " + std::strerror(errno));
  std::fseek(file_, 0, SEEK_END);
  file_size_ = static_cast<uint64_t>(std::ftell(file_));
  std::fseek(file_, 0, SEEK_SET);
  char magic[kMagicSize] = {};
  const size_t got = std::fread(magic, 1, kMagicSize, file_);
  if (got != kMagicSize || std::memcmp(magic, kMagic, kMagicSize) != 0) {
    std::fclose(file_);
    file_ = nullptr;
    throw FormatError("'" + path + "' is not an MCAP file: it does not begin with MCAP's magic bytes (0x89 'MCAP0' CR LF)");
  }
}

Reader::~Reader() {
  if (file_) std::fclose(file_);
}

void Reader::fail(uint64_t offset, const std::string& what) const {
  throw FormatError("'" + path_ + "' at byte " + std::to_string(offset) + ": " + what);
}

ReadSummary Reader::read(const std::function<void(const Message&)>& on_message) {
  ReadSummary summary;
  std::fseek(file_, static_cast<long>(kMagicSize), SEEK_SET);
  uint64_t offset = kMagicSize;
  uint32_t crc = crc32(kMagic, kMagicSize);
  bool header_seen = false, data_end_seen = false, footer_seen = false;
  std::string content;
  for (;;) {
    const uint64_t left = file_size_ - offset;
    if (footer_seen) {
      char magic[kMagicSize];
      if (left <= kMagicSize && std::fread(magic, 1, left, file_) == left && std::memcmp(magic, kMagic, left) == 0) {
        if (left < kMagicSize) {
          summary.incomplete_reason = "the file ends inside its closing magic bytes at byte " +
                                      std::to_string(file_size_) + " (truncated)";
          break;
        }
        summary.complete = data_end_seen;
        if (!data_end_seen) summary.incomplete_reason = "no Data End record before the summary";
        break;
      }
      fail(offset, "the footer must be followed by the closing magic bytes and nothing else");
    }
    if (left == 0) {
      summary.incomplete_reason = "the file ends at byte " + std::to_string(offset) + " without a footer (truncated: the recorder was stopped before closing it)";
      break;
    }
    if (left < kRecordPrefix) {
      summary.incomplete_reason = "the file ends inside a record at byte " + std::to_string(offset) + " (truncated)";
      break;
    }
    uint8_t prefix[kRecordPrefix];
    if (std::fread(prefix, 1, kRecordPrefix, file_) != kRecordPrefix) fail(offset, "read error");
    Cursor c{prefix + 1, 8};
    const uint8_t opcode = prefix[0];
    const uint64_t length = c.le<uint64_t>("record length");
    if (!header_seen && opcode != kHeader) fail(offset, "the first record is not a Header (opcode " + std::to_string(opcode) + ")");
    if (length > left - kRecordPrefix) {
      summary.incomplete_reason = "the record at byte " + std::to_string(offset) + " (opcode " + std::to_string(opcode) +
                                  ") claims " + std::to_string(length) + " bytes but the file has " +
                                  std::to_string(left - kRecordPrefix) + " left (truncated)";
      break;
    }
    if (length > limits_.max_record_bytes) {
      fail(offset, "record of " + std::to_string(length) + " bytes exceeds the limit of " +
                       std::to_string(limits_.max_record_bytes) + " bytes");
    }
    content.resize(length);
    if (length > 0 && std::fread(content.data(), 1, length, file_) != length) fail(offset, "read error");
    if (opcode == kHeader) header_seen = true;
    if (opcode == kDataEnd) {
      Cursor d{reinterpret_cast<const uint8_t*>(content.data()), content.size()};
      try {
        const uint32_t expected = d.le<uint32_t>("data section CRC");
        if (expected != 0 && expected != crc) fail(offset, "the data section's CRC does not match (corrupt file)");
      } catch (const Cursor::Short& e) {
        fail(offset, std::string("Data End: ") + e.what());
      }
      data_end_seen = true;
    } else if (opcode == kFooter) {
      footer_seen = true;
    } else if (!data_end_seen) {
      try {
        record(opcode, Cursor{reinterpret_cast<const uint8_t*>(content.data()), content.size()}, offset, false,
               on_message, summary);
      } catch (const Cursor::Short& e) {
        fail(offset, std::string("opcode ") + std::to_string(opcode) + ": " + e.what());
      }
    } else if (opcode == kStatistics) {
      Cursor s{reinterpret_cast<const uint8_t*>(content.data()), content.size()};
      try {
        summary.summary_message_count = s.le<uint64_t>("message count");
      } catch (const Cursor::Short& e) {
        fail(offset, std::string("Statistics: ") + e.what());
      }
    }
    if (!data_end_seen) {
      crc = crc32(prefix, kRecordPrefix, crc);
      crc = crc32(content.data(), content.size(), crc);
    }
    offset += kRecordPrefix + length;
  }
  if (summary.complete && summary.summary_message_count != summary.messages) {
    summary.complete = false;
    summary.incomplete_reason = "the summary counts " + std::to_string(summary.summary_message_count) +
                                " messages, the data section holds " + std::to_string(summary.messages);
  }
  return summary;
}

void Reader::record(uint8_t opcode, Cursor content, uint64_t offset, bool in_chunk,
                    const std::function<void(const Message&)>& on_message, ReadSummary& summary) {
  switch (opcode) {
    case kSchema: {
      Schema s;
      s.id = content.le<uint16_t>("schema id");
      s.name = content.str("schema name");
      s.encoding = content.str("schema encoding");
      s.data = content.str("schema data");
      if (s.id == 0) fail(offset, "schema id 0 is reserved");
      schemas_[s.id] = std::move(s);
      return;
    }
    case kChannel: {
      Channel ch;
      ch.id = content.le<uint16_t>("channel id");
      ch.schema_id = content.le<uint16_t>("channel schema id");
      ch.topic = content.str("channel topic");
      ch.message_encoding = content.str("channel message encoding");
      const uint32_t map_bytes = content.le<uint32_t>("channel metadata length");
      Cursor map = content.sub(map_bytes, "channel metadata");
      while (map.n > 0) {
        std::string key = map.str("metadata key");
        ch.metadata[key] = map.str("metadata value");
      }
      if (ch.schema_id != 0 && !schemas_.count(ch.schema_id)) {
        fail(offset, "channel " + std::to_string(ch.id) + " ('" + ch.topic + "') names schema " +
                         std::to_string(ch.schema_id) + ", which no Schema record defined before it");
      }
      channels_[ch.id] = std::move(ch);
      return;
    }
    case kMessage: {
      Message m;
      const uint16_t channel = content.le<uint16_t>("message channel id");
      m.sequence = content.le<uint32_t>("message sequence");
      m.log_time = content.le<uint64_t>("message log time");
      m.publish_time = content.le<uint64_t>("message publish time");
      auto it = channels_.find(channel);
      if (it == channels_.end()) {
        fail(offset, "a message names channel " + std::to_string(channel) + ", which no Channel record defined before it");
      }
      m.channel = &it->second;
      auto schema = schemas_.find(it->second.schema_id);
      m.schema = schema == schemas_.end() ? nullptr : &schema->second;
      m.data = content.p;
      m.size = content.n;
      ++summary.messages;
      on_message(m);
      return;
    }
    case kChunk: {
      if (in_chunk) fail(offset, "a chunk inside a chunk");
      content.le<uint64_t>("chunk start time");
      content.le<uint64_t>("chunk end time");
      const uint64_t uncompressed_size = content.le<uint64_t>("chunk uncompressed size");
      const uint32_t uncompressed_crc = content.le<uint32_t>("chunk CRC");
      const std::string compression = content.str("chunk compression");
      const uint64_t records_size = content.le<uint64_t>("chunk records length");
      Cursor compressed = content.sub(records_size, "chunk records");
      if (uncompressed_size > limits_.max_chunk_bytes) {
        fail(offset, "chunk of " + std::to_string(uncompressed_size) + " bytes uncompressed exceeds the limit of " +
                         std::to_string(limits_.max_chunk_bytes));
      }
      std::string records;
      const std::string error = decompress(compression, compressed.p, compressed.n, records, uncompressed_size);
      if (!error.empty()) fail(offset, "chunk: " + error);
      if (uncompressed_crc != 0 && crc32(records.data(), records.size()) != uncompressed_crc) {
        fail(offset, "chunk: the CRC of its records does not match (corrupt chunk)");
      }
      Cursor inner{reinterpret_cast<const uint8_t*>(records.data()), records.size()};
      while (inner.n > 0) {
        const uint64_t at = records.size() - inner.n;
        try {
          const uint8_t op = inner.le<uint8_t>("record opcode");
          const uint64_t length = inner.le<uint64_t>("record length");
          Cursor body = inner.sub(length, "record");
          if (op != kSchema && op != kChannel && op != kMessage) {
            fail(offset, "chunk holds a record of opcode " + std::to_string(op) + " at offset " + std::to_string(at) +
                             " (a chunk holds only Schema, Channel and Message records)");
          }
          record(op, body, offset, true, on_message, summary);
        } catch (const Cursor::Short& e) {
          fail(offset, "chunk, record at offset " + std::to_string(at) + ": " + e.what());
        }
      }
      ++summary.chunks;
      return;
    }
    default:
      return;  // Header, indexes, attachments, metadata, unknown opcodes: nothing to deliver
  }
}

}  // namespace locd::mcap

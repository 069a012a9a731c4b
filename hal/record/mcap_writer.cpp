#include "hal/record/mcap_writer.hpp"

#include <zlib.h>

#include <algorithm>
#include <cstring>

#ifdef ZONEMAP_HAVE_ZSTD
#include <zstd.h>
#endif

namespace zonemap::record {
namespace {

// Record opcodes (MCAP specification, "Records").
enum Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kStatistics = 0x0B,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};
constexpr std::uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};

// Little-endian serialisation of one record's fields.
class Bytes {
 public:
  explicit Bytes(std::vector<std::uint8_t>* out) : out_(out) {}
  void u8(std::uint8_t v) { out_->push_back(v); }
  void u16(std::uint16_t v) { little(v, 2); }
  void u32(std::uint32_t v) { little(v, 4); }
  void u64(std::uint64_t v) { little(v, 8); }
  void raw(const void* data, std::size_t size) {
    const auto* p = static_cast<const std::uint8_t*>(data);
    out_->insert(out_->end(), p, p + size);
  }
  void string(std::string_view s) {
    u32(static_cast<std::uint32_t>(s.size()));
    raw(s.data(), s.size());
  }
  // Opens a record: opcode and a length patched by end_record().
  std::size_t begin_record(std::uint8_t opcode) {
    u8(opcode);
    const std::size_t at = out_->size();
    u64(0);
    return at;
  }
  void end_record(std::size_t at) { patch_u64(at, out_->size() - at - 8); }
  // A u32 byte-length prefix (maps, arrays) patched by end_u32().
  std::size_t begin_u32() {
    const std::size_t at = out_->size();
    u32(0);
    return at;
  }
  void end_u32(std::size_t at) {
    const std::uint64_t n = out_->size() - at - 4;
    for (int i = 0; i < 4; ++i) (*out_)[at + i] = static_cast<std::uint8_t>(n >> (8 * i));
  }
  void patch_u64(std::size_t at, std::uint64_t v) {
    for (int i = 0; i < 8; ++i) (*out_)[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
  }

 private:
  void little(std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i) out_->push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  std::vector<std::uint8_t>* out_;
};

std::uint32_t crc32_of(std::uint32_t crc, const std::uint8_t* data, std::size_t size) {
  while (size > 0) {
    const auto n = static_cast<uInt>(std::min<std::size_t>(size, 1u << 30));
    crc = static_cast<std::uint32_t>(::crc32(crc, data, n));
    data += n;
    size -= n;
  }
  return crc;
}

void schema_record(Bytes& b, std::uint16_t id, std::string_view name, std::string_view encoding,
                   std::string_view data) {
  const std::size_t r = b.begin_record(kSchema);
  b.u16(id);
  b.string(name);
  b.string(encoding);
  b.string(data);  // bytes: the same u32-length prefix
  b.end_record(r);
}

void channel_record(Bytes& b, std::uint16_t id, std::uint16_t schema_id, std::string_view topic,
                    std::string_view encoding) {
  const std::size_t r = b.begin_record(kChannel);
  b.u16(id);
  b.u16(schema_id);
  b.string(topic);
  b.string(encoding);
  b.u32(0);  // metadata: an empty map
  b.end_record(r);
}

}  // namespace

McapWriter::~McapWriter() {
  if (file_ != nullptr) {
    std::string ignored;
    close(&ignored);
  }
}

bool McapWriter::zstd_available() {
#ifdef ZONEMAP_HAVE_ZSTD
  return true;
#else
  return false;
#endif
}

bool McapWriter::open(const std::string& path, const McapOptions& options, std::string* error) {
  file_ = std::fopen(path.c_str(), "wb");
  if (file_ == nullptr) {
    *error = path + ": cannot create";
    return false;
  }
  path_ = path;
  options_ = options;
  options_.zstd = options.zstd && zstd_available();
  chunk_.reserve(options_.chunk_bytes + (options_.chunk_bytes >> 2));
  std::vector<std::uint8_t> head(std::begin(kMagic), std::end(kMagic));
  Bytes b(&head);
  const std::size_t r = b.begin_record(kHeader);
  b.string("");  // profile: none (our own JSON-schema channels)
  b.string("zonemap");
  b.end_record(r);
  put(head);
  return !io_error_;
}

std::uint16_t McapWriter::add_schema(std::string_view name, std::string_view encoding,
                                     std::string_view data) {
  const auto id = static_cast<std::uint16_t>(schemas_.size() + 1);
  schemas_.push_back({id, std::string(name), std::string(encoding), std::string(data)});
  return id;
}

std::uint16_t McapWriter::add_channel(std::uint16_t schema_id, std::string_view topic,
                                      std::string_view message_encoding) {
  const auto id = static_cast<std::uint16_t>(channels_.size() + 1);
  Channel c;
  c.id = id;
  c.schema_id = schema_id;
  c.topic = std::string(topic);
  c.encoding = std::string(message_encoding);
  channels_.push_back(std::move(c));
  return id;
}

void McapWriter::put(const std::vector<std::uint8_t>& bytes) {
  if (file_ == nullptr || bytes.empty()) return;
  if (std::fwrite(bytes.data(), 1, bytes.size(), file_) != bytes.size()) io_error_ = true;
  data_crc_ = crc32_of(data_crc_, bytes.data(), bytes.size());
  position_ += bytes.size();
}

// Schemas and channels once, in the data section ahead of every chunk (and again
// in the summary), so a reader streaming the file knows them before any message.
void McapWriter::write_header_and_definitions() {
  std::vector<std::uint8_t> out;
  Bytes b(&out);
  for (const Schema& s : schemas_) schema_record(b, s.id, s.name, s.encoding, s.data);
  for (const Channel& c : channels_) channel_record(b, c.id, c.schema_id, c.topic, c.encoding);
  put(out);
  definitions_written_ = true;
}

void McapWriter::write(std::uint16_t channel_id, std::uint64_t log_time_ns,
                       std::uint64_t publish_time_ns, std::string_view data) {
  if (file_ == nullptr || channel_id == 0 || channel_id > channels_.size()) return;
  if (!definitions_written_) write_header_and_definitions();
  Channel& channel = channels_[channel_id - 1];
  if (chunk_.empty()) {
    chunk_start_ns_ = log_time_ns;
    chunk_end_ns_ = log_time_ns;
  }
  chunk_start_ns_ = std::min(chunk_start_ns_, log_time_ns);
  chunk_end_ns_ = std::max(chunk_end_ns_, log_time_ns);
  channel.index.push_back(log_time_ns);
  channel.index.push_back(chunk_.size());
  Bytes b(&chunk_);
  const std::size_t r = b.begin_record(kMessage);
  b.u16(channel_id);
  b.u32(channel.sequence++);
  b.u64(log_time_ns);
  b.u64(publish_time_ns);
  b.raw(data.data(), data.size());
  b.end_record(r);
  if (counts_.messages == 0) message_start_ns_ = message_end_ns_ = log_time_ns;
  message_start_ns_ = std::min(message_start_ns_, log_time_ns);
  message_end_ns_ = std::max(message_end_ns_, log_time_ns);
  ++channel.messages;
  ++counts_.messages;
  if (chunk_.size() >= options_.chunk_bytes) flush_chunk();
}

// Writes the open chunk and one message index per channel that has messages in it.
void McapWriter::flush_chunk() {
  if (chunk_.empty()) return;
  const std::uint32_t crc = crc32_of(0, chunk_.data(), chunk_.size());
  const std::uint8_t* stored = chunk_.data();
  std::size_t stored_size = chunk_.size();
  bool compressed = false;
#ifdef ZONEMAP_HAVE_ZSTD
  if (options_.zstd) {
    compressed_.resize(ZSTD_compressBound(chunk_.size()));
    const std::size_t n = ZSTD_compress(compressed_.data(), compressed_.size(), chunk_.data(),
                                        chunk_.size(), options_.zstd_level);
    // Stored plain when compression fails or does not pay.
    if (!ZSTD_isError(n) && n < chunk_.size()) {
      stored = compressed_.data();
      stored_size = n;
      compressed = true;
    }
  }
#endif
  std::vector<std::uint8_t> out;
  out.reserve(stored_size + 64);
  Bytes b(&out);
  const std::uint64_t chunk_offset = position_;
  const std::size_t r = b.begin_record(kChunk);
  b.u64(chunk_start_ns_);
  b.u64(chunk_end_ns_);
  b.u64(chunk_.size());
  b.u32(crc);
  b.string(compressed ? "zstd" : "");
  b.u64(stored_size);
  b.raw(stored, stored_size);
  b.end_record(r);
  const std::uint64_t chunk_length = out.size();

  ChunkIndex index{chunk_start_ns_, chunk_end_ns_, chunk_offset, chunk_length, 0,
                   stored_size,     chunk_.size(), {},           compressed};
  for (Channel& c : channels_) {
    if (c.index.empty()) continue;
    index.index_offsets.emplace_back(c.id, chunk_offset + out.size());
    const std::size_t m = b.begin_record(kMessageIndex);
    b.u16(c.id);
    const std::size_t array = b.begin_u32();
    for (std::uint64_t v : c.index) b.u64(v);
    b.end_u32(array);
    b.end_record(m);
    c.index.clear();
  }
  index.index_length = out.size() - chunk_length;
  put(out);
  chunk_indexes_.push_back(std::move(index));
  ++counts_.chunks;
  counts_.chunk_bytes_uncompressed += chunk_.size();
  counts_.chunk_bytes_stored += stored_size;
  chunk_.clear();
}

// The summary (schemas, channels, statistics, chunk indexes) and, in `offsets`,
// one summary offset per group of records.
std::vector<std::uint8_t> McapWriter::summary_section(std::uint64_t summary_start,
                                                      std::vector<std::uint8_t>* offsets) {
  std::vector<std::uint8_t> out;
  Bytes b(&out);
  Bytes o(offsets);
  auto group = [&](std::uint8_t opcode, std::size_t begin) {
    if (out.size() == begin) return;
    const std::size_t r = o.begin_record(kSummaryOffset);
    o.u8(opcode);
    o.u64(summary_start + begin);
    o.u64(out.size() - begin);
    o.end_record(r);
  };
  std::size_t begin = out.size();
  for (const Schema& s : schemas_) schema_record(b, s.id, s.name, s.encoding, s.data);
  group(kSchema, begin);
  begin = out.size();
  for (const Channel& c : channels_) channel_record(b, c.id, c.schema_id, c.topic, c.encoding);
  group(kChannel, begin);

  begin = out.size();
  const std::size_t r = b.begin_record(kStatistics);
  b.u64(counts_.messages);
  b.u16(static_cast<std::uint16_t>(schemas_.size()));
  b.u32(static_cast<std::uint32_t>(channels_.size()));
  b.u32(0);  // attachments
  b.u32(0);  // metadata
  b.u32(static_cast<std::uint32_t>(chunk_indexes_.size()));
  b.u64(message_start_ns_);
  b.u64(message_end_ns_);
  const std::size_t counts = b.begin_u32();
  for (const Channel& c : channels_) {
    if (c.messages == 0) continue;
    b.u16(c.id);
    b.u64(c.messages);
  }
  b.end_u32(counts);
  b.end_record(r);
  group(kStatistics, begin);

  begin = out.size();
  for (const ChunkIndex& c : chunk_indexes_) {
    const std::size_t ci = b.begin_record(kChunkIndex);
    b.u64(c.start_ns);
    b.u64(c.end_ns);
    b.u64(c.offset);
    b.u64(c.length);
    const std::size_t map = b.begin_u32();
    for (const auto& [channel, offset] : c.index_offsets) {
      b.u16(channel);
      b.u64(offset);
    }
    b.end_u32(map);
    b.u64(c.index_length);
    b.string(c.compressed ? "zstd" : "");
    b.u64(c.stored);
    b.u64(c.uncompressed);
    b.end_record(ci);
  }
  group(kChunkIndex, begin);
  return out;
}

bool McapWriter::close(std::string* error) {
  if (file_ == nullptr) return true;
  if (!definitions_written_) write_header_and_definitions();
  flush_chunk();
  std::vector<std::uint8_t> end;
  Bytes e(&end);
  const std::size_t r = e.begin_record(kDataEnd);
  e.u32(data_crc_);  // every byte from the leading magic to here
  e.end_record(r);
  put(end);

  const std::uint64_t summary_start = position_;
  std::vector<std::uint8_t> offsets;
  std::vector<std::uint8_t> tail = summary_section(summary_start, &offsets);
  const std::uint64_t summary_offset_start = summary_start + tail.size();
  tail.insert(tail.end(), offsets.begin(), offsets.end());
  Bytes t(&tail);
  t.u8(kFooter);
  t.u64(8 + 8 + 4);
  t.u64(summary_start);
  t.u64(summary_offset_start);
  // Summary CRC: the summary, its offsets and the footer up to this field.
  t.u32(crc32_of(0, tail.data(), tail.size()));
  t.raw(kMagic, sizeof(kMagic));
  put(tail);
  counts_.bytes = position_;
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if (io_error_ || !closed) {
    *error = path_ + ": write failed";
    return false;
  }
  return true;
}

}  // namespace zonemap::record

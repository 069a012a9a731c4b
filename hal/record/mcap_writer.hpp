// An MCAP file writer (https://mcap.dev/spec, major version 0), written from the
// specification: magic, header, schemas and channels up front, messages in
// chunks (zstd-compressed when that is smaller, CRC-checked) each followed by
// its message indexes, data end, then a summary (schemas, channels, statistics,
// chunk indexes) with summary offsets, so a viewer can seek without reading the
// whole file. Used by the flight recorder's own thread only: not real-time (it
// grows its buffers when a chunk outgrows them and writes with stdio).
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

namespace zonemap::record {

struct McapOptions {
  std::size_t chunk_bytes = 1 << 20;  // a chunk is closed once it holds this much
  bool zstd = true;                   // compress chunks (when built with libzstd)
  int zstd_level = 3;
};

struct McapCounts {
  std::uint64_t messages = 0, chunks = 0, bytes = 0;
  std::uint64_t chunk_bytes_uncompressed = 0, chunk_bytes_stored = 0;
};

class McapWriter {
 public:
  McapWriter() = default;
  ~McapWriter();
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  // Creates the file and writes the magic and header. False with a message.
  bool open(const std::string& path, const McapOptions& options, std::string* error);
  // Schemas and channels, before the first message (ids from 1).
  std::uint16_t add_schema(std::string_view name, std::string_view encoding, std::string_view data);
  std::uint16_t add_channel(std::uint16_t schema_id, std::string_view topic,
                            std::string_view message_encoding);
  // One message; times in nanoseconds.
  void write(std::uint16_t channel_id, std::uint64_t log_time_ns, std::uint64_t publish_time_ns,
             std::string_view data);
  // Flushes the last chunk, writes data end, summary and footer. False on an I/O error.
  bool close(std::string* error);
  bool is_open() const { return file_ != nullptr; }
  const McapCounts& counts() const { return counts_; }
  // Whether chunks can be compressed in this build.
  static bool zstd_available();

 private:
  struct Schema {
    std::uint16_t id;
    std::string name, encoding, data;
  };
  struct Channel {
    std::uint16_t id, schema_id;
    std::string topic, encoding;
    std::uint64_t messages = 0;
    std::uint32_t sequence = 0;
    std::vector<std::uint64_t> index;  // this chunk: (log time, offset) pairs, flat
  };
  struct ChunkIndex {
    std::uint64_t start_ns, end_ns, offset, length, index_length, stored, uncompressed;
    std::vector<std::pair<std::uint16_t, std::uint64_t>> index_offsets;
    bool compressed;
  };

  void put(const std::vector<std::uint8_t>& bytes);
  void write_header_and_definitions();
  void flush_chunk();
  std::vector<std::uint8_t> summary_section(std::uint64_t summary_start,
                                            std::vector<std::uint8_t>* offsets);

  std::FILE* file_ = nullptr;
  std::string path_;
  McapOptions options_;
  std::uint64_t position_ = 0;
  std::uint32_t data_crc_ = 0;  // running CRC of the data section
  bool io_error_ = false;
  bool definitions_written_ = false;
  std::vector<Schema> schemas_;
  std::vector<Channel> channels_;
  std::vector<std::uint8_t> chunk_;  // uncompressed records of the open chunk
  std::vector<std::uint8_t> compressed_;
  std::uint64_t chunk_start_ns_ = 0, chunk_end_ns_ = 0;
  std::uint64_t message_start_ns_ = 0, message_end_ns_ = 0;
  std::vector<ChunkIndex> chunk_indexes_;
  McapCounts counts_;
};

}  // namespace zonemap::record

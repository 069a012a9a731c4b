// LCM log files (as lcm-logger writes them) read with bounded memory. Each event:
// sync word 0xEDA1DA01, event number (int64), timestamp in µs (int64), channel
// length (int32), data length (int32), channel, data; big-endian. Written here
// rather than taken from liblcm's eventlog reader, which (Debian's 1.3.1) sizes
// its buffer from the file's data length (a corrupt length of 0x7FFFFFFF
// overflows and crashes the process) and stops at the first damaged event. Here
// a damaged event is counted and the reader finds the next sync word; events
// larger than kMaxData (other channels: images, point clouds) are skipped
// without being read into memory.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <string_view>

namespace zonemap::lcm_link {

struct LcmLogEvent {
  std::int64_t event_number = 0;
  std::int64_t timestamp_us = 0;
  std::string_view channel;
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
};

enum class LcmLogRead : std::uint8_t {
  kEvent,    // *event is valid until the next call
  kSkipped,  // damaged bytes or an oversized event were skipped (counted); call again
  kEnd,      // no more events (a torn last event is counted as damaged)
};

class LcmLogReader {
 public:
  static constexpr std::uint32_t kSync = 0xEDA1DA01u;
  static constexpr std::size_t kHeaderBytes = 28;
  static constexpr std::int32_t kMaxChannel = 255;
  static constexpr std::int32_t kMaxData = 64 * 1024;  // ins_state_t is 100-odd bytes
  static constexpr std::int64_t kMaxSkippable = std::int64_t{1} << 30;  // a sane event size

  LcmLogReader();
  ~LcmLogReader();
  LcmLogReader(const LcmLogReader&) = delete;
  LcmLogReader& operator=(const LcmLogReader&) = delete;

  bool open(const std::string& path, std::string* error);
  // Reads from memory that outlives the reader (tests, fuzzing).
  void open_memory(const std::uint8_t* data, std::size_t size);

  LcmLogRead next(LcmLogEvent* event);

  std::int64_t events() const { return events_; }
  std::int64_t damaged() const { return damaged_; }      // resyncs and torn events
  std::int64_t oversized() const { return oversized_; }  // well-formed, too big, skipped
  std::int64_t bytes_skipped() const { return bytes_skipped_; }

 private:
  // Makes at least `want` bytes available from the read position when the
  // source has them; returns how many are.
  std::size_t ensure(std::size_t want);
  const std::uint8_t* cursor() const { return window_ + position_; }
  void advance(std::size_t bytes) { position_ += bytes; }
  // Skips `bytes` (possibly beyond the buffer); false when the source ends first.
  bool skip(std::int64_t bytes);
  // Moves to the next sync word after the current position's first byte.
  LcmLogRead resync();

  std::FILE* file_ = nullptr;
  std::unique_ptr<std::uint8_t[]> buffer_;  // file mode: the window's storage
  std::size_t capacity_ = 0;
  const std::uint8_t* window_ = nullptr;  // bytes [position_, end_) are unread
  std::size_t position_ = 0;
  std::size_t end_ = 0;
  bool source_done_ = true;  // no more bytes beyond end_
  std::int64_t events_ = 0, damaged_ = 0, oversized_ = 0, bytes_skipped_ = 0;
};

}  // namespace zonemap::lcm_link

#include "hal/lcm/lcm_log_reader.hpp"

#include <cstring>

namespace zonemap::lcm_link {
namespace {

std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}

std::uint64_t be64(const std::uint8_t* p) {
  return (std::uint64_t{be32(p)} << 32) | std::uint64_t{be32(p + 4)};
}

}  // namespace

LcmLogReader::LcmLogReader() = default;

LcmLogReader::~LcmLogReader() {
  if (file_ != nullptr) std::fclose(file_);
}

bool LcmLogReader::open(const std::string& path, std::string* error) {
  if (file_ != nullptr) std::fclose(file_);
  file_ = std::fopen(path.c_str(), "rb");
  if (file_ == nullptr) {
    *error = path + ": cannot open the LCM log";
    return false;
  }
  // Room for the largest event we read plus a header, twice, so that a refill
  // always has space after moving the unread part to the front.
  capacity_ = 2 * (kHeaderBytes + kMaxChannel + kMaxData);
  if (!buffer_) buffer_.reset(new std::uint8_t[capacity_]);
  window_ = buffer_.get();
  position_ = end_ = 0;
  source_done_ = false;
  return true;
}

void LcmLogReader::open_memory(const std::uint8_t* data, std::size_t size) {
  if (file_ != nullptr) std::fclose(file_);
  file_ = nullptr;
  window_ = data;
  position_ = 0;
  end_ = size;
  source_done_ = true;
}

std::size_t LcmLogReader::ensure(std::size_t want) {
  if (end_ - position_ >= want || source_done_) return end_ - position_;
  std::uint8_t* buffer = buffer_.get();
  const std::size_t unread = end_ - position_;
  std::memmove(buffer, buffer + position_, unread);
  position_ = 0;
  end_ = unread;
  while (end_ < want && end_ < capacity_) {
    const std::size_t got = std::fread(buffer + end_, 1, capacity_ - end_, file_);
    if (got == 0) {
      source_done_ = true;
      break;
    }
    end_ += got;
  }
  return end_ - position_;
}

bool LcmLogReader::skip(std::int64_t bytes) {
  const auto in_window = static_cast<std::int64_t>(end_ - position_);
  if (bytes <= in_window) {
    advance(static_cast<std::size_t>(bytes));
    bytes_skipped_ += bytes;
    return true;
  }
  if (file_ == nullptr || source_done_) return false;
  // Past the window: seek the file and start an empty window there.
  if (std::fseek(file_, static_cast<long>(bytes - in_window), SEEK_CUR) != 0) return false;
  position_ = end_ = 0;
  bytes_skipped_ += bytes;
  return true;
}

LcmLogRead LcmLogReader::resync() {
  ++damaged_;
  advance(1);
  ++bytes_skipped_;
  for (;;) {
    const std::size_t available = ensure(4);
    if (available < 4) {
      bytes_skipped_ += static_cast<std::int64_t>(available);
      advance(available);
      return LcmLogRead::kSkipped;  // the next call sees the end
    }
    const std::uint8_t* p = cursor();
    const std::size_t last = available - 3;  // sync candidates at [0, last)
    for (std::size_t i = 0; i < last; ++i) {
      if (be32(p + i) == kSync) {
        advance(i);
        bytes_skipped_ += static_cast<std::int64_t>(i);
        return LcmLogRead::kSkipped;
      }
    }
    advance(last);
    bytes_skipped_ += static_cast<std::int64_t>(last);
  }
}

LcmLogRead LcmLogReader::next(LcmLogEvent* event) {
  const std::size_t available = ensure(kHeaderBytes);
  if (available == 0) return LcmLogRead::kEnd;
  if (available < kHeaderBytes) {  // a torn last header
    ++damaged_;
    bytes_skipped_ += static_cast<std::int64_t>(available);
    advance(available);
    return LcmLogRead::kEnd;
  }
  const std::uint8_t* p = cursor();
  if (be32(p) != kSync) return resync();
  const auto channel_length = static_cast<std::int32_t>(be32(p + 20));
  const auto data_length = static_cast<std::int32_t>(be32(p + 24));
  if (channel_length <= 0 || channel_length > kMaxChannel || data_length < 0 ||
      data_length > kMaxSkippable) {
    return resync();  // not a header: look for the next one
  }
  const std::int64_t total =
      static_cast<std::int64_t>(kHeaderBytes) + channel_length + std::int64_t{data_length};
  if (data_length > kMaxData) {  // well-formed but not for us: skip without reading it
    ++oversized_;
    if (!skip(total)) {
      ++damaged_;
      position_ = end_;
      source_done_ = true;
      return LcmLogRead::kEnd;
    }
    return LcmLogRead::kSkipped;
  }
  const auto event_bytes = static_cast<std::size_t>(total);
  if (ensure(event_bytes) < event_bytes) {  // torn last event
    ++damaged_;
    bytes_skipped_ += static_cast<std::int64_t>(end_ - position_);
    position_ = end_;
    return LcmLogRead::kEnd;
  }
  p = cursor();
  event->event_number = static_cast<std::int64_t>(be64(p + 4));
  event->timestamp_us = static_cast<std::int64_t>(be64(p + 12));
  event->channel = std::string_view(reinterpret_cast<const char*>(p + kHeaderBytes),
                                    static_cast<std::size_t>(channel_length));
  event->data = p + kHeaderBytes + channel_length;
  event->size = static_cast<std::size_t>(data_length);
  advance(event_bytes);
  ++events_;
  return LcmLogRead::kEvent;
}

}  // namespace zonemap::lcm_link

#include "hal/lcm/lcm_log_writer.hpp"

#include <lcm/eventlog.h>

#include <cmath>
#include <cstring>

namespace zonemap::lcm_link {

LcmLogWriter::~LcmLogWriter() {
  close();
}

void LcmLogWriter::close() {
  if (log_ != nullptr) lcm_eventlog_destroy(log_);
  log_ = nullptr;
}

bool LcmLogWriter::open(const std::string& path, std::string* error) {
  log_ = lcm_eventlog_create(path.c_str(), "w");
  if (log_ == nullptr) {
    *error = path + ": cannot write";
    return false;
  }
  return true;
}

bool LcmLogWriter::publish(const char* channel, const void* data, std::size_t size, double now_s) {
  if (log_ == nullptr) return false;
  lcm_eventlog_event_t event{};
  event.timestamp = static_cast<std::int64_t>(std::llround(now_s * 1e6));
  event.channellen = static_cast<std::int32_t>(std::strlen(channel));
  event.datalen = static_cast<std::int32_t>(size);
  event.channel = const_cast<char*>(channel);  // lcm's C API takes a non-const pointer; unchanged
  event.data = const_cast<void*>(data);
  if (lcm_eventlog_write_event(log_, &event) != 0) return false;
  ++events_;
  return true;
}

}  // namespace zonemap::lcm_link

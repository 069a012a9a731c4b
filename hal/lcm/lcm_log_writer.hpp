// LCM messages written to an LCM event log (what `lcm-logger` writes, read by
// `lcm-logplayer` and lcm-spy) instead of a provider, each stamped with the time it
// is given: a replay on a desk shows what the vehicle network would have carried.
// Host only: it writes a file.
#pragma once

#include <cstdint>
#include <string>

#include "hal/lcm/lcm_link.hpp"

typedef struct _lcm_eventlog_t lcm_eventlog_t;

namespace zonemap::lcm_link {

class LcmLogWriter final : public LcmMessageOut {
 public:
  LcmLogWriter() = default;
  ~LcmLogWriter() override;
  LcmLogWriter(const LcmLogWriter&) = delete;
  LcmLogWriter& operator=(const LcmLogWriter&) = delete;
  bool open(const std::string& path, std::string* error);
  bool publish(const char* channel, const void* data, std::size_t size, double now_s) override;
  void close();  // flushes; later messages are refused
  std::int64_t events() const { return events_; }

 private:
  lcm_eventlog_t* log_ = nullptr;
  std::int64_t events_ = 0;
};

}  // namespace zonemap::lcm_link

// MAVLink datagrams written to a telemetry log (.tlog, as QGroundControl and
// MAVProxy write them: each message after its time as big-endian microseconds)
// instead of a socket: a replay on a desk shows what the autopilot would have
// received. Host only: it writes a file.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

#include "hal/mavlink/mavlink_udp_sink.hpp"

namespace zonemap::mavlink {

class TlogWriter final : public DatagramOut {
 public:
  TlogWriter() = default;
  ~TlogWriter() override;
  TlogWriter(const TlogWriter&) = delete;
  TlogWriter& operator=(const TlogWriter&) = delete;
  bool open(const std::string& path, std::string* error);
  bool send(const std::uint8_t* datagram, std::size_t size, double now_s) override;
  void close();  // flushes; later datagrams are refused
  std::int64_t messages() const { return messages_; }

 private:
  std::FILE* file_ = nullptr;
  std::int64_t messages_ = 0;
};

}  // namespace zonemap::mavlink

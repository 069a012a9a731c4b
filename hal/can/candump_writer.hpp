// A CAN output written to a candump log instead of a bus.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

#include "hal/can/socketcan.hpp"

namespace zonemap::can {

// A CAN output written to a candump log instead of a bus (a replay on a desk:
// what the flight controller would have received, for `canplayer` or a DBC
// viewer). Each frame is stamped with the send time it is given. Host only: it
// writes a file.
class CandumpWriter final : public CanTransport {
 public:
  CandumpWriter() = default;
  ~CandumpWriter() override;
  CandumpWriter(const CandumpWriter&) = delete;
  CandumpWriter& operator=(const CandumpWriter&) = delete;
  bool open(const std::string& path, std::string_view interface, std::string* error);
  CanIo send(const CanFrame& frame, double now_s) override;
  void close();  // flushes; later frames are refused
  std::int64_t frames() const { return frames_; }

 private:
  std::FILE* file_ = nullptr;
  std::string interface_;
  std::int64_t frames_ = 0;
};

}  // namespace zonemap::can

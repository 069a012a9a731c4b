// A classic CAN 2.0 frame as the CAN HALs (SocketCAN, candump logs) hand it to
// the decoders, independent of <linux/can.h> so the codecs build and test anywhere.
#pragma once

#include <array>
#include <cstdint>

namespace zonemap::can {

struct CanFrame {
  std::uint32_t id = 0;  // 11-bit (standard) or 29-bit (extended)
  bool extended = false;
  bool remote = false;   // RTR: no data
  bool fd = false;       // CAN FD frame (the profiles here are classic CAN: refused)
  std::uint8_t dlc = 0;  // data bytes (0..8; FD up to 64, not kept beyond 8)
  std::array<std::uint8_t, 8> data{};
  double time_s = 0.0;  // receive time (kernel timestamp or the log's)
};

}  // namespace zonemap::can

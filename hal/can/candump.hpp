// candump log lines (`candump -l`, read by `canplayer`):
//   (1436509052.249713) can0 123#DEADBEEF
// 3 hex digits = standard ID, 8 = extended; `123#R` = remote request; `123##<flags><data>`
// = CAN FD. Lines that do not start with '(' are not frames (skipped).
#pragma once

#include <cstddef>
#include <string_view>

#include "hal/can/can_frame.hpp"

namespace zonemap::can {

enum class CandumpLine { kFrame, kNotAFrame, kMalformed };

// Parses one line (without its newline). Allocation-free. `interface` (optional)
// receives the interface name, pointing into `line`. On kMalformed, *why says what.
CandumpLine parse_candump_line(std::string_view line, CanFrame* frame, std::string_view* interface,
                               const char** why);

// Writes `(sec.usec) iface id#data` into buf (room for 64 bytes is enough for classic
// frames); returns the length, 0 if it did not fit.
std::size_t format_candump_line(const CanFrame& frame, std::string_view interface, char* buf,
                                std::size_t size);

}  // namespace zonemap::can

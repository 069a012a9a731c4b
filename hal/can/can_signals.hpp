// Signals inside a CAN payload, described the way a DBC file does (start bit,
// length, Intel or Motorola byte order, sign, factor, offset). Every message of
// zonemap's CAN profiles is a table of these: the encoder, the decoder and the
// DBC files in config/can/ (checked by a test) share them.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

#include "hal/can/can_frame.hpp"

namespace zonemap::can {

struct SignalSpec {
  std::string_view name;
  int start_bit = 0;          // DBC convention: Intel = least significant bit, Motorola = most
  int length = 0;             // 1..64
  bool little_endian = true;  // Intel (@1) or Motorola (@0)
  bool is_signed = false;
  double factor = 1.0;
  double offset = 0.0;
  std::string_view unit;
};

struct MessageSpec {
  std::string_view name;
  std::uint32_t id = 0;
  bool extended = false;
  std::uint8_t dlc = 8;
  std::span<const SignalSpec> signals;
};

// Raw (unscaled) value, sign-extended when the signal is signed.
std::int64_t get_raw(const CanFrame& frame, const SignalSpec& signal);
// Writes the low `length` bits of raw.
void set_raw(CanFrame* frame, const SignalSpec& signal, std::int64_t raw);

double get_physical(const CanFrame& frame, const SignalSpec& signal);
// Rounds to the nearest raw step and saturates at the signal's range; returns
// false when it had to saturate (the caller counts it).
bool set_physical(CanFrame* frame, const SignalSpec& signal, double value);

const SignalSpec* find_signal(const MessageSpec& message, std::string_view name);

}  // namespace zonemap::can

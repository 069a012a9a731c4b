#include "hal/can/can_signals.hpp"

#include <cmath>

namespace zonemap::can {
namespace {

// Bit b of the payload in DBC numbering: byte b/8, bit b%8 (0 = least significant).
int bit_at(const CanFrame& f, int b) {
  return (f.data[b / 8] >> (b % 8)) & 1;
}
void put_bit(CanFrame* f, int b, int v) {
  const auto mask = static_cast<std::uint8_t>(1u << (b % 8));
  if (v) {
    f->data[b / 8] = static_cast<std::uint8_t>(f->data[b / 8] | mask);
  } else {
    f->data[b / 8] = static_cast<std::uint8_t>(f->data[b / 8] & ~mask);
  }
}

// Motorola order walks from the most significant bit down: within a byte towards
// bit 0, then to bit 7 of the next byte.
int next_motorola(int b) {
  return (b % 8 == 0) ? b + 15 : b - 1;
}

bool in_payload(const SignalSpec& s) {
  return s.length >= 1 && s.length <= 64 && s.start_bit >= 0 && s.start_bit < 64;
}

}  // namespace

std::int64_t get_raw(const CanFrame& frame, const SignalSpec& s) {
  if (!in_payload(s)) return 0;
  std::uint64_t raw = 0;
  if (s.little_endian) {
    for (int i = 0; i < s.length && s.start_bit + i < 64; ++i) {
      raw |= static_cast<std::uint64_t>(bit_at(frame, s.start_bit + i)) << i;
    }
  } else {
    int b = s.start_bit;
    for (int i = 0; i < s.length && b < 64; ++i, b = next_motorola(b)) {
      raw = (raw << 1) | static_cast<std::uint64_t>(bit_at(frame, b));
    }
  }
  if (s.is_signed && s.length < 64 && ((raw >> (s.length - 1)) & 1u)) {
    raw |= ~((std::uint64_t{1} << s.length) - 1);  // sign-extend
  }
  return static_cast<std::int64_t>(raw);
}

void set_raw(CanFrame* frame, const SignalSpec& s, std::int64_t raw_value) {
  if (!in_payload(s)) return;
  const auto raw = static_cast<std::uint64_t>(raw_value);
  if (s.little_endian) {
    for (int i = 0; i < s.length && s.start_bit + i < 64; ++i) {
      put_bit(frame, s.start_bit + i, static_cast<int>((raw >> i) & 1u));
    }
  } else {
    int b = s.start_bit;
    for (int i = s.length - 1; i >= 0 && b < 64; --i, b = next_motorola(b)) {
      put_bit(frame, b, static_cast<int>((raw >> i) & 1u));
    }
  }
}

double get_physical(const CanFrame& frame, const SignalSpec& s) {
  return static_cast<double>(get_raw(frame, s)) * s.factor + s.offset;
}

bool set_physical(CanFrame* frame, const SignalSpec& s, double value) {
  const double steps = std::round((value - s.offset) / s.factor);
  const int bits = s.length >= 63 ? 62 : s.length;  // keep the range exact in a double
  const double lo = s.is_signed ? -std::ldexp(1.0, bits - 1) : 0.0;
  const double hi = s.is_signed ? std::ldexp(1.0, bits - 1) - 1.0 : std::ldexp(1.0, bits) - 1.0;
  bool in_range = std::isfinite(steps) && steps >= lo && steps <= hi;
  const double clamped = std::isfinite(steps) ? std::fmin(std::fmax(steps, lo), hi) : 0.0;
  set_raw(frame, s, static_cast<std::int64_t>(clamped));
  return in_range;
}

const SignalSpec* find_signal(const MessageSpec& message, std::string_view name) {
  for (const SignalSpec& s : message.signals) {
    if (s.name == name) return &s;
  }
  return nullptr;
}

}  // namespace zonemap::can

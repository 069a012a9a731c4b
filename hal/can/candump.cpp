#include "hal/can/candump.hpp"

#include <cmath>
#include <cstdio>

namespace zonemap::can {
namespace {

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

bool is_digit(char c) {
  return c >= '0' && c <= '9';
}

CandumpLine malformed(const char** why, const char* what) {
  if (why != nullptr) *why = what;
  return CandumpLine::kMalformed;
}

}  // namespace

CandumpLine parse_candump_line(std::string_view line, CanFrame* frame, std::string_view* interface,
                               const char** why) {
  while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.remove_suffix(1);
  if (line.empty() || line[0] != '(') return CandumpLine::kNotAFrame;
  std::size_t i = 1;
  // Seconds: digits '.' 6 or 9 digits ')'.
  double seconds = 0.0;
  std::size_t int_digits = 0;
  while (i < line.size() && is_digit(line[i]) && int_digits < 12) {
    seconds = seconds * 10.0 + (line[i++] - '0');
    ++int_digits;
  }
  if (int_digits == 0 || i >= line.size() || line[i] != '.') {
    return malformed(why, "timestamp: expected (seconds.fraction)");
  }
  ++i;
  std::size_t frac_digits = 0;
  double fraction = 0.0, scale = 0.1;
  while (i < line.size() && is_digit(line[i]) && frac_digits < 9) {
    fraction += (line[i++] - '0') * scale;
    scale *= 0.1;
    ++frac_digits;
  }
  if ((frac_digits != 6 && frac_digits != 9) || i >= line.size() || line[i] != ')') {
    return malformed(why, "timestamp: exactly 6 or 9 fractional digits expected");
  }
  ++i;
  if (i >= line.size() || line[i] != ' ') return malformed(why, "expected ' ' after timestamp");
  ++i;
  const std::size_t iface_start = i;
  while (i < line.size() && line[i] != ' ') ++i;
  if (i == iface_start || i - iface_start > 16 || i >= line.size()) {
    return malformed(why, "interface name missing or too long");
  }
  const std::string_view iface = line.substr(iface_start, i - iface_start);
  ++i;
  // ID: 3 or 8 hex digits, then '#'.
  const std::size_t id_start = i;
  std::uint32_t id = 0;
  while (i < line.size() && line[i] != '#') {
    const int v = hex_value(line[i]);
    if (v < 0 || i - id_start >= 8) return malformed(why, "CAN ID: 3 or 8 hex digits expected");
    id = (id << 4) | static_cast<std::uint32_t>(v);
    ++i;
  }
  const std::size_t id_digits = i - id_start;
  if (i >= line.size() || (id_digits != 3 && id_digits != 8)) {
    return malformed(why, "CAN ID: 3 or 8 hex digits then '#' expected");
  }
  CanFrame f;
  f.extended = id_digits == 8;
  if ((!f.extended && id > 0x7FF) || (f.extended && id > 0x1FFFFFFF)) {
    return malformed(why, "CAN ID out of range");
  }
  f.id = id;
  f.time_s = seconds + fraction;
  ++i;  // '#'
  std::size_t max_bytes = 8;
  if (i < line.size() && line[i] == '#') {  // CAN FD: flags nibble, then data
    f.fd = true;
    ++i;
    if (i >= line.size() || hex_value(line[i]) < 0) return malformed(why, "CAN FD flags missing");
    ++i;
    max_bytes = 64;
  } else if (i < line.size() && (line[i] == 'R' || line[i] == 'r')) {
    f.remote = true;
    ++i;
    if (i < line.size() && is_digit(line[i])) f.dlc = static_cast<std::uint8_t>(line[i++] - '0');
    if (i != line.size() || f.dlc > 8) return malformed(why, "remote frame: junk after R");
    *frame = f;
    if (interface != nullptr) *interface = iface;
    return CandumpLine::kFrame;
  }
  std::size_t bytes = 0;
  while (i < line.size()) {
    if (i + 1 >= line.size()) return malformed(why, "data: odd number of hex digits");
    const int hi = hex_value(line[i]), lo = hex_value(line[i + 1]);
    if (hi < 0 || lo < 0) return malformed(why, "data: not hex");
    if (bytes >= max_bytes) return malformed(why, "data: too long");
    if (bytes < 8) f.data[bytes] = static_cast<std::uint8_t>(hi * 16 + lo);
    ++bytes;
    i += 2;
  }
  f.dlc = static_cast<std::uint8_t>(bytes);
  *frame = f;
  if (interface != nullptr) *interface = iface;
  return CandumpLine::kFrame;
}

std::size_t format_candump_line(const CanFrame& frame, std::string_view interface, char* buf,
                                std::size_t size) {
  const double whole = std::floor(frame.time_s);
  long long micros = std::llround((frame.time_s - whole) * 1e6);
  long long secs = static_cast<long long>(whole);
  if (micros >= 1000000) {
    micros -= 1000000;
    ++secs;
  }
  int n = std::snprintf(buf, size,
                        frame.extended ? "(%lld.%06lld) %.*s %08X#" : "(%lld.%06lld) %.*s %03X#",
                        secs, micros, static_cast<int>(interface.size()), interface.data(),
                        static_cast<unsigned>(frame.id));
  if (n < 0 || static_cast<std::size_t>(n) >= size) return 0;
  std::size_t used = static_cast<std::size_t>(n);
  if (frame.remote) {
    if (used + 2 > size) return 0;
    buf[used++] = 'R';
    buf[used] = '\0';
    return used;
  }
  for (std::size_t b = 0; b < frame.dlc && b < 8; ++b) {
    if (used + 3 > size) return 0;
    std::snprintf(buf + used, 3, "%02X", frame.data[b]);
    used += 2;
  }
  return used;
}

}  // namespace zonemap::can

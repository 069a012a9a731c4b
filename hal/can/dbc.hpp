// A reader for the part of the DBC format zonemap's layouts use (BO_ messages and
// their SG_ signals), so tests and tools can check config/can/*.dbc against the
// encoder and decoder tables. Not on the real-time path (allocates).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace zonemap::can {

struct DbcSignal {
  std::string name;
  int start_bit = 0, length = 0;
  bool little_endian = true, is_signed = false;
  double factor = 1.0, offset = 0.0, minimum = 0.0, maximum = 0.0;
  std::string unit;
};

struct DbcMessage {
  std::uint32_t id = 0;  // without the extended-ID flag
  bool extended = false;
  std::string name;
  int dlc = 0;
  std::vector<DbcSignal> signals;
};

// Returns false with "file:line: problem" in *error for a line it cannot read.
bool read_dbc(const std::string& path, std::vector<DbcMessage>* messages, std::string* error);

}  // namespace zonemap::can

#include <ostream>
#include <span>
#include <string_view>

#include "hal/can/can_signals.hpp"

namespace zonemap::can {

// Writes the tables as a DBC file (how config/can/*.dbc were made; the test
// reads them back and compares with the tables).
void write_dbc(std::ostream& out, std::string_view comment, std::string_view sender,
               std::span<const MessageSpec> messages);

}  // namespace zonemap::can

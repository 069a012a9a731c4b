// candump log lines (`candump -l`), each line through the parser, then the
// frames through the SBG decoder as the candump pose source does.
#include <string_view>

#include "hal/can/candump.hpp"
#include "hal/can/ins_can.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace zonemap::can;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  InsCanDecoder decoder(InsCanConfig{});
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    CanFrame frame;
    std::string_view iface;
    const char* why = nullptr;
    if (parse_candump_line(text.substr(start, end - start), &frame, &iface, &why) ==
        CandumpLine::kFrame) {
      zonemap::InsSolution s;
      decoder.feed(frame, &s);
      char line[96];
      format_candump_line(frame, iface.substr(0, 16), line, sizeof line);
    }
    start = end + 1;
  }
  return 0;
}

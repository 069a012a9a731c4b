// CAN frames for each INS profile (SBG ECAN both byte orders, zonemap INS): the
// input is a sequence of frames, 11 bytes each: id selector, flags, dlc, 8 data.
#include "hal/can/ins_can.hpp"

namespace {

void feed_all(zonemap::can::InsCanDecoder& decoder, zonemap::InsGate& gate,
              const std::uint8_t* data, std::size_t size) {
  const auto ids = decoder.ids();
  double t = 0.0;
  for (std::size_t at = 0; at + 11 <= size; at += 11) {
    zonemap::can::CanFrame f;
    f.id = data[at] < 0xF0 ? ids[data[at] % ids.size()] : 0x700u + data[at];
    f.extended = data[at + 1] & 1;
    f.remote = data[at + 1] & 2;
    f.fd = data[at + 1] & 4;
    t += (data[at + 1] >> 3) * 1e-3;  // 0..31 ms between frames
    f.time_s = t;
    f.dlc = data[at + 2] % 9;
    for (int b = 0; b < 8; ++b) f.data[static_cast<std::size_t>(b)] = data[at + 3 + b];
    zonemap::InsSolution s;
    if (decoder.feed(f, &s)) {
      zonemap::InsRejection why{};
      gate.check(s, &why);
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace zonemap::can;
  for (int profile = 0; profile < 3; ++profile) {
    InsCanConfig config;
    config.profile = profile == 2 ? InsCanProfile::kZonemapIns : InsCanProfile::kSbgEcan;
    config.little_endian = profile != 1;
    config.time_source = (size % 2) ? InsTimeSource::kIns : InsTimeSource::kReceive;
    InsCanDecoder decoder(config);
    zonemap::InsGate gate;
    feed_all(decoder, gate, data, size);
  }
  return 0;
}

// Depth PNG decoding (16-bit, the replay format): any bytes, never a crash.
#include <vector>

#include "hal/codec/png_io.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = zonemap::fuzz::write_scratch(data, size, ".png");
  static std::vector<std::uint16_t> depth(64 * 48);
  std::string error;
  zonemap::hal::read_png_gray16(path, 64, 48, depth.data(), &error);
  return 0;
}

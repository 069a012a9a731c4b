// Intensity (left image) PNG decoding, 8-bit.
#include <vector>

#include "hal/codec/png_io.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = zonemap::fuzz::write_scratch(data, size, ".png");
  static std::vector<std::uint8_t> left(64 * 48);
  std::string error;
  zonemap::hal::read_png_gray8(path, 64, 48, left.data(), &error);
  return 0;
}

// PNG files of the replay format (FORMATS.md §1): 16-bit depth and 8-bit
// intensity images, plus 8-bit RGB for output pictures. Host side only: libpng
// allocates while decoding, which is why decoding stays off the mapping path.
#pragma once

#include <cstdint>
#include <string>

namespace zonemap::hal {

// Reads a single-channel PNG of exactly width x height and the given bit depth
// (8 or 16) into `out` (width * height values). On failure returns false and
// says why in `error` (naming the file).
bool read_png_gray16(const std::string& path, int width, int height, std::uint16_t* out,
                     std::string* error);
bool read_png_gray8(const std::string& path, int width, int height, std::uint8_t* out,
                    std::string* error);

bool write_png_gray16(const std::string& path, int width, int height, const std::uint16_t* pixels,
                      std::string* error);
bool write_png_gray8(const std::string& path, int width, int height, const std::uint8_t* pixels,
                     std::string* error);
// pixels: width * height * 3 bytes, RGB.
bool write_png_rgb8(const std::string& path, int width, int height, const std::uint8_t* pixels,
                    std::string* error);

}  // namespace zonemap::hal

// Min/max depth over any image rectangle in O(1), for the projective (fast)
// integration path: a 2-D sparse table of the depth frame (for each level l and
// pixel, the minimum and maximum over the 2^l x 2^l square starting there). A
// rectangle is covered by a few overlapping squares. Raw 16-bit depth values
// keep it small; reserved once for the camera size.
//
// Layout, chosen for the query: each level above 0 stores per pixel the pair
// (min, 0xFFFF - max), so one 32-bit load answers a square and the build is one
// element-wise minimum over plain uint16 arrays (vectorises on SSE2 and NEON).
// Level 0 is the frame's codes themselves.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>

namespace zonemap {

class DepthRangeTable {
 public:
  // Codes in the raw domain. A real depth is 1..kMaxDepthCode.
  static constexpr std::uint16_t kFar = 0xFFFE;      // free up to d_max (sky, > d_max)
  static constexpr std::uint16_t kMissing = 0xFFFF;  // no usable ray
  static constexpr std::uint16_t kMaxDepthCode = 0xFFFD;
  static constexpr int kMaxLevels =
      6;  // squares up to 32 x 32 pixels (larger rectangles: a few more)

  DepthRangeTable(int width, int height);

  // Level 0: one code per pixel. Then build() makes the other levels.
  std::uint16_t* base() { return codes_.get(); }
  const std::uint16_t* codes() const { return codes_.get(); }
  void build();

  // Minimum and maximum code over [x0, x1] x [y0, y1] (inclusive, inside the
  // image), missing pixels left out: lo > hi when every pixel is missing.
  void range(int x0, int y0, int x1, int y1, std::uint16_t* lo, std::uint16_t* hi) const;

  int width() const { return width_; }
  int height() const { return height_; }
  std::size_t reserved_bytes() const { return bytes_; }

 private:
  void square_pass(const std::uint16_t* in, std::uint16_t* out, int half) const;

  int width_;
  int height_;
  int levels_;
  std::unique_ptr<std::uint16_t[]> codes_;
  // pairs_[l]: 2 * width * height values, (min, 0xFFFF - max) per pixel; l >= 1.
  std::array<std::uint16_t*, kMaxLevels> pairs_{};
  std::unique_ptr<std::uint16_t[]> storage_;
  std::size_t bytes_;
};

}  // namespace zonemap

// Eight unsigned 16-bit lanes (depth codes) for the range table and the
// projective path. GCC/Clang vector extensions; the two operations compilers
// cannot find on their own on plain SSE2 (the x86-64 baseline: no unsigned
// 16-bit minimum) use intrinsics there: a - saturating(a - b) is the minimum in
// two instructions instead of five. NEON and SSE4.1 have both natively.
#pragma once

#include <cstdint>
#include <cstring>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__SSE4_1__)
#include <smmintrin.h>
#endif
#if defined(__ARM_NEON)
#include <arm_neon.h>
#endif

namespace zonemap::simd {

using U16x8 = std::uint16_t __attribute__((vector_size(16)));
using I16x8 = std::int16_t __attribute__((vector_size(16)));
using U8x16 = std::uint8_t __attribute__((vector_size(16)));

inline U16x8 load_u16(const std::uint16_t* p) {
  U16x8 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

inline void store_u16(std::uint16_t* p, U16x8 v) {
  std::memcpy(p, &v, sizeof v);
}

inline U16x8 splat_u16(std::uint16_t v) {
  return U16x8{v, v, v, v, v, v, v, v};
}

// max(a - b, 0) per lane.
inline U16x8 saturating_sub(U16x8 a, U16x8 b) {
#if defined(__SSE2__)
  return reinterpret_cast<U16x8>(
      _mm_subs_epu16(reinterpret_cast<__m128i>(a), reinterpret_cast<__m128i>(b)));
#elif defined(__ARM_NEON)
  return reinterpret_cast<U16x8>(
      vqsubq_u16(reinterpret_cast<uint16x8_t>(a), reinterpret_cast<uint16x8_t>(b)));
#else
  return a > b ? a - b : U16x8{};
#endif
}

inline U16x8 min_u16(U16x8 a, U16x8 b) {
#if defined(__SSE4_1__)
  return reinterpret_cast<U16x8>(
      _mm_min_epu16(reinterpret_cast<__m128i>(a), reinterpret_cast<__m128i>(b)));
#elif defined(__ARM_NEON)
  return reinterpret_cast<U16x8>(
      vminq_u16(reinterpret_cast<uint16x8_t>(a), reinterpret_cast<uint16x8_t>(b)));
#else
  return a - saturating_sub(a, b);
#endif
}

inline U16x8 max_u16(U16x8 a, U16x8 b) {
#if defined(__SSE4_1__)
  return reinterpret_cast<U16x8>(
      _mm_max_epu16(reinterpret_cast<__m128i>(a), reinterpret_cast<__m128i>(b)));
#elif defined(__ARM_NEON)
  return reinterpret_cast<U16x8>(
      vmaxq_u16(reinterpret_cast<uint16x8_t>(a), reinterpret_cast<uint16x8_t>(b)));
#else
  return b + saturating_sub(a, b);
#endif
}

// min(a + b, 65535) per lane.
inline U16x8 saturating_add(U16x8 a, U16x8 b) {
#if defined(__SSE2__)
  return reinterpret_cast<U16x8>(
      _mm_adds_epu16(reinterpret_cast<__m128i>(a), reinterpret_cast<__m128i>(b)));
#elif defined(__ARM_NEON)
  return reinterpret_cast<U16x8>(
      vqaddq_u16(reinterpret_cast<uint16x8_t>(a), reinterpret_cast<uint16x8_t>(b)));
#else
  const U16x8 sum = a + b;
  return sum < a ? U16x8{} - 1 : sum;
#endif
}

// Sixteen-bit masks (lanes 0 or all ones) of two vectors as sixteen byte masks,
// a's lanes first (snapshot capture: 16 cells' flags at once).
inline U8x16 narrow_masks(I16x8 a, I16x8 b) {
#if defined(__SSE2__)
  return reinterpret_cast<U8x16>(
      _mm_packs_epi16(reinterpret_cast<__m128i>(a), reinterpret_cast<__m128i>(b)));
#elif defined(__ARM_NEON)
  return reinterpret_cast<U8x16>(vcombine_u8(vmovn_u16(reinterpret_cast<uint16x8_t>(a)),
                                             vmovn_u16(reinterpret_cast<uint16x8_t>(b))));
#else
  return __builtin_shufflevector(reinterpret_cast<U8x16>(a), reinterpret_cast<U8x16>(b), 0, 2, 4, 6,
                                 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
#endif
}

// Sixteen byte masks (0 or 0xFF) as the bits of a word, lane 0 the lowest.
inline std::uint16_t bits_of_masks(U8x16 masks) {
#if defined(__SSE2__)
  return static_cast<std::uint16_t>(_mm_movemask_epi8(reinterpret_cast<__m128i>(masks)));
#else
  // Bytes b_i in {0, 1}: (x * 0x0102040810204080) >> 56 = sum b_i 2^i, eight at a time.
  std::uint64_t halves[2];
  std::memcpy(halves, &masks, sizeof halves);
  const std::uint64_t ones = 0x0101010101010101ull, spread = 0x0102040810204080ull;
  return static_cast<std::uint16_t>((((halves[0] & ones) * spread) >> 56) |
                                    ((((halves[1] & ones) * spread) >> 56) << 8));
#endif
}

// True when any lane is non-zero.
inline bool any_u16(U16x8 v) {
  std::uint64_t halves[2];
  std::memcpy(halves, &v, sizeof halves);
  return (halves[0] | halves[1]) != 0;
}

}  // namespace zonemap::simd

// Footprint quadtrees for the feature map (paper §IV-A, eq. 8): the 2-D ground
// plan s'(x, y) of an object, stored as a region quadtree whose nodes come from a
// pool reserved at start-up (groups of four children, a free list, no heap).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

namespace zonemap {

enum class QuadState : std::uint8_t { kEmpty = 0, kFull = 1, kMixed = 2 };

struct QuadNode {
  QuadState state = QuadState::kEmpty;
  std::uint32_t children = 0;  // group index in the pool when kMixed
};

class QuadtreePool {
 public:
  static constexpr std::uint32_t kNone = UINT32_MAX;
  static constexpr int kMaxSide = 1024;  // footprints up to 1024 x 1024 cells (depth 10)

  // groups: how many groups of four nodes to reserve. max_side: the largest
  // footprint edge that build() will be given (sizes the scratch table).
  QuadtreePool(std::size_t groups, int max_side);

  // Builds the tree of a width x height footprint (row-major, non-zero = occupied)
  // over the square [0, side)², side = smallest power of two >= both. Returns false
  // (and holds nothing) when the pool runs out.
  bool build(const std::uint8_t* footprint, int width, int height, QuadNode* root, int* side);
  // Frees the nodes below root (root itself lives with its owner).
  void release(QuadNode* root);

  bool contains(const QuadNode& root, int side, int x, int y) const;
  // Writes the footprint back (1 = occupied) for width x height.
  void rasterize(const QuadNode& root, int side, int width, int height, std::uint8_t* out) const;
  // Nodes in the tree below and including root.
  std::size_t node_count(const QuadNode& root) const;

  std::size_t groups_free() const { return free_count_; }
  std::size_t groups_total() const { return capacity_; }
  std::size_t reserved_bytes() const;

 private:
  QuadNode build_node(int x0, int y0, int size, bool* exhausted);
  int count(int x0, int y0, int size) const;  // occupied cells in a square, clipped
  std::uint32_t take_group();
  void give_group(std::uint32_t group);
  void fill(const QuadNode& node, int x0, int y0, int size, int width, int height,
            std::uint8_t* out) const;

  std::size_t capacity_;
  std::unique_ptr<QuadNode[]> nodes_;  // capacity_ * 4
  std::unique_ptr<std::uint32_t[]> next_free_;
  std::uint32_t free_head_;
  std::size_t free_count_;
  int max_side_;
  std::unique_ptr<std::int32_t[]> sums_;  // summed-area table of the footprint being built
  int width_ = 0;
  int height_ = 0;
};

}  // namespace zonemap

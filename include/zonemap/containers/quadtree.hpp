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
  // Calls visit(x0, y0, size) for each full square of the tree (cells), depth
  // first, until visit returns false. Allocation-free (depth <= 10).
  template <typename Visit>
  void for_each_full_square(const QuadNode& root, int side, Visit&& visit) const {
    struct Pending {
      const QuadNode* node;
      int x0, y0, size;
    };
    Pending stack[4 * 11];  // three siblings wait per level
    int top = 0;
    stack[top++] = {&root, 0, 0, side};
    while (top > 0) {
      const Pending p = stack[--top];
      if (p.node->state == QuadState::kFull) {
        if (!visit(p.x0, p.y0, p.size)) return;
      } else if (p.node->state == QuadState::kMixed && p.size > 1) {
        const int half = p.size / 2;
        const QuadNode* children = &nodes_[static_cast<std::size_t>(p.node->children) * 4];
        for (int c = 3; c >= 0; --c) {
          stack[top++] = {&children[c], p.x0 + (c % 2) * half, p.y0 + (c / 2) * half, half};
        }
      }
    }
  }
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

#include "zonemap/containers/quadtree.hpp"

#include <algorithm>

namespace zonemap {

QuadtreePool::QuadtreePool(std::size_t groups, int max_side)
    : capacity_(groups),
      nodes_(new QuadNode[groups * 4]()),
      next_free_(new std::uint32_t[groups]()),
      free_head_(groups == 0 ? kNone : 0),
      free_count_(groups),
      max_side_(std::min(max_side, kMaxSide)),
      sums_(new std::int32_t[static_cast<std::size_t>(max_side_ + 1) *
                             static_cast<std::size_t>(max_side_ + 1)]()) {
  for (std::size_t g = 0; g < groups; ++g) {
    next_free_[g] = g + 1 < groups ? static_cast<std::uint32_t>(g + 1) : kNone;
  }
}

std::size_t QuadtreePool::reserved_bytes() const {
  return capacity_ * (4 * sizeof(QuadNode) + sizeof(std::uint32_t)) +
         static_cast<std::size_t>(max_side_ + 1) * static_cast<std::size_t>(max_side_ + 1) *
             sizeof(std::int32_t);
}

std::uint32_t QuadtreePool::take_group() {
  if (free_head_ == kNone) return kNone;
  const std::uint32_t g = free_head_;
  free_head_ = next_free_[g];
  --free_count_;
  return g;
}

void QuadtreePool::give_group(std::uint32_t group) {
  next_free_[group] = free_head_;
  free_head_ = group;
  ++free_count_;
}

int QuadtreePool::count(int x0, int y0, int size) const {
  const int x1 = std::min(x0 + size, width_);
  const int y1 = std::min(y0 + size, height_);
  if (x0 >= x1 || y0 >= y1) return 0;
  const std::size_t stride = static_cast<std::size_t>(width_ + 1);
  auto at = [&](int x, int y) { return sums_[static_cast<std::size_t>(y) * stride + x]; };
  return at(x1, y1) - at(x0, y1) - at(x1, y0) + at(x0, y0);
}

QuadNode QuadtreePool::build_node(int x0, int y0, int size, bool* exhausted) {
  QuadNode node;
  // Cells outside the footprint's width x height count as empty.
  const int inside = std::max(0, std::min(x0 + size, width_) - x0) *
                     std::max(0, std::min(y0 + size, height_) - y0);
  const int occupied = count(x0, y0, size);
  if (occupied == 0) return node;  // kEmpty
  if (occupied == size * size && inside == size * size) {
    node.state = QuadState::kFull;
    return node;
  }
  // size > 1 here: a single cell is either empty or full.
  const std::uint32_t group = take_group();
  if (group == kNone) {
    *exhausted = true;
    return node;
  }
  node.state = QuadState::kMixed;
  node.children = group;
  const int half = size / 2;
  QuadNode* child = &nodes_[static_cast<std::size_t>(group) * 4];
  child[0] = build_node(x0, y0, half, exhausted);
  child[1] = build_node(x0 + half, y0, half, exhausted);
  child[2] = build_node(x0, y0 + half, half, exhausted);
  child[3] = build_node(x0 + half, y0 + half, half, exhausted);
  return node;
}

bool QuadtreePool::build(const std::uint8_t* footprint, int width, int height, QuadNode* root,
                         int* side) {
  *root = QuadNode{};
  *side = 1;
  if (width < 1 || height < 1 || width > max_side_ || height > max_side_) return false;
  while (*side < width || *side < height) *side *= 2;
  width_ = width;
  height_ = height;
  const std::size_t stride = static_cast<std::size_t>(width + 1);
  for (int x = 0; x <= width; ++x) sums_[static_cast<std::size_t>(x)] = 0;
  for (int y = 0; y < height; ++y) {
    std::int32_t row = 0;
    sums_[static_cast<std::size_t>(y + 1) * stride] = 0;
    for (int x = 0; x < width; ++x) {
      row += footprint[static_cast<std::size_t>(y) * width + x] != 0 ? 1 : 0;
      sums_[static_cast<std::size_t>(y + 1) * stride + x + 1] =
          sums_[static_cast<std::size_t>(y) * stride + x + 1] + row;
    }
  }
  bool exhausted = false;
  *root = build_node(0, 0, *side, &exhausted);
  if (exhausted) {
    release(root);
    return false;
  }
  return true;
}

void QuadtreePool::release(QuadNode* root) {
  if (root->state == QuadState::kMixed) {
    QuadNode* child = &nodes_[static_cast<std::size_t>(root->children) * 4];
    for (int i = 0; i < 4; ++i) release(&child[i]);
    give_group(root->children);
  }
  *root = QuadNode{};
}

bool QuadtreePool::contains(const QuadNode& root, int side, int x, int y) const {
  if (x < 0 || y < 0 || x >= side || y >= side) return false;
  const QuadNode* node = &root;
  int x0 = 0, y0 = 0, size = side;
  while (node->state == QuadState::kMixed) {  // at most log2(side) steps
    size /= 2;
    const int right = x >= x0 + size ? 1 : 0;
    const int down = y >= y0 + size ? 1 : 0;
    x0 += right * size;
    y0 += down * size;
    node = &nodes_[static_cast<std::size_t>(node->children) * 4 +
                   static_cast<std::size_t>(right + 2 * down)];
  }
  return node->state == QuadState::kFull;
}

void QuadtreePool::fill(const QuadNode& node, int x0, int y0, int size, int width, int height,
                        std::uint8_t* out) const {
  if (node.state == QuadState::kEmpty) return;
  if (node.state == QuadState::kFull) {
    for (int y = y0; y < std::min(y0 + size, height); ++y)
      for (int x = x0; x < std::min(x0 + size, width); ++x)
        out[static_cast<std::size_t>(y) * width + x] = 1;
    return;
  }
  const int half = size / 2;
  const QuadNode* child = &nodes_[static_cast<std::size_t>(node.children) * 4];
  fill(child[0], x0, y0, half, width, height, out);
  fill(child[1], x0 + half, y0, half, width, height, out);
  fill(child[2], x0, y0 + half, half, width, height, out);
  fill(child[3], x0 + half, y0 + half, half, width, height, out);
}

void QuadtreePool::rasterize(const QuadNode& root, int side, int width, int height,
                             std::uint8_t* out) const {
  std::fill_n(out, static_cast<std::size_t>(width) * height, std::uint8_t{0});
  fill(root, 0, 0, side, width, height, out);
}

std::size_t QuadtreePool::node_count(const QuadNode& root) const {
  if (root.state != QuadState::kMixed) return 1;
  std::size_t n = 1;
  const QuadNode* child = &nodes_[static_cast<std::size_t>(root.children) * 4];
  for (int i = 0; i < 4; ++i) n += node_count(child[i]);
  return n;
}

}  // namespace zonemap

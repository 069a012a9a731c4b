#include "hal/os/allocation_counter.hpp"

#include <cstddef>
#include <cstdlib>
#include <new>

namespace zonemap::os {
namespace {
thread_local bool t_armed = false;
thread_local std::int64_t t_allocations = 0;
thread_local std::int64_t t_frees = 0;
}  // namespace

bool arm_allocation_counting(bool armed) {
  const bool previous = t_armed;
  t_armed = armed;
  return previous;
}
AllocationCounts thread_allocation_counts() {
  return {t_allocations, t_frees};
}

namespace {
void* allocate(std::size_t size, std::size_t alignment) {
  if (t_armed) ++t_allocations;
  if (size == 0) size = 1;
  void* p = nullptr;
  if (alignment <= alignof(std::max_align_t)) {
    p = std::malloc(size);
  } else {
    p = std::aligned_alloc(alignment, (size + alignment - 1) / alignment * alignment);
  }
  return p;
}
void release(void* p) {
  if (p == nullptr) return;
  if (t_armed) ++t_frees;
  std::free(p);
}
}  // namespace
}  // namespace zonemap::os

using zonemap::os::allocate;
using zonemap::os::release;

void* operator new(std::size_t size) {
  void* p = allocate(size, alignof(std::max_align_t));
  if (p == nullptr) throw std::bad_alloc();
  return p;
}
void* operator new[](std::size_t size) {
  return operator new(size);
}
void* operator new(std::size_t size, std::align_val_t al) {
  void* p = allocate(size, static_cast<std::size_t>(al));
  if (p == nullptr) throw std::bad_alloc();
  return p;
}
void* operator new[](std::size_t size, std::align_val_t al) {
  return operator new(size, al);
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  return allocate(size, alignof(std::max_align_t));
}
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept {
  return allocate(size, alignof(std::max_align_t));
}
void* operator new(std::size_t size, std::align_val_t al, const std::nothrow_t&) noexcept {
  return allocate(size, static_cast<std::size_t>(al));
}
void* operator new[](std::size_t size, std::align_val_t al, const std::nothrow_t&) noexcept {
  return allocate(size, static_cast<std::size_t>(al));
}
void operator delete(void* p) noexcept {
  release(p);
}
void operator delete[](void* p) noexcept {
  release(p);
}
void operator delete(void* p, std::size_t) noexcept {
  release(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  release(p);
}
void operator delete(void* p, std::align_val_t) noexcept {
  release(p);
}
void operator delete[](void* p, std::align_val_t) noexcept {
  release(p);
}
void operator delete(void* p, std::size_t, std::align_val_t) noexcept {
  release(p);
}
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept {
  release(p);
}
void operator delete(void* p, const std::nothrow_t&) noexcept {
  release(p);
}
void operator delete[](void* p, const std::nothrow_t&) noexcept {
  release(p);
}

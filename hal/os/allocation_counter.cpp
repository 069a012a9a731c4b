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
// Where the C heap itself is replaced (below), malloc counts every allocation,
// operator new included; under a sanitizer (which owns malloc) operator new counts.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kCountInNew = true;
#else
constexpr bool kCountInNew = false;
#endif

void* allocate(std::size_t size, std::size_t alignment) {
  if (kCountInNew && t_armed) ++t_allocations;
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
  if (kCountInNew && t_armed) ++t_frees;
  std::free(p);
}
}  // namespace

void count_c_allocation() {
  if (t_armed) ++t_allocations;
}
void count_c_free() {
  if (t_armed) ++t_frees;
}
}  // namespace zonemap::os

#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
// The C heap, counted per thread too (libraries that call malloc directly): glibc
// keeps its allocator reachable as __libc_*, so these forward to it.
extern "C" {
void* __libc_malloc(std::size_t);
void __libc_free(void*);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);

void* malloc(std::size_t size) {
  zonemap::os::count_c_allocation();
  return __libc_malloc(size);
}
void free(void* p) {
  if (p != nullptr) zonemap::os::count_c_free();
  __libc_free(p);
}
void* calloc(std::size_t n, std::size_t size) {
  zonemap::os::count_c_allocation();
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t size) {
  zonemap::os::count_c_allocation();
  if (p != nullptr) zonemap::os::count_c_free();
  return __libc_realloc(p, size);
}
void* aligned_alloc(std::size_t alignment, std::size_t size) {
  zonemap::os::count_c_allocation();
  return __libc_memalign(alignment, size);
}
void* memalign(std::size_t alignment, std::size_t size) {
  zonemap::os::count_c_allocation();
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t size) {
  zonemap::os::count_c_allocation();
  void* p = __libc_memalign(alignment, size);
  if (p == nullptr) return 12;  // ENOMEM
  *out = p;
  return 0;
}
}
#endif

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

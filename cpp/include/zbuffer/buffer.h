// Large arrays that a build fills once: vectors whose growth does not zero
// what is about to be written, and a hint to back them with huge pages.
#pragma once

#include <cstddef>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

namespace zbuffer {

// std::allocator, except that value-initialisation (resize(n)) becomes
// default-initialisation: for the plain numbers stored in Buffers, no write
// at all. With kAlign, blocks start on a kAlign-byte boundary (LineBuffer).
template <class T, size_t kAlign = 0>
struct DefaultInitAllocator : std::allocator<T> {
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U, kAlign>;
  };
  DefaultInitAllocator() noexcept = default;
  template <class U>
  DefaultInitAllocator(const DefaultInitAllocator<U, kAlign>&) noexcept {}
  T* allocate(size_t n) {
    if constexpr (kAlign != 0)
      return static_cast<T*>(::operator new(n * sizeof(T), std::align_val_t(kAlign)));
    else
      return std::allocator<T>::allocate(n);
  }
  void deallocate(T* p, size_t n) noexcept {
    if constexpr (kAlign != 0)
      ::operator delete(p, std::align_val_t(kAlign));
    else
      std::allocator<T>::deallocate(p, n);
  }
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible<U>::value) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

// Design decision: a build writes each element of its output exactly once,
// at places it computes itself, so it grows the array by resize() and then
// writes through a pointer. Good: no push_back capacity check per element
// and no zeroing pass before the real write (a Scene of 11.7 million
// triangles writes ~500 MB). Bad: elements between resize() and their write
// are indeterminate; every writer must fill what it resizes (or shrink back).
template <class T>
using Buffer = std::vector<T, DefaultInitAllocator<T>>;
// A Buffer that starts on a cache line (for arrays of records a line long).
template <class T>
using LineBuffer = std::vector<T, DefaultInitAllocator<T, 64>>;

// Asks the kernel to back the whole 2 MiB pages of [p, p + bytes) with
// transparent huge pages (Linux; elsewhere, or if refused, nothing happens).
// For large arrays written once right after allocation: their first touch
// then costs one page fault per 2 MiB instead of one per 4 KiB. Used for a
// tree's own arrays (a Scene of 11.7 million triangles: 990 -> 790 ms);
// not for the builders' scratch, which is kept from build to build (a first
// build with it advised too was no faster, often slower).
void advise_huge_pages(const void* p, size_t bytes);

template <class T, class A>
void reserve_huge(std::vector<T, A>& v, size_t n) {
  v.reserve(n);
  advise_huge_pages(v.data(), v.capacity() * sizeof(T));
}

}  // namespace zbuffer

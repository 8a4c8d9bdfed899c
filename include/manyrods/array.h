// include/manyrods/array.h — 64-byte aligned host arrays with guard entries.
//
// Array<T> holds `size` entries plus kGuard entries on each side, so a kernel
// at any index k in [0, size) may read k−1 and k+1 without a branch. data()
// points at entry 0 and is 64-byte aligned.
//
// The components of a vector or frame field (std::array<Array<T>, N>) are
// allocated as one block by resize_components: component i starts
// component_stride(size) entries after component i−1, so the field is one
// strided [N][size] array (the Python module's zero-copy NumPy views).
// Copying into an array of the same size copies in place: pointers into it
// (kernel views, NumPy views) stay valid.
#pragma once

#include <array>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>

namespace manyrods {

inline constexpr int kGuard = 64;  // entries; also the kernel block length

template <class T>
class Array {
 public:
  Array() = default;
  Array(std::size_t size, T fill) { resize(size, fill); }
  Array(const Array& o) { *this = o; }
  Array& operator=(const Array& o) {
    if (this != &o) {
      if (!raw_ || size_ != o.size_) allocate(o.size_);
      if (size_ + 2 * kGuard > 0 && o.raw_)
        std::memcpy(raw_.get(), o.raw_.get(), (size_ + 2 * kGuard) * sizeof(T));
    }
    return *this;
  }
  Array(Array&&) noexcept = default;
  Array& operator=(Array&&) noexcept = default;

  void resize(std::size_t size, T fill) {
    allocate(size);
    for (std::size_t i = 0; i < size + 2 * kGuard; ++i) raw_.get()[i] = fill;
  }
  std::size_t size() const { return size_; }
  // (null for an array never allocated: an offset from null is undefined)
  T* data() { return raw_ ? raw_.get() + kGuard : nullptr; }
  const T* data() const { return raw_ ? raw_.get() + kGuard : nullptr; }
  T& operator[](std::ptrdiff_t k) { return data()[k]; }
  const T& operator[](std::ptrdiff_t k) const { return data()[k]; }
  std::size_t bytes() const { return (size_ + 2 * kGuard) * sizeof(T); }

  // Entries from one component's entry 0 to the next one's in a block of
  // resize_components (a multiple of 64 bytes).
  static std::size_t component_stride(std::size_t size) {
    return ((size + 2 * kGuard) * sizeof(T) + 63) / 64 * 64 / sizeof(T);
  }
  // The N components of a field in one block, component i filled with fill(i).
  template <std::size_t N, class Fill>
  static void resize_components(std::array<Array, N>& a, std::size_t size, Fill fill) {
    const std::size_t stride = component_stride(size);
    T* p = static_cast<T*>(std::aligned_alloc(64, N * stride * sizeof(T)));
    if (!p) throw std::bad_alloc();
    std::shared_ptr<T> block(p, Free{});
    for (std::size_t i = 0; i < N; ++i) {
      a[i].size_ = size;
      a[i].raw_ = std::shared_ptr<T>(block, p + i * stride);  // shares the block's ownership
      const T v = fill(static_cast<int>(i));
      for (std::size_t k = 0; k < size + 2 * kGuard; ++k) a[i].raw_.get()[k] = v;
    }
  }

 private:
  struct Free {
    void operator()(T* p) const { std::free(p); }
  };
  void allocate(std::size_t size) {
    size_ = size;
    const std::size_t bytes = ((size + 2 * kGuard) * sizeof(T) + 63) / 64 * 64;
    T* p = static_cast<T*>(std::aligned_alloc(64, bytes));
    if (!p) throw std::bad_alloc();
    raw_ = std::shared_ptr<T>(p, Free{});
  }
  std::shared_ptr<T> raw_;  // into its own allocation or a block of components
  std::size_t size_ = 0;
};

}  // namespace manyrods

// include/manyrods/array.h — 64-byte aligned host arrays with guard entries.
//
// Array<T> holds `size` entries plus kGuard entries on each side, so a kernel
// at any index k in [0, size) may read k−1 and k+1 without a branch. data()
// points at entry 0 and is 64-byte aligned.
#pragma once

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
      allocate(o.size_);
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

 private:
  struct Free {
    void operator()(T* p) const { std::free(p); }
  };
  void allocate(std::size_t size) {
    size_ = size;
    const std::size_t bytes = ((size + 2 * kGuard) * sizeof(T) + 63) / 64 * 64;
    T* p = static_cast<T*>(std::aligned_alloc(64, bytes));
    if (!p) throw std::bad_alloc();
    raw_.reset(p);
  }
  std::unique_ptr<T, Free> raw_;
  std::size_t size_ = 0;
};

}  // namespace manyrods

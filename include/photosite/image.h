// Typed images: an owning, interleaved, row-major buffer with its size, channel count and the
// physical unit of its samples. Stages take and return these; the unit string travels into the
// EXR header so every layer on disk says what it holds.
#pragma once
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <type_traits>
#include <string>
#include <utility>
#include <vector>

#include "photosite/frame_buffers.h"

namespace photosite {

// An allocator whose value-initialisation is default-initialisation: a buffer that a stage is
// about to overwrite in full is not first zero-filled (a 2048x1024 RGB float image is 25 MB:
// the memset alone costs about as much as a simple per-pixel stage).
// Buffers of a megabyte and more go through the frame-buffer cache (frame_buffers.h), which a
// program running frame after frame can turn on so that freed frames are reused, not faulted in
// again; with the cache off (the default) they come from and go to ::operator new and delete.
template <class T>
struct DefaultInitAllocator : std::allocator<T> {
  static_assert(alignof(T) <= __STDCPP_DEFAULT_NEW_ALIGNMENT__, "over-aligned samples need an aligned allocation");
  template <class U>
  struct rebind { using other = DefaultInitAllocator<U>; };
  using std::allocator<T>::allocator;
  T* allocate(size_t n) {
    if (n > static_cast<size_t>(-1) / sizeof(T)) throw std::bad_array_new_length();
    return static_cast<T*>(detail::frame_buffer_allocate(n * sizeof(T)));
  }
  void deallocate(T* p, size_t n) noexcept { detail::frame_buffer_release(p, n * sizeof(T)); }
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) { ::new (static_cast<void*>(p)) U; }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) { ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...); }
};

// Tag for an image whose samples are left unset, for stages that write every sample.
struct Uninitialized {};
inline constexpr Uninitialized uninitialized{};

template <class T>
class Image {
 public:
  using Buffer = std::vector<T, DefaultInitAllocator<T>>;
  Image() = default;
  Image(int width, int height, int channels = 1, T fill = T{}, std::string unit = {})
      : width_(width), height_(height), channels_(channels),
        data_(static_cast<size_t>(width) * height * channels, fill), unit_(std::move(unit)) {
    assert(width >= 0 && height >= 0 && channels >= 1);
  }
  // Samples left unset: the caller writes every one of them before reading any.
  Image(int width, int height, int channels, Uninitialized, std::string unit = {})
      : width_(width), height_(height), channels_(channels),
        data_(static_cast<size_t>(width) * height * channels), unit_(std::move(unit)) {
    assert(width >= 0 && height >= 0 && channels >= 1);
  }

  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return channels_; }
  size_t pixel_count() const { return static_cast<size_t>(width_) * height_; }
  size_t size() const { return data_.size(); }
  bool empty() const { return data_.empty(); }
  bool same_shape(int w, int h) const { return w == width_ && h == height_; }
  template <class U>
  bool same_shape(const Image<U>& o) const { return o.width() == width_ && o.height() == height_; }

  T* data() { return data_.data(); }
  const T* data() const { return data_.data(); }
  T* row(int y) { return data_.data() + static_cast<size_t>(y) * width_ * channels_; }
  const T* row(int y) const { return data_.data() + static_cast<size_t>(y) * width_ * channels_; }
  T& at(int x, int y, int c = 0) {
    assert(x >= 0 && x < width_ && y >= 0 && y < height_ && c >= 0 && c < channels_);
    return data_[(static_cast<size_t>(y) * width_ + x) * channels_ + c];
  }
  const T& at(int x, int y, int c = 0) const {
    assert(x >= 0 && x < width_ && y >= 0 && y < height_ && c >= 0 && c < channels_);
    return data_[(static_cast<size_t>(y) * width_ + x) * channels_ + c];
  }
  T& operator[](size_t i) { return data_[i]; }
  const T& operator[](size_t i) const { return data_[i]; }
  Buffer& vec() { return data_; }
  const Buffer& vec() const { return data_; }

  // The physical unit of the samples, e.g. "W.sr-1.m-2", "e-", "DN", "1" (dimensionless).
  const std::string& unit() const { return unit_; }
  void set_unit(std::string u) { unit_ = std::move(u); }

 private:
  int width_ = 0, height_ = 0, channels_ = 1;
  Buffer data_;
  std::string unit_;
};

using ImageF = Image<float>;
using ImageU8 = Image<uint8_t>;
using ImageU16 = Image<uint16_t>;
using ImageI32 = Image<int32_t>;

// Unit strings used across photosite (UCUM-like, ASCII so they survive every EXR reader).
namespace unit {
inline constexpr const char* radiance = "W.sr-1.m-2";
inline constexpr const char* irradiance = "W.m-2";
inline constexpr const char* electrons = "e-";
inline constexpr const char* dn = "DN";
inline constexpr const char* dimensionless = "1";
inline constexpr const char* label_id = "label id";
}  // namespace unit

}  // namespace photosite

// Flat little-endian byte layouts: what the core keeps of a run in files of its own (the seed
// archive, rv/edit/seed_archive.hpp; the line pieces, rv/lines/strip_lines.hpp's LinePieces). Values are
// appended as their bytes, doubles bit for bit; a reader checks every read and every count
// against the bytes left before anything is allocated, so damaged bytes fail with a message
// naming what was read instead of a huge allocation.
// Internal to rv_raster. Thread safety: one object per encoding or decoding.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <utility>

#include "rv/field/error.hpp"
#include "rv/field/seeds.hpp"

namespace rv::detail {

static_assert(std::endian::native == std::endian::little, "the layouts are written in the machine's order");

class ByteWriter {
 public:
  template <class T>
  void put(T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    s_.append(b, sizeof(T));
  }
  void text(const std::string& t) {
    put<uint64_t>(t.size());
    s_ += t;
  }
  void vec(Vec2 v) {
    put(v.x);
    put(v.y);
  }
  std::string take() { return std::move(s_); }

 private:
  std::string s_;
};

class ByteReader {
 public:
  // `what` names the bytes in errors ("seed archive").
  ByteReader(std::string_view b, std::string what) : b_(b), what_(std::move(what)) {}
  template <class T>
  T get() {
    need(sizeof(T));
    T v;
    std::memcpy(&v, b_.data(), sizeof(T));
    b_.remove_prefix(sizeof(T));
    return v;
  }
  // A count of items of at least `min_bytes` each: no more than the bytes left can hold.
  uint64_t count(uint64_t min_bytes) {
    const auto n = get<uint64_t>();
    if (n > b_.size() / min_bytes) fail();
    return n;
  }
  std::string text() {
    const uint64_t n = count(1);
    std::string t(b_.substr(0, n));
    b_.remove_prefix(n);
    return t;
  }
  Vec2 vec() {
    const auto x = get<double>();
    return Vec2{x, get<double>()};
  }
  void need(size_t n) const {
    if (b_.size() < n) fail();
  }
  bool done() const { return b_.empty(); }
  [[noreturn]] void fail() const { throw Error(ErrorKind::invalid_input, what_ + ": truncated or damaged"); }

 private:
  std::string_view b_;
  std::string what_;
};

}  // namespace rv::detail

// Checks an encoded LCM message against its type before the lcm-gen decoder
// sees it. The generated decoders trust the bytes: a string length of 0 makes
// them throw std::length_error, a negative array count throws from resize(),
// and a huge count allocates (count x element size) before noticing the
// buffer is short. The walk here reads only lengths and counts and proves
// every string length is >= 1 and inside the buffer and every array's
// elements fit in the bytes left, so the decoder that runs afterwards can
// neither throw nor allocate more than a small multiple of the message size.
// Strings must also be text with one terminating NUL, as the encoder writes
// them, so whatever passes re-encodes to the same bytes.
//
// The per-type walks (runtime/wire_check_gen.hpp) are generated from
// lcmtypes/*.lcm by gen_wire_check.py; only the primitives are written here.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <exception>
#include <limits>
#include <string>

namespace harvest::rt {

class WireReader {
 public:
  WireReader(const void* data, std::size_t size) : p_(static_cast<const uint8_t*>(data)), size_(size) {}

  std::size_t remaining() const { return size_ - pos_; }
  std::size_t position() const { return pos_; }
  // "header.frame_id: string length 0 (...)"
  std::string error() const { return path_.empty() ? error_ : path_ + ": " + error_; }

  // n bytes of fixed-size data.
  bool skip(std::size_t n) {
    if (n > remaining()) return fail("needs " + std::to_string(n) + " bytes, " + std::to_string(remaining()) + " left");
    pos_ += n;
    return true;
  }

  // A big-endian signed integer of `bytes` bytes (an array count, the fingerprint).
  bool integer(std::size_t bytes, int64_t& value) {
    if (bytes > remaining())
      return fail("needs " + std::to_string(bytes) + " bytes, " + std::to_string(remaining()) + " left");
    uint64_t v = 0;
    for (std::size_t i = 0; i < bytes; ++i) v = (v << 8) | p_[pos_ + i];
    // Sign-extend from the field's width.
    const unsigned shift = static_cast<unsigned>(64 - 8 * bytes);
    value = static_cast<int64_t>(v << shift) >> shift;
    pos_ += bytes;
    return true;
  }

  // An LCM string: int32 length counting the terminating NUL, then the bytes.
  bool string() {
    int64_t len = 0;
    if (!integer(4, len)) return false;
    if (len < 1) return fail("string length " + std::to_string(len) + " (must be >= 1, it counts the NUL)");
    if (static_cast<uint64_t>(len) > remaining())
      return fail("string length " + std::to_string(len) + ", " + std::to_string(remaining()) + " bytes left");
    // The decoder drops the last byte and keeps any NUL before it, the
    // encoder writes up to the first NUL: anything but text + one final NUL
    // would not re-encode to the same bytes (found by lcm_decode_fuzz).
    const auto n = static_cast<std::size_t>(len);
    if (p_[pos_ + n - 1] != 0) return fail("string of " + std::to_string(len) + " bytes does not end with a NUL");
    if (std::memchr(p_ + pos_, 0, n - 1) != nullptr)
      return fail("string of " + std::to_string(len) + " bytes has a NUL inside");
    pos_ += n;
    return true;
  }

  // The element count of an array from its dimensions (each an earlier count
  // field or a constant). Every dimension must be >= 0 and, because the
  // decoder allocates the outer vectors before the elements, at most the
  // bytes left; all elements must fit in the bytes left at min_element_size
  // (> 0, the fewest bytes one element can take).
  template <std::size_t N>
  bool elements(const int64_t (&dims)[N], std::size_t min_element_size, int64_t& total) {
    total = 1;
    for (int64_t d : dims) {
      if (d < 0) return fail("array count " + std::to_string(d) + " (negative)");
      if (static_cast<uint64_t>(d) > remaining())
        return fail("array count " + std::to_string(d) + ", only " + std::to_string(remaining()) + " bytes left");
      total *= d;  // each factor <= remaining() <= INT_MAX, checked below before the next can overflow
      if (static_cast<uint64_t>(total) > remaining() / min_element_size)
        return fail("array of " + std::to_string(total) + " elements of >= " + std::to_string(min_element_size) +
                    " bytes, only " + std::to_string(remaining()) + " bytes left");
    }
    return true;
  }

  bool fail(std::string what) {
    error_ = std::move(what);
    return false;
  }

  // Prefix the failing field to the error's path (called on the way out, so
  // the innermost field comes first).
  bool in(const char* field) {
    path_ = std::string(field) + (path_.empty() || path_[0] == '[' ? "" : ".") + path_;
    return false;
  }
  bool in(const char* field, int64_t index) {
    path_ = std::string(field) + "[" + std::to_string(index) + "]" + (path_.empty() ? "" : ".") + path_;
    return false;
  }

 private:
  const uint8_t* p_;
  std::size_t size_;
  std::size_t pos_ = 0;
  std::string error_;
  std::string path_;
};

// Specialised for every harvest type in runtime/wire_check_gen.hpp.
template <class T>
struct WireType;

}  // namespace harvest::rt

#include "runtime/wire_check_gen.hpp"

namespace harvest::rt {

// Why `size` bytes are not a well-formed encoded T, or empty if they are.
template <class T>
std::string wire_check(const void* data, std::size_t size) {
  if (size > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    return std::to_string(size) + " bytes, more than an LCM message can hold";
  WireReader w(data, size);
  int64_t hash = 0;
  if (!w.integer(8, hash)) return "shorter than a fingerprint (" + std::to_string(size) + " bytes)";
  if (hash != T::getHash()) return "fingerprint is not " + std::string(T::getTypeName());
  if (!WireType<T>::walk(w)) return w.error();
  return {};
}

// The one way harvest code decodes received bytes: checked first, then the
// lcm-gen decoder, which by then cannot fail; a throw from it all the same
// (a gap in the check) is turned into an error, not passed up.
template <class T>
std::string decode_checked(const void* data, std::size_t size, T& out) {
  std::string why = wire_check<T>(data, size);
  if (!why.empty()) return why;
  try {
    if (out.decode(data, 0, static_cast<int>(size)) < 0) return "decoder refused the bytes";
  } catch (const std::exception& e) {
    return std::string("decoder threw: ") + e.what();
  }
  return {};
}

}  // namespace harvest::rt

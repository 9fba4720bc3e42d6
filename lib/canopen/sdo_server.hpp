// Device side of SDO: an object dictionary and an SDO server answering
// expedited and segmented transfers. Used by the simulated drives
// (lib/simdrive) and by the SDO client's tests.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "canopen/protocol.hpp"

namespace harvest::canopen {

class ObjectDictionary {
 public:
  // Validates a write; returns 0 to accept or an SDO abort code.
  using Validator = std::function<uint32_t(const std::vector<uint8_t>&)>;
  struct Entry {
    std::vector<uint8_t> value;
    bool writable = false;
    bool fixed_size = true;  // writes must have the current size (strings/domains: false)
    Validator validate;
  };

  void add(uint16_t index, uint8_t sub, std::vector<uint8_t> value, bool writable, Validator validate = {});
  void add_u8(uint16_t index, uint8_t sub, uint8_t v, bool writable, Validator validate = {});
  void add_u16(uint16_t index, uint8_t sub, uint16_t v, bool writable, Validator validate = {});
  void add_u32(uint16_t index, uint8_t sub, uint32_t v, bool writable, Validator validate = {});
  void add_string(uint16_t index, uint8_t sub, const std::string& s, bool writable);

  // 0 on success, else an SDO abort code.
  uint32_t write(uint16_t index, uint8_t sub, const std::vector<uint8_t>& value);
  uint32_t read(uint16_t index, uint8_t sub, std::vector<uint8_t>& out) const;
  // Local (device-side) access, no checks; 0 for a missing entry.
  uint32_t get(uint16_t index, uint8_t sub) const;
  void set(uint16_t index, uint8_t sub, uint32_t value);
  bool has(uint16_t index, uint8_t sub) const;

 private:
  static uint32_t key(uint16_t index, uint8_t sub) { return (static_cast<uint32_t>(index) << 8) | sub; }
  std::map<uint32_t, Entry> entries_;
};

class SdoServer {
 public:
  SdoServer(uint8_t node, ObjectDictionary& od, std::function<void(const CanFrame&)> send);
  // Returns true if the frame was an SDO request to this node.
  bool on_frame(const CanFrame& frame);

 private:
  void abort(uint32_t code);
  uint8_t node_;
  ObjectDictionary& od_;
  std::function<void(const CanFrame&)> send_;
  enum class Mode { kIdle, kDownload, kUpload } mode_ = Mode::kIdle;
  uint16_t index_ = 0;
  uint8_t sub_ = 0;
  bool toggle_ = false;
  std::vector<uint8_t> buffer_;
  std::size_t offset_ = 0;
  std::size_t expected_ = 0;
};

}  // namespace harvest::canopen

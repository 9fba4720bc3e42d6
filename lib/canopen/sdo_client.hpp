// SDO client: reads and writes object-dictionary entries of other nodes,
// expedited (<= 4 bytes) or segmented, one transfer at a time per node with a
// queue behind it. Driven entirely from outside: on_frame() for received
// frames and poll(now) for timeouts, with time from the caller's (injected)
// clock, so it is deterministic and unit-testable without a bus.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "canopen/protocol.hpp"

namespace harvest::canopen {

struct SdoResult {
  bool ok = false;
  uint32_t abort_code = 0;    // set when !ok: from the server, or ours (e.g. timeout)
  std::string error;          // "node 3 0x6060:00: SDO protocol timed out"
  std::vector<uint8_t> data;  // uploaded bytes (reads)
};
using SdoCallback = std::function<void(const SdoResult&)>;

class SdoClient {
 public:
  SdoClient(std::function<void(const CanFrame&)> send, Micros timeout);

  void write(uint8_t node, uint16_t index, uint8_t sub, std::vector<uint8_t> data, SdoCallback done, Micros now);
  void write_u8(uint8_t node, uint16_t index, uint8_t sub, uint8_t v, SdoCallback done, Micros now);
  void write_u16(uint8_t node, uint16_t index, uint8_t sub, uint16_t v, SdoCallback done, Micros now);
  void write_u32(uint8_t node, uint16_t index, uint8_t sub, uint32_t v, SdoCallback done, Micros now);
  void read(uint8_t node, uint16_t index, uint8_t sub, SdoCallback done, Micros now);

  // Returns true if the frame was an SDO response for us.
  bool on_frame(const CanFrame& frame, Micros now);
  // Aborts transfers whose server did not answer within the timeout.
  void poll(Micros now);

  bool idle() const;
  // Drops every queued and active transfer without calling back (e.g. on shutdown).
  void cancel_all();

 private:
  struct Transfer {
    uint8_t node = 0;
    uint16_t index = 0;
    uint8_t sub = 0;
    bool write = false;
    std::vector<uint8_t> data;  // to send, or received so far
    SdoCallback done;
    // progress
    bool started = false;
    bool segmented = false;
    bool toggle = false;
    std::size_t offset = 0;
    std::size_t expected = 0;  // upload size if indicated
    Micros deadline = 0;
  };
  void enqueue(Transfer t, Micros now);
  void start(Transfer& t, Micros now);
  void finish(uint8_t node, SdoResult result, Micros now);
  void fail(uint8_t node, uint32_t code, bool send_abort, Micros now);
  void send_next_segment(Transfer& t, Micros now);

  std::function<void(const CanFrame&)> send_;
  Micros timeout_;
  std::map<uint8_t, std::deque<Transfer>> queues_;  // front = active
};

}  // namespace harvest::canopen

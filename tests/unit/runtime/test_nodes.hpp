// Small nodes used by the runtime tests.
#pragma once

#include <harvest/ir_range_t.hpp>

#include "runtime/clock.hpp"
#include "runtime/node.hpp"

namespace harvest::testing {

// Scales IR_RANGE-like messages by a gain; a stand-in for any processing node.
// Also ticks at 10 Hz on TICK so timer behaviour is visible in the output.
class ScaleNode : public rt::Node {
 public:
  ScaleNode(std::string in, std::string out, double gain, bool tick = true)
      : Node("scale"), in_(std::move(in)), out_(std::move(out)), gain_(gain), tick_(tick) {}
  int received = 0;

 protected:
  void on_attach() override {
    advertise(out_);
    subscribe<harvest::ir_range_t>(in_, [this](const harvest::ir_range_t& m) {
      ++received;
      harvest::ir_range_t o = m;
      o.header.source_seq = m.header.seq;
      o.range_m = static_cast<float>(m.range_m * gain_);
      o.raw = stamp(m.raw);
      publish(out_, o);
    });
    if (tick_) {
      advertise("TICK");
      every(100 * rt::kMilli, [this] {
        harvest::ir_range_t t{};
        t.header.utime = now();
        t.header.source_seq = -1;
        t.raw = ++ticks_;
        publish("TICK", t);
      });
    }
  }
  virtual int32_t stamp(int32_t raw) { return raw; }

 private:
  std::string in_, out_;
  double gain_;
  bool tick_;
  int32_t ticks_ = 0;
};

// The same node, but it (wrongly) reads the wall clock: replays differ.
class WallClockNode : public ScaleNode {
 public:
  using ScaleNode::ScaleNode;

 protected:
  int32_t stamp(int32_t) override { return static_cast<int32_t>(rt::wall_time_now() % 1000003); }
};

inline harvest::ir_range_t make_ir(int64_t utime, int32_t raw, float range) {
  harvest::ir_range_t m{};
  m.header.utime = utime;
  m.header.seq = raw;
  m.header.frame_id = "ir";
  m.header.source_seq = -1;
  m.header.publish_utime = utime;
  m.validity = harvest::ir_range_t::VALID;
  m.raw = raw;
  m.range_m = range;
  return m;
}

}  // namespace harvest::testing

// libFuzzer target: CANopen frame handling (lib/canopen). The input is a
// sequence of frames, 11 bytes each: id low byte; id high bits (0-2), remote
// (bit 3), extended (bit 4) and a time step (bits 5-7, x 3 ms); dlc (mod 9);
// 8 data bytes. Every frame goes to
//  * the robot link's Master (6 drives, started and configuring: SDO
//    responses, heartbeats, EMCY, TPDOs, NMT/SYNC from another master), with
//    SYNC periods and timeouts run as time advances, and
//  * a drive-side SdoServer (node 1) over an object dictionary with fixed and
//    variable-size entries (expedited and segmented transfers, aborts),
// and the stateless decoders (heartbeat, EMCY, TPDO1/2). Besides "no crash,
// no sanitizer report": the server answers only with SDO responses from its
// own node, 8 bytes each, and the master never loses or gains a drive.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <optional>

#include "can/can_bus.hpp"
#include "canopen/master.hpp"
#include "canopen/pdo.hpp"
#include "canopen/protocol.hpp"
#include "canopen/sdo_server.hpp"

namespace can = harvest::can;
namespace co = harvest::canopen;

namespace {

// Swallows what the master sends; nothing comes back but the fuzz input.
class SinkBus final : public can::CanBus {
 public:
  void send(const can::CanFrame&) override { ++sent; }
  std::optional<can::CanFrame> receive() override { return std::nullopt; }
  int fd() const override { return -1; }
  void set_filters(const std::vector<can::CanFilter>&) override {}
  can::BusState state() const override { return can::BusState::kActive; }
  std::string describe() const override { return "fuzz sink"; }
  int64_t sent = 0;
};

void check(bool ok) {
  if (!ok) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  SinkBus bus;
  co::MasterConfig cfg;
  for (uint8_t n = 1; n <= 6; ++n) cfg.drives.push_back({n, 1000.0, 0, 0.0});
  co::Master master(bus, cfg);
  co::Micros now = 1'000'000;
  master.start(now);

  co::ObjectDictionary od;
  od.add_u8(0x1001, 0, 0, false);
  od.add_u16(0x1017, 0, 50, true);
  od.add_u32(0x1016, 1, 0x007F0032, true, [](const std::vector<uint8_t>& v) { return v[3] == 0 ? 0u : 0x06090030u; });
  od.add_string(0x1008, 0, "harvest fuzz drive with a long name", false);
  od.add(0x2000, 0, std::vector<uint8_t>(3, 0), true);
  od.add_string(0x2001, 0, "", true);
  int bad_answers = 0;
  co::SdoServer server(1, od, [&](const can::CanFrame& f) {
    if (f.id != 0x581 || f.dlc != 8) ++bad_answers;
  });

  co::Micros next_sync = now + cfg.sync_period;
  for (std::size_t at = 0; at + 11 <= size; at += 11) {
    const uint8_t* r = data + at;
    can::CanFrame f;
    f.id = static_cast<uint32_t>(r[0] | ((r[1] & 0x07) << 8));
    f.remote = (r[1] & 0x08) != 0;
    f.extended = (r[1] & 0x10) != 0;
    f.dlc = static_cast<uint8_t>(r[2] % 9);
    for (int i = 0; i < 8; ++i) f.data[static_cast<std::size_t>(i)] = r[3 + i];
    now += 3'000 * (r[1] >> 5);
    while (next_sync <= now) {
      master.sync(next_sync);
      next_sync += cfg.sync_period;
    }
    master.handle_frame(f, now);
    server.on_frame(f);
    (void)co::decode_heartbeat(f);
    (void)co::decode_emcy(f);
    (void)co::decode_tpdo1(f);
    (void)co::decode_tpdo2(f);
    if (f.id == 0x7FF) master.clear_faults();  // the operator's RESET_FAULT, at an input-chosen moment
  }
  master.check_timeouts(now + 1'000'000);
  master.sync(now + 1'000'000);
  (void)master.take_events();
  check(bad_answers == 0);
  check(master.drives().size() == 6);
  return 0;
}

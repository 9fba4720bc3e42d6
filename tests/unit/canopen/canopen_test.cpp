// CANopen encodings against the byte layouts of CiA 301 / CiA 402, and the SDO
// client against the SDO server (expedited, segmented, aborts, timeouts).
#include <gtest/gtest.h>

#include <map>

#include <deque>

#include "canopen/cia402.hpp"
#include "canopen/pdo.hpp"
#include "canopen/protocol.hpp"
#include "canopen/sdo_client.hpp"
#include "canopen/sdo_server.hpp"

namespace harvest::canopen {
namespace {

std::vector<uint8_t> bytes(const CanFrame& f) { return {f.data.begin(), f.data.begin() + f.dlc}; }
using B = std::vector<uint8_t>;

TEST(Nmt, FramesMatchCia301) {
  const CanFrame start = nmt_frame(NmtCommand::kStart, 5);
  EXPECT_EQ(start.id, 0x000u);
  EXPECT_EQ(bytes(start), (B{0x01, 0x05}));
  EXPECT_EQ(bytes(nmt_frame(NmtCommand::kEnterPreOperational, 0)), (B{0x80, 0x00}));
  EXPECT_EQ(bytes(nmt_frame(NmtCommand::kResetCommunication, 127)), (B{0x82, 0x7F}));
  const CanFrame hb = heartbeat_frame(5, NmtState::kOperational);
  EXPECT_EQ(hb.id, 0x705u);
  EXPECT_EQ(bytes(hb), (B{0x05}));
  EXPECT_EQ(decode_heartbeat(hb), NmtState::kOperational);
  EXPECT_EQ(decode_heartbeat(heartbeat_frame(5, NmtState::kPreOperational)), NmtState::kPreOperational);
  CanFrame bad = hb;
  bad.data[0] = 0x33;
  EXPECT_FALSE(decode_heartbeat(bad));
  EXPECT_EQ(sync_frame().id, 0x080u);
  EXPECT_EQ(sync_frame().dlc, 0);
}

TEST(Emcy, LayoutAndDescription) {
  Emcy e;
  e.error_code = 0x2310;
  e.error_register = 0x03;
  const CanFrame f = emcy_frame(4, e);
  EXPECT_EQ(f.id, 0x084u);
  EXPECT_EQ(bytes(f), (B{0x10, 0x23, 0x03, 0, 0, 0, 0, 0}));
  EXPECT_EQ(decode_emcy(f)->error_code, 0x2310);
  EXPECT_EQ(describe_emcy(0x2310), "0x2310 current");
  EXPECT_FALSE(decode_emcy(sync_frame()));  // 0x080 with node 0 is SYNC, not EMCY
}

TEST(Sdo, ClientRequestLayouts) {
  CanFrame f = sdo::initiate_download_expedited(3, 0x6060, 0x00, 9, 1);
  EXPECT_EQ(f.id, 0x603u);
  EXPECT_EQ(bytes(f), (B{0x2F, 0x60, 0x60, 0x00, 0x09, 0, 0, 0}));
  f = sdo::initiate_download_expedited(3, 0x1017, 0x00, 50, 2);
  EXPECT_EQ(bytes(f), (B{0x2B, 0x17, 0x10, 0x00, 0x32, 0x00, 0, 0}));
  f = sdo::initiate_download_expedited(2, 0x1400, 0x01, 0x80000202, 4);
  EXPECT_EQ(bytes(f), (B{0x23, 0x00, 0x14, 0x01, 0x02, 0x02, 0x00, 0x80}));
  EXPECT_EQ(bytes(sdo::initiate_upload(1, 0x6041, 0)), (B{0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(bytes(sdo::initiate_download_segmented(1, 0x1008, 0, 19)), (B{0x21, 0x08, 0x10, 0x00, 19, 0, 0, 0}));
  const uint8_t seg[] = {'a', 'b', 'c'};
  // toggle 1, 7-3 = 4 unused bytes, last: 0x10 | (4 << 1) | 1 = 0x19
  EXPECT_EQ(bytes(sdo::download_segment(1, true, seg, 3, true)), (B{0x19, 'a', 'b', 'c', 0, 0, 0, 0}));
  EXPECT_EQ(bytes(sdo::upload_segment_request(1, true)), (B{0x70, 0, 0, 0, 0, 0, 0, 0}));
  f = sdo::abort_frame(0x601, 0x6060, 0, sdo::kAbortTimeout);
  EXPECT_EQ(bytes(f), (B{0x80, 0x60, 0x60, 0x00, 0x00, 0x00, 0x04, 0x05}));
  EXPECT_EQ(sdo::abort_code_of(f), 0x05040000u);
}

TEST(Sdo, ServerResponseLayouts) {
  EXPECT_EQ(bytes(sdo::download_response(3, 0x6060, 0)), (B{0x60, 0x60, 0x60, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(bytes(sdo::upload_response_expedited(3, 0x6041, 0, 0x0237, 2)),
            (B{0x4B, 0x41, 0x60, 0x00, 0x37, 0x02, 0, 0}));
  EXPECT_EQ(bytes(sdo::upload_response_expedited(3, 0x1000, 0, 0x00020192, 4)),
            (B{0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00}));
  EXPECT_EQ(sdo::upload_response_expedited(3, 0x1000, 0, 0, 4).id, 0x583u);
}

TEST(Sdo, AbortCodesHaveNames) {
  EXPECT_STREQ(sdo::abort_name(0x06020000), "object does not exist in the object dictionary");
  EXPECT_STREQ(sdo::abort_name(0x05040000), "SDO protocol timed out");
  EXPECT_STREQ(sdo::abort_name(0x06010002), "attempt to write a read only object");
  EXPECT_STREQ(sdo::abort_name(0x12345678), "unknown abort code");
}

TEST(Pdo, DefaultMappingLayouts) {
  const CanFrame r = rpdo1_frame(2, 0x000F, -1000);
  EXPECT_EQ(r.id, 0x202u);
  EXPECT_EQ(bytes(r), (B{0x0F, 0x00, 0x18, 0xFC, 0xFF, 0xFF}));
  CanFrame t;
  t.id = 0x182;
  t.dlc = 6;
  t.data = {0x37, 0x02, 0x40, 0xE2, 0x01, 0x00};  // statusword 0x0237, position 123456
  const auto tp = decode_tpdo1(t);
  ASSERT_TRUE(tp);
  EXPECT_EQ(tp->statusword, 0x0237);
  EXPECT_EQ(tp->position, 123456);
  t.id = 0x282;
  t.dlc = 4;
  t.data = {0xFF, 0xFF, 0xFF, 0xFF};
  EXPECT_EQ(decode_tpdo2(t), -1);
  t.dlc = 3;
  EXPECT_FALSE(decode_tpdo2(t));  // wrong length is not a TPDO2 of our mapping

  const auto writes = default_drive_configuration(4, 50);
  // Mapping entries: index << 16 | sub << 8 | bit length.
  bool rpdo_velocity = false, tpdo_position = false, csv = false;
  for (const auto& w : writes) {
    if (w.index == 0x1600 && w.sub == 2) rpdo_velocity = w.value == 0x60FF0020;
    if (w.index == 0x1A00 && w.sub == 2) tpdo_position = w.value == 0x60640020;
    if (w.index == 0x6060) csv = w.value == 9 && w.size == 1;
  }
  EXPECT_TRUE(rpdo_velocity && tpdo_position && csv);
  bool heartbeat_producer = false;
  for (const auto& w : writes) heartbeat_producer = heartbeat_producer || (w.index == 0x1017 && w.value == 50);
  EXPECT_TRUE(heartbeat_producer);
}

// The drive-side protection writes (docs/can.md): heartbeat consumer on the
// master's node, RPDO1 event timer as its deadline, abort connection option
// quick stop, quick-stop deceleration; after the mapping, before NMT start.
TEST(Pdo, DriveProtectionWrites) {
  DriveProtection p;
  p.master_node = 127;
  p.heartbeat_consumer_ms = 50;
  p.rpdo_timeout_ms = 30;
  p.abort_connection_option = 3;
  p.quick_stop_deceleration = 3'930'000;
  const auto writes = default_drive_configuration(4, 50, p);
  std::map<uint32_t, SdoWrite> by_key;
  for (const auto& w : writes) by_key[(static_cast<uint32_t>(w.index) << 8) | w.sub] = w;
  ASSERT_TRUE(by_key.count(0x101601));
  EXPECT_EQ(by_key[0x101601].value, 0x007F0032u);  // node 127, 50 ms
  EXPECT_EQ(by_key[0x101601].size, 4);
  EXPECT_EQ(by_key[0x140005].value, 30u);
  EXPECT_EQ(by_key[0x140005].size, 2);
  EXPECT_EQ(by_key[0x600700].value, 3u);
  EXPECT_EQ(by_key[0x600700].size, 2);
  EXPECT_EQ(by_key[0x608500].value, 3'930'000u);
  // Off where not asked for: no consumer, no deadline, the drive's own deceleration.
  const auto plain = default_drive_configuration(4, 50);
  for (const auto& w : plain) {
    EXPECT_NE(w.index, 0x1016);
    EXPECT_FALSE(w.index == 0x1400 && w.sub == 5);
    EXPECT_NE(w.index, 0x6085);
  }
}

TEST(Cia402, StatuswordDecoding) {
  EXPECT_EQ(decode_statusword(0x0000), Cia402State::kNotReadyToSwitchOn);
  EXPECT_EQ(decode_statusword(0x0250), Cia402State::kSwitchOnDisabled);
  EXPECT_EQ(decode_statusword(0x0231), Cia402State::kReadyToSwitchOn);
  EXPECT_EQ(decode_statusword(0x0233), Cia402State::kSwitchedOn);
  EXPECT_EQ(decode_statusword(0x0237), Cia402State::kOperationEnabled);
  EXPECT_EQ(decode_statusword(0x0217), Cia402State::kQuickStopActive);
  EXPECT_EQ(decode_statusword(0x021F), Cia402State::kFaultReactionActive);
  EXPECT_EQ(decode_statusword(0x0218), Cia402State::kFault);
  for (int s = 0; s <= 7; ++s)
    EXPECT_EQ(decode_statusword(encode_statusword(static_cast<Cia402State>(s))), static_cast<Cia402State>(s));
}

// Runs the master's controlword logic against the device state machine.
Cia402State drive_toward(Cia402State s, DriveGoal goal, bool allow_reset, int steps, int* used = nullptr) {
  uint16_t master_prev = 0, device_prev = 0;
  for (int i = 0; i < steps; ++i) {
    const uint16_t cw = next_controlword(s, goal, master_prev, allow_reset);
    s = apply_controlword(s, cw, device_prev);
    master_prev = device_prev = cw;
    if (used != nullptr) *used = i + 1;
    if ((goal == DriveGoal::kEnabled && s == Cia402State::kOperationEnabled) ||
        (goal == DriveGoal::kDisabled && s == Cia402State::kSwitchOnDisabled))
      break;
  }
  return s;
}

TEST(Cia402, MasterBringsDriveToOperationEnabledFromAnyState) {
  int used = 0;
  EXPECT_EQ(drive_toward(Cia402State::kSwitchOnDisabled, DriveGoal::kEnabled, true, 10, &used),
            Cia402State::kOperationEnabled);
  EXPECT_EQ(used, 3);  // shutdown, switch on, enable operation
  EXPECT_EQ(drive_toward(Cia402State::kFault, DriveGoal::kEnabled, true, 10), Cia402State::kOperationEnabled);
  EXPECT_EQ(drive_toward(Cia402State::kQuickStopActive, DriveGoal::kEnabled, true, 10), Cia402State::kOperationEnabled);
  EXPECT_EQ(drive_toward(Cia402State::kOperationEnabled, DriveGoal::kDisabled, true, 10),
            Cia402State::kSwitchOnDisabled);
}

TEST(Cia402, FaultStaysLatchedWithoutPermission) {
  EXPECT_EQ(drive_toward(Cia402State::kFault, DriveGoal::kEnabled, false, 10), Cia402State::kFault);
  // A fault reset needs a rising edge of bit 7.
  EXPECT_EQ(apply_controlword(Cia402State::kFault, 0x0080, 0x0080), Cia402State::kFault);
  EXPECT_EQ(apply_controlword(Cia402State::kFault, 0x0080, 0x0000), Cia402State::kSwitchOnDisabled);
}

// What the master accepts as a state change it caused (or a drive makes on
// its own); anything else is a state change without a command.
TEST(Cia402, CommandedTransitions) {
  using S = Cia402State;
  namespace cw = controlword;
  EXPECT_TRUE(commanded_transition(S::kOperationEnabled, S::kOperationEnabled, cw::kEnableOperation, cw::kEnableOperation));
  EXPECT_TRUE(commanded_transition(S::kSwitchedOn, S::kOperationEnabled, cw::kEnableOperation, cw::kSwitchOn));
  EXPECT_TRUE(commanded_transition(S::kOperationEnabled, S::kQuickStopActive, cw::kQuickStop, cw::kEnableOperation));
  EXPECT_TRUE(commanded_transition(S::kOperationEnabled, S::kSwitchedOn, cw::kShutdown, cw::kSwitchOn))
      << "a TPDO may answer the SYNC before the last one";
  EXPECT_TRUE(commanded_transition(S::kOperationEnabled, S::kFaultReactionActive, cw::kEnableOperation, 0));
  EXPECT_TRUE(commanded_transition(S::kFault, S::kSwitchOnDisabled, cw::kDisableVoltage, cw::kFaultReset));
  EXPECT_TRUE(commanded_transition(S::kQuickStopActive, S::kSwitchOnDisabled, cw::kQuickStop, cw::kQuickStop));
  EXPECT_TRUE(commanded_transition(S::kNotReadyToSwitchOn, S::kSwitchOnDisabled, 0, 0));
  // Disabled, stopped or enabled by someone else:
  EXPECT_FALSE(commanded_transition(S::kOperationEnabled, S::kSwitchOnDisabled, cw::kEnableOperation,
                                    cw::kEnableOperation));
  EXPECT_FALSE(commanded_transition(S::kOperationEnabled, S::kQuickStopActive, cw::kEnableOperation,
                                    cw::kEnableOperation));
  EXPECT_FALSE(commanded_transition(S::kSwitchOnDisabled, S::kOperationEnabled, cw::kDisableVoltage,
                                    cw::kDisableVoltage));
  EXPECT_FALSE(commanded_transition(S::kFault, S::kSwitchOnDisabled, cw::kDisableVoltage, cw::kDisableVoltage))
      << "a fault reset we did not send";
}

TEST(Cia402, QuickStopFromOperationEnabled) {
  EXPECT_EQ(next_controlword(Cia402State::kOperationEnabled, DriveGoal::kQuickStop, 0x000F, true), 0x0002);
  EXPECT_EQ(apply_controlword(Cia402State::kOperationEnabled, 0x0002, 0x000F), Cia402State::kQuickStopActive);
  // Stays in quick stop until voltage is disabled (transition 12).
  EXPECT_EQ(apply_controlword(Cia402State::kQuickStopActive, 0x000F, 0x0002), Cia402State::kQuickStopActive);
  EXPECT_EQ(apply_controlword(Cia402State::kQuickStopActive, 0x0000, 0x0002), Cia402State::kSwitchOnDisabled);
}

// Client and server connected back to back through queues.
class SdoLoop : public ::testing::Test {
 protected:
  SdoLoop()
      : client_([this](const CanFrame& f) { to_server_.push_back(f); }, 100'000),
        server_(7, od_, [this](const CanFrame& f) { to_client_.push_back(f); }) {
    od_.add_u32(0x1000, 0, 0x00020192, false);
    od_.add_u8(0x6060, 0, 0, true,
               [](const std::vector<uint8_t>& v) { return v[0] == 9 ? 0u : sdo::kAbortValueRange; });
    od_.add_string(0x1008, 0, "K-1207i joint drive (simulated)", false);
    od_.add_string(0x2000, 0, "", true);
  }
  // Deliver frames until both sides are quiet (drop_responses simulates a dead server).
  void pump(bool drop_responses = false) {
    while (!to_server_.empty() || !to_client_.empty()) {
      while (!to_server_.empty()) {
        const CanFrame f = to_server_.front();
        to_server_.pop_front();
        frames_to_server_++;
        if (!drop_responses) server_.on_frame(f);
      }
      while (!to_client_.empty()) {
        const CanFrame f = to_client_.front();
        to_client_.pop_front();
        client_.on_frame(f, now_);
      }
    }
  }
  ObjectDictionary od_;
  std::deque<CanFrame> to_server_, to_client_;
  SdoClient client_;
  SdoServer server_;
  Micros now_ = 0;
  int frames_to_server_ = 0;
};

TEST_F(SdoLoop, ExpeditedReadAndWrite) {
  SdoResult read, write;
  client_.read(
      7, 0x1000, 0, [&](const SdoResult& r) { read = r; }, now_);
  client_.write_u8(
      7, 0x6060, 0, 9, [&](const SdoResult& r) { write = r; }, now_);
  pump();
  ASSERT_TRUE(read.ok) << read.error;
  EXPECT_EQ(read.data, (B{0x92, 0x01, 0x02, 0x00}));
  EXPECT_TRUE(write.ok) << write.error;
  EXPECT_EQ(od_.get(0x6060, 0), 9u);
  EXPECT_TRUE(client_.idle());
}

TEST_F(SdoLoop, SegmentedUploadAndDownload) {
  SdoResult read;
  client_.read(
      7, 0x1008, 0, [&](const SdoResult& r) { read = r; }, now_);
  pump();
  ASSERT_TRUE(read.ok) << read.error;
  EXPECT_EQ(std::string(read.data.begin(), read.data.end()), "K-1207i joint drive (simulated)");
  EXPECT_EQ(frames_to_server_, 1 + 5);  // initiate + ceil(31 / 7) segment requests

  const std::string text = "fourteen bytes";  // exactly two segments
  SdoResult write;
  client_.write(
      7, 0x2000, 0, B(text.begin(), text.end()), [&](const SdoResult& r) { write = r; }, now_);
  pump();
  ASSERT_TRUE(write.ok) << write.error;
  std::vector<uint8_t> stored;
  od_.read(0x2000, 0, stored);
  EXPECT_EQ(std::string(stored.begin(), stored.end()), text);
}

TEST_F(SdoLoop, ServerAbortsAreReportedByName) {
  SdoResult missing, read_only, range;
  client_.read(
      7, 0x6064, 0, [&](const SdoResult& r) { missing = r; }, now_);
  client_.write_u32(
      7, 0x1000, 0, 1, [&](const SdoResult& r) { read_only = r; }, now_);
  client_.write_u8(
      7, 0x6060, 0, 3, [&](const SdoResult& r) { range = r; }, now_);
  pump();
  EXPECT_FALSE(missing.ok);
  EXPECT_EQ(missing.abort_code, sdo::kAbortNoObject);
  EXPECT_EQ(missing.error, "node 7 0x6064:00: object does not exist in the object dictionary");
  EXPECT_EQ(read_only.abort_code, sdo::kAbortReadOnly);
  EXPECT_EQ(range.abort_code, sdo::kAbortValueRange);
  EXPECT_EQ(od_.get(0x6060, 0), 0u);  // refused value not stored
}

TEST_F(SdoLoop, TimeoutAbortsAndTheQueueMovesOn) {
  SdoResult first, second;
  client_.read(
      7, 0x1000, 0, [&](const SdoResult& r) { first = r; }, now_);
  client_.read(
      7, 0x1000, 0, [&](const SdoResult& r) { second = r; }, now_);
  pump(/*drop_responses=*/true);
  now_ = 99'999;
  client_.poll(now_);
  EXPECT_FALSE(first.ok || !first.error.empty());  // not yet
  now_ = 100'000;
  client_.poll(now_);
  EXPECT_FALSE(first.ok);
  EXPECT_EQ(first.abort_code, sdo::kAbortTimeout);
  EXPECT_NE(first.error.find("SDO protocol timed out"), std::string::npos);
  // The abort went out on the bus, then the queued read started and now succeeds.
  ASSERT_GE(to_server_.size(), 2u);
  EXPECT_EQ(sdo::specifier(to_server_.front()), sdo::kAbort);
  pump();
  EXPECT_TRUE(second.ok) << second.error;
}

TEST_F(SdoLoop, ToggleErrorAborts) {
  SdoResult read;
  client_.read(
      7, 0x1008, 0, [&](const SdoResult& r) { read = r; }, now_);
  // Let the initiate go through, then answer the segment request with the wrong toggle.
  server_.on_frame(to_server_.front());
  to_server_.pop_front();
  client_.on_frame(to_client_.front(), now_);
  to_client_.pop_front();
  const uint8_t data[7] = {};
  client_.on_frame(sdo::upload_segment(7, /*toggle=*/true, data, 7, false), now_);
  EXPECT_EQ(read.abort_code, sdo::kAbortToggle);
}

}  // namespace
}  // namespace harvest::canopen

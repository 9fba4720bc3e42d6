#include "canopen/sdo_client.hpp"

#include <cstdio>

namespace harvest::canopen {
namespace {

std::string where(uint8_t node, uint16_t index, uint8_t sub) {
  char buf[48];
  std::snprintf(buf, sizeof(buf), "node %u 0x%04X:%02X", node, index, sub);
  return buf;
}

SdoResult success() {
  SdoResult r;
  r.ok = true;
  return r;
}

std::vector<uint8_t> le(uint32_t v, int n) {
  std::vector<uint8_t> out(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) out[static_cast<std::size_t>(i)] = static_cast<uint8_t>(v >> (8 * i));
  return out;
}

}  // namespace

SdoClient::SdoClient(std::function<void(const CanFrame&)> send, Micros timeout)
    : send_(std::move(send)), timeout_(timeout) {}

void SdoClient::write(uint8_t node, uint16_t index, uint8_t sub, std::vector<uint8_t> data, SdoCallback done,
                      Micros now) {
  Transfer t;
  t.node = node;
  t.index = index;
  t.sub = sub;
  t.write = true;
  t.data = std::move(data);
  t.done = std::move(done);
  enqueue(std::move(t), now);
}
void SdoClient::write_u8(uint8_t node, uint16_t index, uint8_t sub, uint8_t v, SdoCallback done, Micros now) {
  write(node, index, sub, le(v, 1), std::move(done), now);
}
void SdoClient::write_u16(uint8_t node, uint16_t index, uint8_t sub, uint16_t v, SdoCallback done, Micros now) {
  write(node, index, sub, le(v, 2), std::move(done), now);
}
void SdoClient::write_u32(uint8_t node, uint16_t index, uint8_t sub, uint32_t v, SdoCallback done, Micros now) {
  write(node, index, sub, le(v, 4), std::move(done), now);
}
void SdoClient::read(uint8_t node, uint16_t index, uint8_t sub, SdoCallback done, Micros now) {
  Transfer t;
  t.node = node;
  t.index = index;
  t.sub = sub;
  t.done = std::move(done);
  enqueue(std::move(t), now);
}

void SdoClient::enqueue(Transfer t, Micros now) {
  auto& q = queues_[t.node];
  q.push_back(std::move(t));
  if (q.size() == 1) start(q.front(), now);
}

void SdoClient::start(Transfer& t, Micros now) {
  t.started = true;
  t.deadline = now + timeout_;
  if (!t.write) {
    send_(sdo::initiate_upload(t.node, t.index, t.sub));
  } else if (!t.data.empty() && t.data.size() <= 4) {
    uint32_t v = 0;
    for (std::size_t i = 0; i < t.data.size(); ++i) v |= static_cast<uint32_t>(t.data[i]) << (8 * i);
    send_(sdo::initiate_download_expedited(t.node, t.index, t.sub, v, static_cast<uint8_t>(t.data.size())));
  } else {
    t.segmented = true;
    send_(sdo::initiate_download_segmented(t.node, t.index, t.sub, static_cast<uint32_t>(t.data.size())));
  }
}

void SdoClient::send_next_segment(Transfer& t, Micros now) {
  const std::size_t n = std::min<std::size_t>(7, t.data.size() - t.offset);
  const bool last = t.offset + n == t.data.size();
  send_(sdo::download_segment(t.node, t.toggle, t.data.data() + t.offset, static_cast<uint8_t>(n), last));
  t.offset += n;
  t.deadline = now + timeout_;
}

void SdoClient::finish(uint8_t node, SdoResult result, Micros now) {
  auto& q = queues_[node];
  Transfer t = std::move(q.front());
  q.pop_front();
  // Start the next before calling back, so a callback may enqueue freely.
  if (!q.empty()) start(q.front(), now);
  if (t.done) t.done(result);
}

void SdoClient::fail(uint8_t node, uint32_t code, bool send_abort, Micros now) {
  const Transfer& t = queues_[node].front();
  if (send_abort) send_(sdo::abort_frame(cob::kSdoRx + node, t.index, t.sub, code));
  SdoResult r;
  r.abort_code = code;
  r.error = where(node, t.index, t.sub) + ": " + sdo::abort_name(code);
  finish(node, std::move(r), now);
}

bool SdoClient::on_frame(const CanFrame& f, Micros now) {
  if (function_of(f.id) != cob::kSdoTx || f.extended || f.remote) return false;
  const uint8_t node = node_of(f.id);
  auto it = queues_.find(node);
  if (it == queues_.end() || it->second.empty()) return true;  // stray response: ignore
  Transfer& t = it->second.front();
  if (f.dlc != 8) {
    fail(node, sdo::kAbortBadCommand, true, now);
    return true;
  }
  const uint8_t scs = sdo::specifier(f);
  if (scs == sdo::kAbort) {
    fail(node, sdo::abort_code_of(f), false, now);
    return true;
  }
  if (t.write) {
    if (!t.segmented || t.offset == 0) {
      // Response to the initiate request.
      if (scs != sdo::kServerInitiateDownload || sdo::index_of(f) != t.index || sdo::subindex_of(f) != t.sub) {
        fail(node, sdo::kAbortBadCommand, true, now);
        return true;
      }
      if (!t.segmented) {
        finish(node, success(), now);
        return true;
      }
      send_next_segment(t, now);
      return true;
    }
    if (scs != sdo::kServerDownloadSegment) {
      fail(node, sdo::kAbortBadCommand, true, now);
      return true;
    }
    if (((f.data[0] & 0x10) != 0) != t.toggle) {
      fail(node, sdo::kAbortToggle, true, now);
      return true;
    }
    t.toggle = !t.toggle;
    if (t.offset == t.data.size()) {
      finish(node, success(), now);
    } else {
      send_next_segment(t, now);
    }
    return true;
  }

  // Upload.
  if (!t.segmented) {
    if (scs != sdo::kServerInitiateUpload || sdo::index_of(f) != t.index || sdo::subindex_of(f) != t.sub) {
      fail(node, sdo::kAbortBadCommand, true, now);
      return true;
    }
    const bool expedited = f.data[0] & 0x02;
    const bool size_indicated = f.data[0] & 0x01;
    if (expedited) {
      const std::size_t n = size_indicated ? 4 - ((f.data[0] >> 2) & 0x03) : 4;
      SdoResult r = success();
      r.data.assign(f.data.begin() + 4, f.data.begin() + 4 + static_cast<std::ptrdiff_t>(n));
      finish(node, std::move(r), now);
      return true;
    }
    t.segmented = true;
    t.expected = size_indicated ? get_u32(&f.data[4]) : 0;
    send_(sdo::upload_segment_request(node, t.toggle));
    t.deadline = now + timeout_;
    return true;
  }
  if (scs != sdo::kServerUploadSegment) {
    fail(node, sdo::kAbortBadCommand, true, now);
    return true;
  }
  if (((f.data[0] & 0x10) != 0) != t.toggle) {
    fail(node, sdo::kAbortToggle, true, now);
    return true;
  }
  const std::size_t n = 7 - ((f.data[0] >> 1) & 0x07);
  t.data.insert(t.data.end(), f.data.begin() + 1, f.data.begin() + 1 + static_cast<std::ptrdiff_t>(n));
  if (f.data[0] & 0x01) {
    if (t.expected != 0 && t.data.size() != t.expected) {
      fail(node, sdo::kAbortLengthMismatch, true, now);
      return true;
    }
    SdoResult r = success();
    r.data = std::move(t.data);
    finish(node, std::move(r), now);
    return true;
  }
  t.toggle = !t.toggle;
  send_(sdo::upload_segment_request(node, t.toggle));
  t.deadline = now + timeout_;
  return true;
}

void SdoClient::poll(Micros now) {
  for (auto& [node, q] : queues_) {
    if (!q.empty() && q.front().started && now >= q.front().deadline) {
      fail(node, sdo::kAbortTimeout, true, now);
    }
  }
}

bool SdoClient::idle() const {
  for (const auto& [node, q] : queues_)
    if (!q.empty()) return false;
  return true;
}

void SdoClient::cancel_all() { queues_.clear(); }

}  // namespace harvest::canopen

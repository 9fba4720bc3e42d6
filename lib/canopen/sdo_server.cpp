#include "canopen/sdo_server.hpp"

namespace harvest::canopen {
namespace {
std::vector<uint8_t> le(uint32_t v, int n) {
  std::vector<uint8_t> out(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) out[static_cast<std::size_t>(i)] = static_cast<uint8_t>(v >> (8 * i));
  return out;
}
}  // namespace

void ObjectDictionary::add(uint16_t index, uint8_t sub, std::vector<uint8_t> value, bool writable, Validator validate) {
  entries_[key(index, sub)] = Entry{std::move(value), writable, true, std::move(validate)};
}
void ObjectDictionary::add_u8(uint16_t index, uint8_t sub, uint8_t v, bool writable, Validator validate) {
  add(index, sub, le(v, 1), writable, std::move(validate));
}
void ObjectDictionary::add_u16(uint16_t index, uint8_t sub, uint16_t v, bool writable, Validator validate) {
  add(index, sub, le(v, 2), writable, std::move(validate));
}
void ObjectDictionary::add_u32(uint16_t index, uint8_t sub, uint32_t v, bool writable, Validator validate) {
  add(index, sub, le(v, 4), writable, std::move(validate));
}
void ObjectDictionary::add_string(uint16_t index, uint8_t sub, const std::string& s, bool writable) {
  entries_[key(index, sub)] = Entry{std::vector<uint8_t>(s.begin(), s.end()), writable, false, {}};
}

bool ObjectDictionary::has(uint16_t index, uint8_t sub) const { return entries_.count(key(index, sub)) != 0; }

uint32_t ObjectDictionary::write(uint16_t index, uint8_t sub, const std::vector<uint8_t>& value) {
  auto it = entries_.find(key(index, sub));
  if (it == entries_.end()) {
    for (const auto& [k, e] : entries_)
      if ((k >> 8) == index) return sdo::kAbortNoSubindex;
    return sdo::kAbortNoObject;
  }
  Entry& e = it->second;
  if (!e.writable) return sdo::kAbortReadOnly;
  if (e.fixed_size && value.size() != e.value.size()) return sdo::kAbortLengthMismatch;
  if (e.validate) {
    if (const uint32_t code = e.validate(value); code != 0) return code;
  }
  e.value = value;
  return 0;
}

uint32_t ObjectDictionary::read(uint16_t index, uint8_t sub, std::vector<uint8_t>& out) const {
  auto it = entries_.find(key(index, sub));
  if (it == entries_.end()) {
    for (const auto& [k, e] : entries_)
      if ((k >> 8) == index) return sdo::kAbortNoSubindex;
    return sdo::kAbortNoObject;
  }
  out = it->second.value;
  return 0;
}

uint32_t ObjectDictionary::get(uint16_t index, uint8_t sub) const {
  auto it = entries_.find(key(index, sub));
  if (it == entries_.end()) return 0;
  uint32_t v = 0;
  for (std::size_t i = 0; i < it->second.value.size() && i < 4; ++i)
    v |= static_cast<uint32_t>(it->second.value[i]) << (8 * i);
  return v;
}

void ObjectDictionary::set(uint16_t index, uint8_t sub, uint32_t value) {
  auto it = entries_.find(key(index, sub));
  if (it == entries_.end()) return;
  for (std::size_t i = 0; i < it->second.value.size() && i < 4; ++i)
    it->second.value[i] = static_cast<uint8_t>(value >> (8 * i));
}

SdoServer::SdoServer(uint8_t node, ObjectDictionary& od, std::function<void(const CanFrame&)> send)
    : node_(node), od_(od), send_(std::move(send)) {}

void SdoServer::abort(uint32_t code) {
  send_(sdo::abort_frame(cob::kSdoTx + node_, index_, sub_, code));
  mode_ = Mode::kIdle;
}

bool SdoServer::on_frame(const CanFrame& f) {
  if (f.id != cob::kSdoRx + node_ || f.extended || f.remote) return false;
  if (f.dlc != 8) return true;  // not a valid SDO request: ignore, the client times out
  const uint8_t ccs = sdo::specifier(f);
  switch (ccs) {
    case sdo::kAbort:
      mode_ = Mode::kIdle;
      return true;
    case sdo::kClientInitiateDownload: {
      index_ = sdo::index_of(f);
      sub_ = sdo::subindex_of(f);
      const bool expedited = f.data[0] & 0x02;
      const bool size_indicated = f.data[0] & 0x01;
      if (expedited) {
        const std::size_t n = size_indicated ? 4 - ((f.data[0] >> 2) & 0x03) : 4;
        const std::vector<uint8_t> value(f.data.begin() + 4, f.data.begin() + 4 + static_cast<std::ptrdiff_t>(n));
        if (const uint32_t code = od_.write(index_, sub_, value); code != 0) {
          abort(code);
          return true;
        }
        mode_ = Mode::kIdle;
        send_(sdo::download_response(node_, index_, sub_));
        return true;
      }
      if (!od_.has(index_, sub_)) {
        std::vector<uint8_t> dummy;
        abort(od_.read(index_, sub_, dummy));
        return true;
      }
      mode_ = Mode::kDownload;
      toggle_ = false;
      buffer_.clear();
      expected_ = size_indicated ? get_u32(&f.data[4]) : 0;
      send_(sdo::download_response(node_, index_, sub_));
      return true;
    }
    case sdo::kClientDownloadSegment: {
      if (mode_ != Mode::kDownload) {
        abort(sdo::kAbortBadCommand);
        return true;
      }
      if (((f.data[0] & 0x10) != 0) != toggle_) {
        abort(sdo::kAbortToggle);
        return true;
      }
      const std::size_t n = 7 - ((f.data[0] >> 1) & 0x07);
      buffer_.insert(buffer_.end(), f.data.begin() + 1, f.data.begin() + 1 + static_cast<std::ptrdiff_t>(n));
      const bool last = f.data[0] & 0x01;
      if (last) {
        if (expected_ != 0 && buffer_.size() != expected_) {
          abort(sdo::kAbortLengthMismatch);
          return true;
        }
        if (const uint32_t code = od_.write(index_, sub_, buffer_); code != 0) {
          abort(code);
          return true;
        }
        mode_ = Mode::kIdle;
      }
      send_(sdo::download_segment_response(node_, toggle_));
      toggle_ = !toggle_;
      return true;
    }
    case sdo::kClientInitiateUpload: {
      index_ = sdo::index_of(f);
      sub_ = sdo::subindex_of(f);
      if (const uint32_t code = od_.read(index_, sub_, buffer_); code != 0) {
        abort(code);
        return true;
      }
      if (!buffer_.empty() && buffer_.size() <= 4) {
        uint32_t v = 0;
        for (std::size_t i = 0; i < buffer_.size(); ++i) v |= static_cast<uint32_t>(buffer_[i]) << (8 * i);
        send_(sdo::upload_response_expedited(node_, index_, sub_, v, static_cast<uint8_t>(buffer_.size())));
        mode_ = Mode::kIdle;
        return true;
      }
      mode_ = Mode::kUpload;
      toggle_ = false;
      offset_ = 0;
      send_(sdo::upload_response_segmented(node_, index_, sub_, static_cast<uint32_t>(buffer_.size())));
      return true;
    }
    case sdo::kClientUploadSegment: {
      if (mode_ != Mode::kUpload) {
        abort(sdo::kAbortBadCommand);
        return true;
      }
      if (((f.data[0] & 0x10) != 0) != toggle_) {
        abort(sdo::kAbortToggle);
        return true;
      }
      const std::size_t n = std::min<std::size_t>(7, buffer_.size() - offset_);
      const bool last = offset_ + n == buffer_.size();
      send_(sdo::upload_segment(node_, toggle_, buffer_.data() + offset_, static_cast<uint8_t>(n), last));
      offset_ += n;
      toggle_ = !toggle_;
      if (last) mode_ = Mode::kIdle;
      return true;
    }
    default:
      abort(sdo::kAbortBadCommand);
      return true;
  }
}

}  // namespace harvest::canopen

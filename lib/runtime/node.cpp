#include "runtime/node.hpp"

#include <spdlog/spdlog.h>

#include <stdexcept>

namespace harvest::rt {

void Node::attach(Context& context) {
  if (ctx_ != nullptr) throw std::logic_error("node '" + name_ + "' attached twice");
  ctx_ = &context;
  on_attach();
}

Context& Node::ctx() const {
  if (ctx_ == nullptr) throw std::logic_error("node '" + name_ + "' used before it was attached to a runner");
  return *ctx_;
}

TimerId Node::every(Micros period, std::function<void()> callback) {
  if (period <= 0) throw std::invalid_argument("node '" + name_ + "': timer period must be > 0");
  return ctx().add_timer(now() + period, period, std::move(callback), name_);
}

TimerId Node::after(Micros delay, std::function<void()> callback) {
  return ctx().add_timer(now() + std::max<Micros>(delay, 0), 0, std::move(callback), name_);
}

void Node::set_health(Health h, std::string message) {
  if (log_health_ && (h != health_ || message != health_message_)) {
    if (h == Health::kError)
      spdlog::error("{}{}", log_prefix(), message);
    else if (h == Health::kDegraded)
      spdlog::warn("{}{}", log_prefix(), message);
    else if (!message.empty())
      spdlog::info("{}{}", log_prefix(), message);
  }
  health_ = h;
  health_message_ = std::move(message);
}

std::string Node::log_prefix() const {
  const spdlog::logger* logger = spdlog::default_logger_raw();
  return logger != nullptr && logger->name() == name_ ? std::string() : "[" + name_ + "] ";
}

void Node::drop_malformed(const std::string& channel, const char* type, std::size_t size, const std::string& why) {
  ++stats_.decode_errors;
  const int64_t n = ++stats_.counters["malformed." + channel];
  int64_t suppressed = 0;
  Micros since = 0;
  if (malformed_log_[channel].admit(now(), suppressed, since))
    spdlog::warn("{}dropped malformed message on {} ({} bytes, expected {}): {}; {} on this channel so far",
                 log_prefix(), channel, size, type, why, n);
}

void Node::handler_failed(const std::string& channel, const char* what) {
  ++stats_.handler_errors;
  const int64_t n = ++stats_.counters["handler_errors." + channel];
  int64_t suppressed = 0;
  Micros since = 0;
  if (handler_log_[channel].admit(now(), suppressed, since))
    spdlog::error("{}handling a message on {} failed: {}; {} on this channel so far, going on", log_prefix(), channel,
                  what, n);
}

void Node::publish_encoded(const std::string& channel, const std::vector<uint8_t>& bytes) {
  ++stats_.published;
  ctx().publish_bytes(channel, bytes.data(), bytes.size());
}

}  // namespace harvest::rt

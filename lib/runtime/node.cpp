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
  return ctx().add_timer(now() + period, period, std::move(callback));
}

TimerId Node::after(Micros delay, std::function<void()> callback) {
  return ctx().add_timer(now() + std::max<Micros>(delay, 0), 0, std::move(callback));
}

void Node::set_health(Health h, std::string message) {
  if (h != health_ || message != health_message_) {
    if (h == Health::kError)
      spdlog::error("[{}] {}", name_, message);
    else if (h == Health::kDegraded)
      spdlog::warn("[{}] {}", name_, message);
    else if (!message.empty())
      spdlog::info("[{}] {}", name_, message);
  }
  health_ = h;
  health_message_ = std::move(message);
}

void Node::on_decode_error(const std::string& channel, const std::string& type, std::size_t size) {
  // Rate-limit by count: the 1st, 10th, 100th, ... so a flood cannot fill the log.
  const int64_t n = stats_.decode_errors;
  if ((n & (n - 1)) == 0 || n % 1000 == 0)
    spdlog::warn("[{}] dropped malformed message on {} ({} bytes, expected {}); {} so far", name_, channel, size,
                 type, n);
}

void Node::publish_encoded(const std::string& channel, const std::vector<uint8_t>& bytes) {
  ++stats_.published;
  ctx().publish_bytes(channel, bytes.data(), bytes.size());
}

}  // namespace harvest::rt

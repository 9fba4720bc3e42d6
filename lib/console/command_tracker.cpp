#include "console/command_tracker.hpp"

#include <algorithm>
#include <stdexcept>

namespace harvest::console {

std::string verb_of_request(const std::string& text) {
  const auto j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) throw std::invalid_argument("request is not JSON");
  if (!j.is_object() || !j.contains("command") || !j["command"].is_string())
    throw std::invalid_argument("request has no \"command\" string");
  const std::string verb = j["command"].get<std::string>();
  const auto& verbs = servo::operator_verbs();
  if (std::find(verbs.begin(), verbs.end(), verb) == verbs.end())
    throw std::invalid_argument("unknown command \"" + verb + "\"");
  return verb;
}

CommandTracker::CommandTracker(std::string source, int64_t timeout_us)
    : source_(std::move(source)), timeout_us_(timeout_us) {}

servo::OperatorMessage CommandTracker::command(const std::string& verb, int64_t now_us) {
  auto msg = servo::make_operator_message(verb, source_, verb == "estop" ? "operator console" : "", now_us);
  last_ = Pending{verb, now_us, "waiting", ""};
  return msg;
}

void CommandTracker::invalid_request(const std::string& why, int64_t now_us) {
  last_ = Pending{"?", now_us, "invalid", "console: " + why + "; nothing sent"};
}

void CommandTracker::send_failed(int64_t /*now_us*/) {
  if (!last_) return;
  last_->state = "send failed";
  last_->detail = "could not publish on LCM";
}

void CommandTracker::on_status(const harvest_status_t& m, int64_t now_us) {
  if (!last_ || last_->state != "waiting" || now_us - last_->sent_us > timeout_us_) return;
  const auto ack = servo::acknowledgement(last_->verb, source_, m);
  if (ack.state == servo::AckState::kAccepted) last_->state = "accepted";
  if (ack.state == servo::AckState::kRefused) last_->state = "refused";
  if (ack.state != servo::AckState::kWaiting) last_->detail = ack.detail;
}

nlohmann::json CommandTracker::to_json(int64_t now_us) const {
  if (!last_) return nullptr;
  std::string state = last_->state;
  if (state == "waiting" && now_us - last_->sent_us > timeout_us_) state = "no reply";
  return {{"verb", last_->verb},
          {"state", state},
          {"detail", last_->detail},
          {"age_s", static_cast<double>(now_us - last_->sent_us) / 1e6}};
}

}  // namespace harvest::console

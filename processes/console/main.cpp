// harvest-console: the web operator console (docs/console.md). One HTTP +
// WebSocket server (civetweb) bridging LCM to one browser page: the state the
// page shows goes out as JSON over the WebSocket 5 times a second, camera
// frames are served as JPEG at a reduced rate, and a button on the page
// becomes an operator command, sent only then, whose acknowledgement comes
// back in the state. LCM is handled on the main thread only; civetweb's
// threads touch the shared state under one mutex.
//
//   harvest-console [--listen 127.0.0.1:8080] [--lcm-url URL] [--prefix P]
//                   [--image-rate HZ] [--www DIR] [--stats-s S]
#include <civetweb.h>
#include <sys/resource.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <csignal>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>

#include "camera/image_codec.hpp"
#include "console/command_tracker.hpp"
#include "console/console_state.hpp"
#include "runtime/channels.hpp"
#include "runtime/checked_subscription.hpp"
#include "runtime/clock.hpp"
#include "runtime/rate_gate.hpp"
#include "runtime/wire_check.hpp"
#include "security/authority.hpp"

namespace {

namespace ch = harvest::channels;
namespace fs = std::filesystem;
using harvest::console::CommandTracker;
using harvest::console::ConsoleState;

std::atomic<bool> g_stop{false};

int64_t now_us() { return harvest::rt::wall_time_now(); }

double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) / 1e6;
}

// Everything the server threads and the LCM thread share.
struct Shared {
  std::mutex m;
  ConsoleState state;
  CommandTracker tracker;
  std::map<std::string, std::string> jpeg;  // camera -> last frame passed on
  std::deque<std::string> requests;         // verbs from the page, sent by the LCM thread
  std::set<mg_connection*> clients;
  fs::path www;
  explicit Shared(std::string source) : tracker(std::move(source)) {}
};

int send_bytes(mg_connection* conn, const std::string& body, const char* mime) {
  mg_printf(conn,
            "HTTP/1.1 200 OK\r\nContent-Type: %s\r\nContent-Length: %zu\r\nCache-Control: no-store\r\n"
            "Connection: close\r\n\r\n",
            mime, body.size());
  mg_write(conn, body.data(), body.size());
  return 200;
}

// Only the page's own files: no path from the request reaches the file system.
int serve_static(mg_connection* conn, void* cb) {
  auto* s = static_cast<Shared*>(cb);
  static const std::map<std::string, std::pair<std::string, const char*>> files{
      {"/", {"index.html", "text/html; charset=utf-8"}},
      {"/index.html", {"index.html", "text/html; charset=utf-8"}},
      {"/console.js", {"console.js", "text/javascript; charset=utf-8"}},
      {"/console.css", {"console.css", "text/css; charset=utf-8"}}};
  const auto it = files.find(mg_get_request_info(conn)->local_uri);
  if (it == files.end()) return mg_send_http_error(conn, 404, "not found"), 404;
  std::ifstream f(s->www / it->second.first, std::ios::binary);
  if (!f) return mg_send_http_error(conn, 500, "cannot read %s", it->second.first.c_str()), 500;
  std::ostringstream body;
  body << f.rdbuf();
  return send_bytes(conn, body.str(), it->second.second);
}

int serve_camera(mg_connection* conn, void* cb) {
  auto* s = static_cast<Shared*>(cb);
  std::string uri = mg_get_request_info(conn)->local_uri;  // /camera/NAME.jpg
  const std::string name = uri.substr(std::string("/camera/").size(), uri.size() - 12);
  std::string body;
  {
    std::lock_guard lock(s->m);
    const auto it = s->jpeg.find(name);
    if (it != s->jpeg.end()) body = it->second;
  }
  if (body.empty()) return mg_send_http_error(conn, 404, "no frame from camera %s yet", name.c_str()), 404;
  return send_bytes(conn, body, "image/jpeg");
}

nlohmann::json page_state(Shared& s) {
  const int64_t t = now_us();
  auto j = s.state.to_json(t);
  j["command"] = s.tracker.to_json(t);
  return j;
}

int serve_state(mg_connection* conn, void* cb) {
  auto* s = static_cast<Shared*>(cb);
  std::string body;
  {
    std::lock_guard lock(s->m);
    body = page_state(*s).dump();
  }
  return send_bytes(conn, body, "application/json");
}

void ws_ready(mg_connection* conn, void* cb) {
  auto* s = static_cast<Shared*>(cb);
  std::lock_guard lock(s->m);
  s->clients.insert(conn);
}

void ws_close(const mg_connection* conn, void* cb) {
  auto* s = static_cast<Shared*>(cb);
  std::lock_guard lock(s->m);
  s->clients.erase(const_cast<mg_connection*>(conn));
}

// A button press: {"command": "start"}. A bad request is answered on the
// socket and sends nothing.
int ws_data(mg_connection* conn, int flags, char* data, size_t len, void* cb) {
  auto* s = static_cast<Shared*>(cb);
  if ((flags & 0xf) != MG_WEBSOCKET_OPCODE_TEXT) return 1;
  try {
    const std::string verb = harvest::console::verb_of_request(std::string(data, len));
    std::lock_guard lock(s->m);
    s->requests.push_back(verb);
  } catch (const std::exception& e) {
    {
      std::lock_guard lock(s->m);
      s->tracker.invalid_request(e.what(), now_us());
    }
    const std::string reply = nlohmann::json{{"error", e.what()}}.dump();
    mg_websocket_write(conn, MG_WEBSOCKET_OPCODE_TEXT, reply.data(), reply.size());
  }
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Web operator console: one page showing the arm's process graph, with the operator's buttons"};
  std::string listen = "127.0.0.1:8080", url, prefix, www = HARVEST_CONSOLE_WWW;
  double image_rate = 5.0, stats_s = 0;
  app.add_option("--listen", listen, "address:port to serve on (0.0.0.0:PORT for every interface)")
      ->capture_default_str();
  app.add_option("--lcm-url", url, "LCM provider URL (default: $LCM_DEFAULT_URL or LCM's default)");
  app.add_option("--prefix", prefix, "channel prefix of the arm's process graph");
  app.add_option("--image-rate", image_rate, "camera frames passed to the browser per second and camera")
      ->check(CLI::Range(0.1, 30.0))
      ->capture_default_str();
  app.add_option("--www", www, "folder of the page's files")->capture_default_str();
  app.add_option("--stats-s", stats_s, "print the console's CPU share and frame rates every S seconds (0: never)");
  std::string key_name = harvest::security::default_command_key(), sender = "console";
  app.add_option(
      "--key", key_name,
      "command key the buttons sign with: 'sim' or the robot's key file (default $HARVEST_COMMAND_KEY or sim)");
  app.add_option("--sender", sender, "sender id it signs as (one of the receivers' authority.operators)")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  harvest::rt::SystemClock signing_clock;
  std::optional<harvest::security::Signer> signer;
  try {
    signer.emplace(harvest::security::load_named_key(key_name), sender, signing_clock);
  } catch (const std::exception& e) {
    std::cerr << "harvest-console: " << e.what() << "\n";
    return 2;
  }

  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::cerr << "harvest-console: cannot open LCM (" << (url.empty() ? "default URL" : url) << ")\n";
    return 1;
  }
  if (!fs::exists(fs::path(www) / "index.html")) {
    std::cerr << "harvest-console: no index.html in " << www << " (--www)\n";
    return 2;
  }
  Shared shared(harvest::servo::operator_source("harvest-console"));
  shared.www = www;

  // Subscriptions first: nothing is missed between the server coming up and the first message.
  const auto locked = [&](auto fn) {
    return [&, fn](const auto& m) {
      std::lock_guard lock(shared.m);
      fn(m, now_us());
    };
  };
  using namespace harvest;
  rt::CheckedSubscription<process_status_t> s_proc(
      lcm, prefix + ch::kProcessStatus,
      locked([&](const process_status_t& m, int64_t t) { shared.state.on_process_status(m, t); }));
  rt::CheckedSubscription<harvest_status_t> s_harvest(lcm, prefix + ch::kHarvestStatus,
                                                      locked([&](const harvest_status_t& m, int64_t t) {
                                                        shared.state.on_harvest_status(m, t);
                                                        shared.tracker.on_status(m, t);
                                                      }));
  rt::CheckedSubscription<robot_state_t> s_robot(
      lcm, prefix + ch::kRobotState,
      locked([&](const robot_state_t& m, int64_t t) { shared.state.on_robot_state(m, t); }));
  rt::CheckedSubscription<ir_range_t> s_ir(
      lcm, prefix + ch::kIrRange, locked([&](const ir_range_t& m, int64_t t) { shared.state.on_ir_range(m, t); }));
  rt::CheckedSubscription<gripper_state_t> s_grip(
      lcm, prefix + ch::kGripperState,
      locked([&](const gripper_state_t& m, int64_t t) { shared.state.on_gripper_state(m, t); }));
  rt::CheckedSubscription<fruit_detections_t> s_det_f(
      lcm, prefix + ch::kFruitFixed,
      locked([&](const fruit_detections_t& m, int64_t t) { shared.state.on_detections("fixed", m, t); }));
  rt::CheckedSubscription<fruit_detections_t> s_det_h(
      lcm, prefix + ch::kFruitHand,
      locked([&](const fruit_detections_t& m, int64_t t) { shared.state.on_detections("hand", m, t); }));

  // Camera frames: every frame is heard (LCM cannot filter at the sender), but
  // only those the rate gate admits are decoded, and a queue of one keeps
  // the console from falling behind a 30 Hz stream.
  struct Camera {
    std::string name;
    rt::RateGate gate;
    int64_t heard = 0, passed = 0;
  };
  std::map<std::string, Camera> cameras{{prefix + ch::kCameraFixed, {"fixed", rt::RateGate(image_rate)}},
                                        {prefix + ch::kCameraHand, {"hand", rt::RateGate(image_rate)}}};
  struct ImageHandler {
    std::map<std::string, Camera>* cameras;
    Shared* shared;
    void on_raw(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
      Camera& cam = cameras->at(channel);
      ++cam.heard;
      const int64_t t = now_us();
      if (!cam.gate.admit(t)) return;
      image_t img;
      if (!rt::decode_checked(rbuf->data, rbuf->data_size, img).empty()) return;
      std::string jpeg;
      if (img.encoding == image_t::ENCODING_JPEG) {
        jpeg.assign(img.data.begin(), img.data.end());
      } else {
        const auto decoded = camera::decode_image(img);
        if (!decoded.ok()) return;
        image_t out;
        camera::encode_image(decoded.bgr, true, 80, out);
        jpeg.assign(out.data.begin(), out.data.end());
      }
      ++cam.passed;
      std::lock_guard lock(shared->m);
      shared->jpeg[cam.name] = std::move(jpeg);
      shared->state.on_frame(cam.name, img, t);
    }
  } image_handler{&cameras, &shared};
  std::vector<lcm::Subscription*> image_subs;
  for (const auto& [channel, cam] : cameras) {
    image_subs.push_back(lcm.subscribe(channel, &ImageHandler::on_raw, &image_handler));
    image_subs.back()->setQueueCapacity(1);
  }

  mg_init_library(0);
  const char* options[] = {"listening_ports", listen.c_str(), "num_threads", "4", nullptr};
  mg_callbacks callbacks{};
  mg_context* ctx = mg_start(&callbacks, nullptr, options);
  if (ctx == nullptr) {
    std::cerr << "harvest-console: cannot serve on " << listen << " (address in use, or not this host's?)\n";
    return 1;
  }
  mg_set_request_handler(ctx, "/camera/", serve_camera, &shared);
  mg_set_request_handler(ctx, "/state", serve_state, &shared);
  mg_set_request_handler(ctx, "/$", serve_static, &shared);
  mg_set_request_handler(ctx, "/index.html", serve_static, &shared);
  mg_set_request_handler(ctx, "/console.js", serve_static, &shared);
  mg_set_request_handler(ctx, "/console.css", serve_static, &shared);
  mg_set_websocket_handler(ctx, "/ws", nullptr, ws_ready, ws_data, ws_close, &shared);
  std::cout << "harvest-console: serving http://" << listen << "/ (LCM " << (url.empty() ? "default URL" : url)
            << ", images at " << image_rate << " Hz per camera)" << std::endl;

  std::signal(SIGINT, [](int) { g_stop = true; });
  std::signal(SIGTERM, [](int) { g_stop = true; });

  const auto t0 = std::chrono::steady_clock::now();
  const auto stats_period =
      std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(stats_s));
  auto next_push = t0, next_stats = t0 + stats_period;
  double cpu_at_stats = cpu_seconds();
  std::map<std::string, int64_t> heard_at_stats, passed_at_stats;
  while (!g_stop) {
    lcm.handleTimeout(20);
    // Commands go out only here, one per button press on the page.
    std::deque<std::string> verbs;
    {
      std::lock_guard lock(shared.m);
      verbs.swap(shared.requests);
    }
    for (const auto& verb : verbs) {
      servo::OperatorMessage msg;
      {
        std::lock_guard lock(shared.m);
        msg = shared.tracker.command(verb, now_us());
      }
      const bool ok = servo::send_operator_message(lcm, prefix, msg, servo::default_repeat(verb), *signer);
      std::cout << "harvest-console: " << (ok ? "sent " : "FAILED to send ") << verb << " as "
                << shared.tracker.source() << std::endl;
      if (!ok) {
        std::lock_guard lock(shared.m);
        shared.tracker.send_failed(now_us());
      }
    }
    const auto now = std::chrono::steady_clock::now();
    if (now >= next_push) {
      next_push = now + std::chrono::milliseconds(200);
      std::lock_guard lock(shared.m);
      if (!shared.clients.empty()) {
        const std::string text = page_state(shared).dump();
        for (mg_connection* c : shared.clients)
          mg_websocket_write(c, MG_WEBSOCKET_OPCODE_TEXT, text.data(), text.size());
      }
    }
    if (stats_s > 0 && now >= next_stats) {
      const double span = stats_s;
      const double cpu = cpu_seconds();
      std::cout << "harvest-console: cpu " << 100.0 * (cpu - cpu_at_stats) / span << " % of a core over " << span
                << " s";
      for (const auto& [channel, cam] : cameras)
        std::cout << "; " << cam.name << " heard " << (cam.heard - heard_at_stats[channel]) / span << " Hz, passed "
                  << (cam.passed - passed_at_stats[channel]) / span << " Hz";
      std::cout << std::endl;
      cpu_at_stats = cpu;
      for (const auto& [channel, cam] : cameras) {
        heard_at_stats[channel] = cam.heard;
        passed_at_stats[channel] = cam.passed;
      }
      next_stats = now + stats_period;
    }
  }
  mg_stop(ctx);
  for (auto* sub : image_subs) lcm.unsubscribe(sub);
  std::cout << "harvest-console: stopped" << std::endl;
  return 0;
}

// The Inverse Service stand-in (inverse_service.hpp): Boost.Beast HTTP and WebSocket servers on one
// Asio thread, the simulated cursor stepped once per answer.
#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without including it

// GCC 12 takes Asio's coroutine frames (allocated by the frame's own operator new, freed by its
// sized operator delete) for a mismatched pair; they are not.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

#include <algorithm>
#include <boost/asio/co_spawn.hpp>
#include <boost/asio/detached.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/redirect_error.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/use_awaitable.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <future>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "standins/haply/inverse_service.hpp"

namespace cariesim::test {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;
using nlohmann::json;

struct InverseService::Impl {
  InverseServiceOptions options;
  asio::io_context io;
  std::unique_ptr<tcp::acceptor> http_acceptor, ws_acceptor;
  unsigned short http_port = 0, ws_port = 0;
  std::thread thread;

  // Shared with the test's thread.
  mutable std::mutex mutex;
  bool inverse3 = true;
  double delay = 0.0;  // s
  Vec3 hand = Vec3::Zero();
  Vec3 x = Vec3::Zero(), v = Vec3::Zero();  // m, m/s
  Vec3 force = Vec3::Zero();                // N, commanded
  Vec3 peak = Vec3::Zero();                 // N, the largest commanded
  Vec3 nonzero = Vec3::Zero();              // N, the newest non-zero commanded
  Quat q = Quat::Identity();
  uint32_t buttons = 0;
  uint64_t commands = 0, bad = 0, accepted = 0;
  std::set<std::shared_ptr<websocket::stream<beast::tcp_stream>>> sessions;  // Asio thread only

  // One vec3 as the service writes it.
  static json vec(const Vec3& a) { return {{"x", a.x()}, {"y", a.y()}, {"z", a.z()}}; }

  // The devices' entries; `full` adds config (the inventory, `/devices`).
  json devices(bool full) const {
    const std::lock_guard<std::mutex> lock(mutex);
    json doc = json::object();
    json inv = json::array();
    if (inverse3) {
      json d = {
          {"device_id", options.device_id},
          {"state",
           {{"cursor_position", vec(x)}, {"cursor_velocity", vec(v)}, {"current_cursor_force", vec(force)}}},
          {"status", json::object()}};
      if (full) d["config"] = {{"type", "inverse3"}, {"handedness", "right"}};
      inv.push_back(std::move(d));
    }
    doc["inverse3"] = std::move(inv);
    json grips = json::array();
    if (options.grip) {
      json buttons_json = {
          {"a", (buttons & 1u) != 0}, {"b", (buttons & 2u) != 0}, {"c", (buttons & 4u) != 0}};
      grips.push_back({{"device_id", options.grip_id},
                       {"state",
                        {{"orientation", {{"w", q.w()}, {"x", q.x()}, {"y", q.y()}, {"z", q.z()}}},
                         {"buttons", std::move(buttons_json)},
                         {"battery_level", 0.9}}}});
    }
    doc["wireless_verse_grip"] = std::move(grips);
    return doc;
  }

  // One tick of the cursor: m a = F_command + F_hand - b v, with a hard stop 0.3 m out.
  void step(double dt) {
    const std::lock_guard<std::mutex> lock(mutex);
    const Vec3 a = (force + hand - options.damping * v) / options.mass;
    v += a * dt;
    x += v * dt;
    for (int i = 0; i < 3; ++i)
      if (std::abs(x[i]) > 0.3) {
        x[i] = std::clamp(x[i], -0.3, 0.3);
        v[i] = 0.0;
      }
  }

  // A set_cursor_force for our device: its values become the commanded force.
  void command(const std::string& text) {
    const json doc = json::parse(text, nullptr, false);
    const std::lock_guard<std::mutex> lock(mutex);
    try {
      const json& d = doc.at("inverse3").at(0);
      if (d.at("device_id").get<std::string>() != options.device_id) throw std::runtime_error("device");
      const json& values = d.at("commands").at("set_cursor_force").at("values");
      force = Vec3(values.at("x").get<double>(), values.at("y").get<double>(), values.at("z").get<double>());
      if (force.norm() > peak.norm()) peak = force;
      if (force != Vec3::Zero()) nonzero = force;
      ++commands;
    } catch (const std::exception&) {
      ++bad;
    }
  }

  // GET /version and /devices, one request per connection.
  asio::awaitable<void> serve_http(tcp::socket socket) {
    beast::tcp_stream stream(std::move(socket));
    beast::flat_buffer buffer;
    http::request<http::string_body> request;
    beast::error_code ec;
    co_await http::async_read(stream, buffer, request, asio::redirect_error(asio::use_awaitable, ec));
    if (ec) co_return;
    http::response<http::string_body> response(http::status::ok, request.version());
    response.set(http::field::content_type, "application/json");
    if (request.target() == "/version") {
      std::string version;
      {
        const std::lock_guard<std::mutex> lock(mutex);
        version = options.version;
      }
      response.body() = json{{"project_name", "haply-inverse-service"},
                             {"project_version", version},
                             {"git_tag", version.substr(0, version.rfind('.'))}}
                            .dump();
    } else if (request.target() == "/devices") {
      response.body() = devices(true).dump();
    } else {
      response.result(http::status::not_found);
      response.body() = R"({"ok":false,"error":"no such route"})";
    }
    response.keep_alive(false);
    response.prepare_payload();
    co_await http::async_write(stream, response, asio::redirect_error(asio::use_awaitable, ec));
    stream.socket().shutdown(tcp::socket::shutdown_both, ec);
  }

  // The simulation channel: the inventory, then one state per message, paced by the device's rate.
  asio::awaitable<void> serve_ws(tcp::socket socket) {
    auto ws = std::make_shared<websocket::stream<beast::tcp_stream>>(std::move(socket));
    sessions.insert(ws);
    beast::error_code ec;
    co_await ws->async_accept(asio::redirect_error(asio::use_awaitable, ec));
    if (!ec) {
      {
        const std::lock_guard<std::mutex> lock(mutex);
        ++accepted;
      }
      ws->text(true);
      std::string out = devices(true).dump();
      co_await ws->async_write(asio::buffer(out), asio::redirect_error(asio::use_awaitable, ec));
    }
    const auto period = std::chrono::nanoseconds(static_cast<int64_t>(1e9 / options.rate_hz));
    auto next = std::chrono::steady_clock::now();
    asio::steady_timer timer(ws->get_executor());
    beast::flat_buffer buffer;
    while (!ec) {
      co_await ws->async_read(buffer, asio::redirect_error(asio::use_awaitable, ec));
      if (ec) break;
      command(beast::buffers_to_string(buffer.data()));
      buffer.consume(buffer.size());
      double delay = 0.0;
      {
        const std::lock_guard<std::mutex> lock(mutex);
        delay = this->delay;
      }
      next = std::max(next + period, std::chrono::steady_clock::now());
      timer.expires_at(next + std::chrono::nanoseconds(static_cast<int64_t>(delay * 1e9)));
      co_await timer.async_wait(asio::redirect_error(asio::use_awaitable, ec));
      if (ec) break;
      step(1.0 / options.rate_hz);
      std::string out = devices(false).dump();
      co_await ws->async_write(asio::buffer(out), asio::redirect_error(asio::use_awaitable, ec));
    }
    sessions.erase(ws);
  }

  // Accepts connections on `acceptor` while it is open.
  template <typename Serve>
  asio::awaitable<void> accept(tcp::acceptor& acceptor, Serve serve) {
    for (;;) {
      beast::error_code ec;
      tcp::socket socket = co_await acceptor.async_accept(asio::redirect_error(asio::use_awaitable, ec));
      if (ec) co_return;
      asio::co_spawn(io, (this->*serve)(std::move(socket)), asio::detached);
    }
  }

  // Listens at `port` (0: any free port), address reusable so come_back() gets the same ports.
  std::unique_ptr<tcp::acceptor> listen(unsigned short port) {
    auto a = std::make_unique<tcp::acceptor>(io);
    const tcp::endpoint at(asio::ip::make_address("127.0.0.1"), port);
    a->open(at.protocol());
    a->set_option(asio::socket_base::reuse_address(true));
    a->bind(at);
    a->listen();
    return a;
  }

  void start_listening() {
    http_acceptor = listen(http_port);
    ws_acceptor = listen(ws_port);
    http_port = http_acceptor->local_endpoint().port();
    ws_port = ws_acceptor->local_endpoint().port();
    asio::co_spawn(io, accept(*http_acceptor, &Impl::serve_http), asio::detached);
    asio::co_spawn(io, accept(*ws_acceptor, &Impl::serve_ws), asio::detached);
  }

  // Runs `f` on the Asio thread and waits for it.
  template <typename F>
  void on_io(F f) {
    std::promise<void> done;
    asio::post(io, [&] {
      f();
      done.set_value();
    });
    done.get_future().wait();
  }

  void close_sessions() {
    for (const auto& ws : sessions) {
      beast::error_code ec;
      beast::get_lowest_layer(*ws).socket().shutdown(tcp::socket::shutdown_both, ec);
      beast::get_lowest_layer(*ws).socket().close(ec);
    }
  }
};

InverseService::InverseService(InverseServiceOptions options) : impl_(std::make_unique<Impl>()) {
  impl_->options = std::move(options);
  impl_->inverse3 = impl_->options.inverse3;
  impl_->http_port = impl_->options.http_port;
  impl_->ws_port = impl_->options.ws_port;
  impl_->x = Vec3(0.0, 0.1, 0.1);  // m, in front of the base, above the table
  impl_->start_listening();
  impl_->thread = std::thread([this] {
    auto guard = asio::make_work_guard(impl_->io);
    impl_->io.run();
  });
}

InverseService::~InverseService() {
  impl_->on_io([this] {
    impl_->close_sessions();
    beast::error_code ec;
    impl_->http_acceptor->close(ec);
    impl_->ws_acceptor->close(ec);
  });
  impl_->io.stop();
  impl_->thread.join();
}

std::string InverseService::url() const {
  return "http://127.0.0.1:" + std::to_string(impl_->http_port) +
         ",ws://127.0.0.1:" + std::to_string(impl_->ws_port);
}

void InverseService::set_version(const std::string& version) {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->options.version = version;
}
void InverseService::set_inverse3(bool attached) {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->inverse3 = attached;
}
void InverseService::set_answer_delay(double seconds) {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->delay = seconds;
}
void InverseService::drop_connections() {
  impl_->on_io([this] { impl_->close_sessions(); });
}
void InverseService::go_away() {
  impl_->on_io([this] {
    beast::error_code ec;
    impl_->http_acceptor->close(ec);
    impl_->ws_acceptor->close(ec);
    impl_->close_sessions();
  });
}
void InverseService::come_back() {
  impl_->on_io([this] { impl_->start_listening(); });
}
void InverseService::push_hand(const Vec3& force) {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->hand = force;
}
void InverseService::place_cursor(const Vec3& position) {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->x = position;
  impl_->v.setZero();
}
void InverseService::set_orientation(const Quat& q) {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->q = q;
}
void InverseService::set_buttons(uint32_t bits) {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->buttons = bits;
}
Vec3 InverseService::last_force() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->force;
}
Vec3 InverseService::peak_force() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->peak;
}
Vec3 InverseService::last_nonzero_force() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->nonzero;
}
Vec3 InverseService::position() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->x;
}
uint64_t InverseService::commands() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->commands;
}
uint64_t InverseService::bad_commands() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->bad;
}
uint64_t InverseService::connections() const {
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->accepted;
}
int InverseService::open_connections() const {
  int n = 0;
  impl_->on_io([&] { n = static_cast<int>(impl_->sessions.size()); });
  return n;
}

}  // namespace cariesim::test

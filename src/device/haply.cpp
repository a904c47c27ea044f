// The Haply Inverse3 backend (docs/devices.md, "Haply Inverse3"): the Inverse Service's HTTP routes
// (`/version`, `/devices`) with Boost.Beast on the control thread, and its WebSocket on an I/O thread
// of the backend's own. The service answers one state per message, so the I/O thread sends the newest
// force, receives a state and hands it to the servo thread through a TripleBuffer; the exchange's rate
// is the service's answer rate. The servo thread's read(), write() and enable_force() touch only the
// triple buffers and atomics.
#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without including it

// GCC 12 takes Asio's coroutine frames (allocated by the frame's own operator new, freed by its
// sized operator delete) for a mismatched pair; they are not.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
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
#include <condition_variable>
#include <cstdlib>
#include <mutex>
#include <thread>

#include "cariesim/common/clock.hpp"
#include "cariesim/common/error.hpp"
#include "cariesim/common/lockfree.hpp"
#include "cariesim/device/hardware_backends.hpp"
#include "device/haply_protocol.hpp"

namespace cariesim {

namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;
using namespace std::chrono_literals;

constexpr auto kHttpTimeout = 3s;              // an HTTP request, connect to answer
constexpr auto kConnectTimeout = 2s;           // the WebSocket's connect and handshake
constexpr auto kFirstStateTimeout = 3s;        // open(): the inventory and the first answers
constexpr auto kReconnectEvery = 250ms;        // after the service went away
constexpr auto kIdleTimeout = 2s;              // no answer at all for this long: the connection is lost
constexpr auto kCloseTimeout = 1s;             // close(): the zero-force command's answer
constexpr int kRateSamples = 20;               // answers open() times for the rate
constexpr double kStalePeriods = 5.0;          // a state older than this many answer periods is stale
constexpr int64_t kStaleFloorNs = 10'000'000;  // ... but never younger than 10 ms
constexpr int64_t kCalibrationFreshNs = 100'000'000;  // calibrate(): a state this recent is streaming
constexpr double kMmPerM = 1000.0;

// cariesim's figures for an Inverse3 (the service announces none): conservative, below the device's.
constexpr double kMaxForce = 6.0;                                                             // N
constexpr double kContinuousForce = 3.0;                                                      // N
constexpr double kMaxStiffness = 2.0;                                                         // N/mm
const Eigen::AlignedBox3d kWorkspace{Vec3(-150.0, -50.0, -50.0), Vec3(150.0, 250.0, 250.0)};  // mm

// What the install lacks when the service is not reachable.
constexpr const char* kInstall =
    "install and start Haply's Inverse Service (haply-inverse-service .deb; systemctl start "
    "haply-inverse-service)";

// Runs one coroutine on a private io_context and rethrows what it threw.
template <typename T>
T run_blocking(asio::awaitable<T> task) {
  asio::io_context io;
  std::exception_ptr failure;
  T result{};
  asio::co_spawn(io, std::move(task), [&](std::exception_ptr e, T value) {
    failure = e;
    result = std::move(value);
  });
  io.run();
  if (failure) std::rethrow_exception(failure);
  return result;
}

// "connection refused" -> the service is not running; a timeout -> it does not answer.
std::string explain(const beast::error_code& ec) {
  if (ec == asio::error::connection_refused) return "connection refused: the service is not running";
  if (ec == beast::error::timeout) return "no answer within the timeout";
  return ec.message();
}

// GET http://host:port/target with a deadline; the body of a 200 answer, else an Error naming why.
asio::awaitable<std::string> http_get(haply::Endpoint e, std::string target) {
  const std::string where = "http://" + e.http_host + ":" + e.http_port + target;
  auto executor = co_await asio::this_coro::executor;
  tcp::resolver resolver(executor);
  beast::tcp_stream stream(executor);
  beast::error_code ec;
  const auto hosts = co_await resolver.async_resolve(e.http_host, e.http_port,
                                                     asio::redirect_error(asio::use_awaitable, ec));
  if (ec)
    throw Error("Haply Inverse Service at " + where + ": cannot resolve " + e.http_host + ": " +
                ec.message());
  stream.expires_after(kHttpTimeout);
  co_await stream.async_connect(hosts, asio::redirect_error(asio::use_awaitable, ec));
  if (ec) throw Error("Haply Inverse Service at " + where + ": " + explain(ec) + " (" + kInstall + ")");
  http::request<http::empty_body> request(http::verb::get, target, 11);
  request.set(http::field::host, e.http_host);
  co_await http::async_write(stream, request, asio::redirect_error(asio::use_awaitable, ec));
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.body_limit(1u << 20);
  if (!ec) co_await http::async_read(stream, buffer, parser, asio::redirect_error(asio::use_awaitable, ec));
  if (ec) throw Error("Haply Inverse Service at " + where + ": " + explain(ec));
  const auto& response = parser.get();
  if (response.result() != http::status::ok)
    throw Error("Haply Inverse Service at " + where + ": answered " + std::to_string(response.result_int()) +
                " " + std::string(response.reason()));
  co_return response.body();
}

// What an Inverse3 is: the service announces no limits, so cariesim's own figures.
HardwareInfo inverse3_info(const haply::ServiceVersion& version, const haply::Endpoint& e,
                           const haply::Inventory& inventory, const std::string& id) {
  HardwareInfo info;
  info.backend = "haply";
  info.model = "Inverse3";
  info.serial = id;
  info.sdk = "Haply Inverse Service " + version.text + " at " + e.describe();
  info.dof_in = inventory.grips.empty() ? 3 : 6;  // a VerseGrip gives the orientation and buttons
  info.dof_out = 3;
  info.buttons = inventory.grips.empty() ? 0 : 3;
  info.max_force = kMaxForce;
  info.continuous_force = kContinuousForce;
  info.max_stiffness = kMaxStiffness;
  info.workspace = kWorkspace;
  // The service's frame: x to the right, y forward (away from the operator), z up: the operator frame.
  info.axes = Quat::Identity();
  // The VerseGrip's orientation is zeroed when it is powered in its holder.
  info.rest_orientation = Quat::Identity();
  return info;
}

// The version, checked, and the inventory; throws naming the problem.
std::pair<haply::ServiceVersion, haply::Inventory> query_service(const haply::Endpoint& e) {
  haply::ServiceVersion version = haply::parse_version(run_blocking(http_get(e, "/version")));
  haply::check_version(version);
  haply::Inventory inventory = haply::parse_inventory(run_blocking(http_get(e, "/devices")));
  return {std::move(version), std::move(inventory)};
}

// One state as the servo thread takes it (a plain value: copied through the triple buffer).
struct Sample {
  Vec3 position = Vec3::Zero();  // mm
  Vec3 velocity = Vec3::Zero();  // mm/s
  Quat orientation = Quat::Identity();
  uint32_t buttons = 0;
  uint32_t faults = 0;               // HardwareFault bits
  int64_t received_ns = 0;           // monotonic_ns() of the answer; 0: none yet
  int64_t stale_ns = kStaleFloorNs;  // older than this is stale
};

// The force the servo thread asks for (N, device frame).
struct Command {
  Vec3 force = Vec3::Zero();
};

// What open() waits for from the I/O thread.
enum class Startup { Pending, Running, Failed };

class HaplyDevice final : public HardwareDevice {
 public:
  explicit HaplyDevice(haply::Endpoint endpoint) : endpoint_(std::move(endpoint)) {}
  ~HaplyDevice() override { close(); }
  HaplyDevice(const HaplyDevice&) = delete;
  HaplyDevice& operator=(const HaplyDevice&) = delete;

  void open() override;
  void close() override;
  [[nodiscard]] HardwareInfo info() const override { return info_; }
  Calibration calibrate() override;
  HardwareReading read() override;
  void write(const Vec3& force, const Vec3& torque) override;
  void enable_force(bool on) override { force_on_.store(on, std::memory_order_release); }

 private:
  asio::awaitable<void> run();
  asio::awaitable<bool> session(bool first);
  void publish(const haply::State& state, int64_t now_ns);
  void publish_fault(uint32_t faults);
  void startup_failed(const std::string& why);
  void report(const std::string& problem);
  void stop_io();

  haply::Endpoint endpoint_;
  HardwareInfo info_;
  std::string device_id_;
  bool opened_ = false;

  // The I/O thread and its context, made anew by each open() (a context destroyed with the
  // coroutines it still holds frees them).
  struct Io {
    asio::io_context context;
    asio::steady_timer stop_timer{context};  // ends the context when close() waited long enough
    std::thread thread;
  };
  std::unique_ptr<Io> io_;
  std::atomic<bool> stopping_{false};

  // Servo thread <-> I/O thread.
  TripleBuffer<Command> command_;
  TripleBuffer<Sample> sample_;
  std::atomic<bool> force_on_{false};
  std::atomic<int64_t> newest_ns_{0};       // the newest sample's time, for calibrate()
  std::atomic<uint32_t> newest_faults_{0};  // and its faults
  Sample latest_;                           // servo thread: the newest sample read
  Sample last_;                             // I/O thread: the newest sample published
  std::string reported_;                    // I/O thread: the problem logged last ("" while streaming)
  double period_s_ = 0.0;                   // I/O thread: the answers' mean period (exponential average)
  int64_t last_answer_ns_ = 0;

  // open() <- I/O thread: the first session's outcome and the answers timed.
  std::mutex startup_mutex_;
  std::condition_variable startup_cv_;
  Startup startup_ = Startup::Pending;
  std::string startup_error_;
  int answers_ = 0;
  double startup_period_s_ = 0.0;  // s, the answers' period when open() stopped waiting
};

// The version and inventory over HTTP, then the WebSocket on the I/O thread; waits for its first
// answers (which time the rate).
void HaplyDevice::open() {
  if (opened_) return;
  const auto [version, inventory] = query_service(endpoint_);
  if (inventory.inverse3.empty())
    throw Error("Haply Inverse Service " + version.text + " at " + endpoint_.describe() +
                ": no Inverse3 attached (plug it in and power it; the service lists it at /devices)");
  device_id_ = inventory.inverse3.front();
  info_ = inverse3_info(version, endpoint_, inventory, device_id_);

  stopping_ = false;
  startup_ = Startup::Pending;
  startup_error_.clear();
  answers_ = 0;
  startup_period_s_ = 0.0;
  newest_ns_ = 0;
  period_s_ = 0.0;
  last_answer_ns_ = 0;
  io_ = std::make_unique<Io>();
  asio::co_spawn(io_->context, run(), asio::detached);
  io_->thread = std::thread([io = io_.get()] { io->context.run(); });
  std::unique_lock<std::mutex> lock(startup_mutex_);
  startup_cv_.wait_for(lock, kFirstStateTimeout, [this] {
    return startup_ == Startup::Failed || (startup_ == Startup::Running && answers_ >= kRateSamples);
  });
  const Startup how = startup_;
  const std::string why = startup_error_;
  const double period = startup_period_s_;
  lock.unlock();
  if (how != Startup::Running) {
    stop_io();
    throw Error("Haply Inverse Service at " + endpoint_.describe() + ": " +
                (how == Startup::Failed ? why : std::string("no state on the WebSocket within 3 s")));
  }
  info_.rate_hz = period > 0.0 ? 1.0 / period : 1000.0;
  opened_ = true;
}

// Ends the I/O thread: it sends a zero force, reads its answer and closes the WebSocket; a service
// that does not answer in time is left (the context stopped).
void HaplyDevice::stop_io() {
  if (!io_) return;
  stopping_ = true;
  asio::post(io_->context, [io = io_.get()] {
    io->stop_timer.expires_after(kCloseTimeout + kIdleTimeout);
    io->stop_timer.async_wait([io](const beast::error_code& ec) {
      if (!ec) io->context.stop();
    });
  });
  io_->thread.join();
  io_.reset();
}

// Zero force through the I/O thread (its last command), then the WebSocket closed.
void HaplyDevice::close() {
  force_on_ = false;
  stop_io();
  opened_ = false;
}

// The Inverse3 calibrates itself when powered with the grip in its holder; the service streams its
// state once it is ready.
Calibration HaplyDevice::calibrate() {
  Calibration c;
  if (!opened_) {
    c.readiness = Readiness::Failed;
    c.message = "the Haply device is not open";
    return c;
  }
  // Not read(): the servo thread is the triple buffer's one reader.
  const int64_t newest = newest_ns_.load(std::memory_order_acquire);
  const uint32_t faults =
      newest_faults_.load(std::memory_order_acquire) |
      (newest == 0 || monotonic_ns() - newest > kCalibrationFreshNs ? kHardwareCommunication : 0u);
  if (faults == 0) {
    c.readiness = Readiness::Ready;
    c.message = "Inverse3 " + device_id_ + " streaming at " +
                std::to_string(static_cast<int>(info_.rate_hz)) + " Hz (it calibrates itself at power-up)";
  } else {
    c.readiness = Readiness::NeedsOperator;
    c.message = "Inverse3 " + device_id_ + ": " + describe_hardware_faults(faults) +
                "; power-cycle it with the VerseGrip in its holder and check the service";
  }
  return c;
}

// The newest sample; stale (older than a few answer periods) is a communication fault.
HardwareReading HaplyDevice::read() {
  sample_.read(latest_);
  HardwareReading r;
  r.pose.p = latest_.position;
  r.pose.q = latest_.orientation;
  r.velocity = latest_.velocity;
  r.buttons = latest_.buttons;
  r.faults = latest_.faults;
  if (latest_.received_ns == 0 || monotonic_ns() - latest_.received_ns > latest_.stale_ns)
    r.faults |= kHardwareCommunication;
  r.valid = r.faults == 0;
  return r;
}

// The force for the I/O thread's next command; a 3-DoF device renders no torque.
void HaplyDevice::write(const Vec3& force, const Vec3& /*torque*/) {
  Command c;
  c.force = force.allFinite() ? force : Vec3::Zero();
  command_.write(c);
}

// open() learns why the first session failed.
void HaplyDevice::startup_failed(const std::string& why) {
  const std::lock_guard<std::mutex> lock(startup_mutex_);
  if (startup_ != Startup::Pending) return;
  startup_ = Startup::Failed;
  startup_error_ = why;
  startup_cv_.notify_all();
}

// Logs a problem of the I/O thread once, not once per message or attempt.
void HaplyDevice::report(const std::string& problem) {
  if (problem == reported_) return;
  spdlog::warn("haply: {}", problem);
  reported_ = problem;
}

// A state in the project's units, with the answer period's staleness limit.
void HaplyDevice::publish(const haply::State& state, int64_t now_ns) {
  if (last_answer_ns_ != 0) {
    const double dt = static_cast<double>(now_ns - last_answer_ns_) * 1e-9;
    period_s_ = period_s_ == 0.0 ? dt : 0.9 * period_s_ + 0.1 * dt;
  }
  last_answer_ns_ = now_ns;
  last_.position = state.position * kMmPerM;
  last_.velocity = state.velocity * kMmPerM;
  last_.orientation = state.grip ? state.orientation : Quat::Identity();
  last_.buttons = state.buttons;
  last_.faults = 0;
  last_.received_ns = now_ns;
  last_.stale_ns = std::max(kStaleFloorNs, static_cast<int64_t>(kStalePeriods * period_s_ * 1e9));
  sample_.write(last_);
  newest_faults_.store(0, std::memory_order_release);
  newest_ns_.store(now_ns, std::memory_order_release);
}

// The last pose with a fault (the servo thread zeroes the force in the cycle it reads it).
void HaplyDevice::publish_fault(uint32_t faults) {
  last_.faults = faults;
  sample_.write(last_);
  newest_faults_.store(faults, std::memory_order_release);
  last_answer_ns_ = 0;
}

// The I/O thread: sessions until close(). The first one's failure fails open(); after it, a lost
// service is retried every kReconnectEvery.
asio::awaitable<void> HaplyDevice::run() {
  asio::steady_timer wait(co_await asio::this_coro::executor);
  for (bool first = true; !stopping_; first = false) {
    bool lost = false;
    try {
      lost = co_await session(first);
    } catch (const std::exception& e) {
      if (first)
        startup_failed(e.what());
      else
        report(e.what());
      lost = true;
    }
    if (first && startup_ != Startup::Running) {
      startup_failed("the WebSocket closed before answering");
      break;
    }
    if (lost && !stopping_) {
      publish_fault(kHardwareLost);
      wait.expires_after(kReconnectEvery);
      beast::error_code ignored;
      co_await wait.async_wait(asio::redirect_error(asio::use_awaitable, ignored));
    }
  }
  io_->stop_timer.cancel();
}

// One WebSocket session: the inventory, then command -> state until close() or the service goes
// away. Returns true when the service went away (and was not asked to).
asio::awaitable<bool> HaplyDevice::session(bool first) {
  auto executor = co_await asio::this_coro::executor;
  beast::error_code ec;
  // A reconnection asks the service its version again: it may have been replaced meanwhile.
  if (!first) {
    try {
      haply::check_version(haply::parse_version(co_await http_get(endpoint_, "/version")));
    } catch (const Error& e) {
      report(e.what());
      co_return true;
    }
  }
  tcp::resolver resolver(executor);
  const auto hosts = co_await resolver.async_resolve(endpoint_.ws_host, endpoint_.ws_port,
                                                     asio::redirect_error(asio::use_awaitable, ec));
  if (ec) throw Error("cannot resolve " + endpoint_.ws_host + ": " + ec.message());
  websocket::stream<beast::tcp_stream> ws(executor);
  beast::get_lowest_layer(ws).expires_after(kConnectTimeout);
  co_await beast::get_lowest_layer(ws).async_connect(hosts, asio::redirect_error(asio::use_awaitable, ec));
  if (ec) throw Error("WebSocket ws://" + endpoint_.ws_host + ":" + endpoint_.ws_port + ": " + explain(ec));
  beast::get_lowest_layer(ws).expires_never();
  websocket::stream_base::timeout timeouts;
  timeouts.handshake_timeout = kConnectTimeout;
  timeouts.idle_timeout = kIdleTimeout;
  timeouts.keep_alive_pings = false;
  ws.set_option(timeouts);
  ws.read_message_max(1u << 20);
  co_await ws.async_handshake(endpoint_.ws_host + ":" + endpoint_.ws_port, "/",
                              asio::redirect_error(asio::use_awaitable, ec));
  if (ec)
    throw Error("WebSocket handshake with ws://" + endpoint_.ws_host + ":" + endpoint_.ws_port + ": " +
                explain(ec));
  ws.text(true);

  // The inventory: our Inverse3 must be in it.
  beast::flat_buffer buffer;
  co_await ws.async_read(buffer, asio::redirect_error(asio::use_awaitable, ec));
  if (ec) throw Error("the WebSocket closed before the inventory: " + explain(ec));
  const std::string inventory_text = beast::buffers_to_string(buffer.data());
  buffer.consume(buffer.size());
  std::string error;
  bool absent = false;
  {
    const haply::Inventory inventory = haply::parse_inventory(inventory_text);
    if (std::find(inventory.inverse3.begin(), inventory.inverse3.end(), device_id_) ==
        inventory.inverse3.end())
      throw Error("Inverse3 " + device_id_ + " is not in the WebSocket's inventory");
  }
  if (auto state = haply::parse_state(inventory_text, device_id_, error, absent))
    publish(*state, monotonic_ns());

  // The exchange: the newest force (zero while force is off or closing), then one state.
  Command command;
  bool closing = false;
  for (;;) {
    closing = stopping_.load();
    command_.read(command);
    const Vec3 force = force_on_.load(std::memory_order_acquire) && !closing ? command.force : Vec3::Zero();
    const std::string out = haply::force_command(device_id_, force);
    co_await ws.async_write(asio::buffer(out), asio::redirect_error(asio::use_awaitable, ec));
    if (!ec) co_await ws.async_read(buffer, asio::redirect_error(asio::use_awaitable, ec));
    if (ec) {
      if (closing) co_return false;
      report("the Inverse Service went away (" + explain(ec) + "); reconnecting");
      co_return true;
    }
    const int64_t now = monotonic_ns();
    const std::string message = beast::buffers_to_string(buffer.data());
    buffer.consume(buffer.size());
    if (auto state = haply::parse_state(message, device_id_, error, absent)) {
      publish(*state, now);
      if (!reported_.empty()) {
        spdlog::info("haply: Inverse3 {} streaming again at {}", device_id_, endpoint_.describe());
        reported_.clear();
      }
      if (first && answers_ < kRateSamples) {  // open() waits for these, which time the rate
        const std::lock_guard<std::mutex> lock(startup_mutex_);
        ++answers_;
        startup_period_s_ = period_s_;
        if (startup_ == Startup::Pending) startup_ = Startup::Running;
        startup_cv_.notify_all();
      }
    } else {
      publish_fault(absent ? kHardwareLost : kHardwareOther);
      report(error);
    }
    if (closing) break;
  }
  ws.set_option(websocket::stream_base::timeout{kCloseTimeout, kCloseTimeout, false});
  co_await ws.async_close(websocket::close_code::normal, asio::redirect_error(asio::use_awaitable, ec));
  co_return false;
}

}  // namespace

std::unique_ptr<HardwareDevice> make_haply_device(std::string_view url) {
  const char* env = std::getenv("CARIESIM_HAPLY_URL");
  return std::make_unique<HaplyDevice>(haply::parse_endpoint(url.empty() && env != nullptr ? env : url));
}

// The version and the attached Inverse3s of the service (CARIESIM_HAPLY_URL, else the defaults).
HardwareSurvey survey_haply() {
  HardwareSurvey s;
  s.backend = "haply";
  s.sdk.what = "Haply Inverse Service";
  s.sdk.env_var = "CARIESIM_HAPLY_URL";
  s.install = kInstall;
  try {
    const char* env = std::getenv("CARIESIM_HAPLY_URL");
    const haply::Endpoint e = haply::parse_endpoint(env != nullptr ? env : "");
    try {
      const auto [version, inventory] = query_service(e);
      s.sdk.path = e.describe();
      s.version = version.text;
      for (const std::string& id : inventory.inverse3)
        s.devices.push_back(inverse3_info(version, e, inventory, id));
      if (inventory.inverse3.empty()) s.problem = "no Inverse3 attached to the service";
    } catch (const Error& ex) {
      s.sdk.tried.emplace_back(e.describe(), ex.what());
      s.problem = ex.what();
    }
  } catch (const Error& ex) {
    s.problem = ex.what();
  }
  return s;
}

}  // namespace cariesim

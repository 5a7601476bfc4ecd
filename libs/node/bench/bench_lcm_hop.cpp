// One LCM hop between two processes on loopback: a ROBOT_SENSORS-sized message (27 joints) sent at
// 1 kHz, one-way latency measured with CLOCK_MONOTONIC (shared by both processes).
//
//   bench_lcm_hop [--count N] [--rate HZ] [--joints N]
//
// Three modes, each N messages:
//   raw     LCM's own cost: pre-encoded bytes published with lcm_publish, read through liblcm's
//           receive thread, timestamped on arrival.
//   typed   the stack's path: fill robot_sensors_t, Output::publish (encode and sign), Runtime
//           Input (read from the Runtime's own socket, hpr/node/udpm.hpp; check the code, decode,
//           validate, callback), timestamped in the callback.
//   typed-liblcm  the same with the Runtime reading through liblcm (lcm.receive: liblcm).
// Prints median, p99 and max per mode. Then the same three as ping-pong, back to back (the next
// message leaves when the echo is back, as liblcm's own latency figures are taken): the other
// process echoes each message (raw: the bytes; typed: decoded, validated and re-encoded), and half
// the round trip is one hop with both processes awake.
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <cstring>
#include <functional>
#include <memory>
#include <humanoid/robot_sensors_t.hpp>
#include <vector>

#include "hpr/common/stats.hpp"
#include "hpr/node/lcm_url.hpp"
#include "hpr/node/runtime.hpp"

namespace {

// The bench's channels, and what its processes read and write.
constexpr hpr::Channel<humanoid::robot_sensors_t> kHop{"BENCH_HOP"}, kPing{"PING"}, kPong{"PONG"};
constexpr hpr::Read kBenchReads[] = {{"BENCH_HOP", 0, false, false, "the hop measured"},
                                     {"PING", 0, false, false, "the echo's input"},
                                     {"PONG", 0, false, false, "the echo"}};
constexpr std::string_view kBenchWrites[] = {"PING", "PONG"};
constexpr hpr::Ports kBenchPorts{.name = "bench_lcm_hop", .reads = kBenchReads, .writes = kBenchWrites};

enum class Mode { kRaw, kTyped, kTypedLiblcm };
const char* name(Mode m) { return m == Mode::kRaw ? "raw" : m == Mode::kTyped ? "typed" : "typed-liblcm"; }
hpr::node::RuntimeOptions options(Mode m) {
  hpr::node::RuntimeOptions o;
  o.receive_direct = m == Mode::kTyped;
  return o;
}

std::int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec * 1000000000LL + ts.tv_nsec;
}

humanoid::robot_sensors_t make_message(int joints) {
  humanoid::robot_sensors_t m{};
  m.num_joints = joints;
  for (int i = 0; i < joints; ++i) m.joint_name.push_back("joint_" + std::to_string(i) + "_pitch");
  m.q.assign(static_cast<size_t>(joints), 0.1);
  m.qd.assign(static_cast<size_t>(joints), 0.2);
  m.tau.assign(static_cast<size_t>(joints), 0.3);
  m.drive_status.assign(static_cast<size_t>(joints), 1);
  m.imu_quat_WB[0] = 1;
  m.num_ft = 2;
  m.ft_name = {"right_foot", "left_foot"};
  m.ft_wrench_S.assign(2, std::vector<double>(6, 1.0));
  return m;
}

// Receiver: collects `count` one-way latencies [us] and writes them to `fd`.
void receive(const std::string& url, Mode mode, int count, int fd) {
  std::vector<double> lat;
  lat.reserve(static_cast<size_t>(count));
  if (mode != Mode::kRaw) {
    hpr::node::Runtime rt(kBenchPorts, "bench_rx", url, options(mode));
    rt.subscribe(
        kHop,
        [](const humanoid::robot_sensors_t& m) { return m.num_joints == 27 ? std::string() : std::string("size"); },
        [&](const humanoid::robot_sensors_t& m) { lat.push_back(static_cast<double>(now_ns() - m.utime) * 1e-3); });
    rt.spin_until([&] { return static_cast<int>(lat.size()) >= count; }, 3.0 * count / 1000.0 + 10.0);
  } else {
    lcm::LCM lcm(url);
    struct H {
      std::vector<double>* lat;
      void on(const lcm::ReceiveBuffer* rb, const std::string&) {
        const std::int64_t t = now_ns();
        std::int64_t sent = 0;
        std::memcpy(&sent, static_cast<const char*>(rb->data) + rb->data_size - 8, 8);
        lat->push_back(static_cast<double>(t - sent) * 1e-3);
      }
    } h{&lat};
    lcm.subscribe("BENCH_HOP_RAW", &H::on, &h);
    const std::int64_t end = now_ns() + static_cast<std::int64_t>((3.0 * count / 1000.0 + 10.0) * 1e9);
    while (static_cast<int>(lat.size()) < count && now_ns() < end) lcm.handleTimeout(100);
  }
  const auto bytes = static_cast<ssize_t>(lat.size() * sizeof(double));
  if (write(fd, lat.data(), static_cast<size_t>(bytes)) != bytes) _exit(1);
  _exit(0);
}

void send(const std::string& url, Mode mode, int count, double rate, int joints) {
  lcm::LCM lcm(url);
  // Signed with the deployment's key and stamped with a source, as every process publishes it.
  const hpr::auth::Key key = hpr::auth::load_key(hpr::auth::key_path());
  auto out = hpr::node::Output<humanoid::robot_sensors_t>(&lcm, "BENCH_HOP", &key, 1);
  humanoid::robot_sensors_t m = make_message(joints);
  std::vector<std::uint8_t> raw(static_cast<size_t>(m.getEncodedSize()) + 8);
  m.encode(raw.data(), 0, m.getEncodedSize());
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  const long period_ns = static_cast<long>(1e9 / rate);
  for (int k = 0; k < count + 200; ++k) {  // a few extra in case of loss
    next.tv_nsec += period_ns;
    while (next.tv_nsec >= 1000000000L) {
      next.tv_nsec -= 1000000000L;
      ++next.tv_sec;
    }
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
    if (mode != Mode::kRaw) {
      m.tick = k;
      m.utime = now_ns();
      m.q[0] = 0.001 * k;
      out.publish(m);
    } else {
      const std::int64_t t = now_ns();
      std::memcpy(raw.data() + raw.size() - 8, &t, 8);
      lcm.publish("BENCH_HOP_RAW", raw.data(), static_cast<unsigned>(raw.size()));
    }
  }
}

void run(const std::string& url, Mode mode, int count, double rate, int joints) {
  int fds[2];
  if (pipe(fds) != 0) return;
  const pid_t child = fork();
  if (child == 0) {
    close(fds[0]);
    receive(url, mode, count, fds[1]);
  }
  close(fds[1]);
  usleep(300000);  // let the receiver subscribe
  send(url, mode, count, rate, joints);
  std::vector<double> lat(static_cast<size_t>(count));
  size_t got = 0;
  while (got < lat.size() * sizeof(double)) {
    const ssize_t n = read(fds[0], reinterpret_cast<char*>(lat.data()) + got, lat.size() * sizeof(double) - got);
    if (n <= 0) break;
    got += static_cast<size_t>(n);
  }
  lat.resize(got / sizeof(double));
  int status = 0;
  waitpid(child, &status, 0);
  humanoid::robot_sensors_t m = make_message(joints);
  std::printf("%-12s %6zu msgs of %5d bytes: one-way median %7.1f us  p99 %7.1f us  max %8.1f us\n",
              name(mode), lat.size(), m.getEncodedSize(), hpr::percentile(lat, 0.5),
              hpr::percentile(lat, 0.99), hpr::percentile(lat, 1.0));
  std::fflush(stdout);
}

/// Echoes PING as PONG until `count` messages went back (raw bytes, or through the Runtime typed).
void echo(const std::string& url, Mode mode, int count) {
  int n = 0;
  if (mode != Mode::kRaw) {
    hpr::node::Runtime rt(kBenchPorts, "bench_echo", url, options(mode));
    auto out = rt.advertise(kPong);
    rt.subscribe(
        kPing, [](const humanoid::robot_sensors_t& m) { return m.num_joints > 0 ? std::string() : std::string("size"); },
        [&](const humanoid::robot_sensors_t& m) {
          out.publish(m);
          ++n;
        });
    rt.spin_until([&] { return n >= count; }, 30.0 + count * 1e-3);
  } else {
    lcm::LCM lcm(url);
    struct H {
      lcm::LCM* lcm;
      int* n;
      void on(const lcm::ReceiveBuffer* rb, const std::string&) {
        lcm->publish("PONG", rb->data, rb->data_size);
        ++*n;
      }
    } h{&lcm, &n};
    lcm.subscribe("PING", &H::on, &h);
    const std::int64_t end = now_ns() + static_cast<std::int64_t>((30.0 + count * 1e-3) * 1e9);
    while (n < count && now_ns() < end) lcm.handleTimeout(100);
  }
  _exit(0);
}

void ping_pong(const std::string& url, Mode mode, int count, int joints) {
  const pid_t child = fork();
  if (child == 0) echo(url, mode, count + 100);
  usleep(300000);  // let the echo subscribe
  std::vector<double> rtt;
  rtt.reserve(static_cast<size_t>(count));
  humanoid::robot_sensors_t m = make_message(joints);
  std::int64_t sent = 0;
  bool back = false;
  auto record = [&] {
    rtt.push_back(static_cast<double>(now_ns() - sent) * 1e-3);
    back = true;
  };
  // Typed: this side publishes with Output and receives through a Runtime Input as well.
  std::unique_ptr<hpr::node::Runtime> rt;
  hpr::node::Output<humanoid::robot_sensors_t> out;
  std::unique_ptr<lcm::LCM> raw_lcm;
  struct H {
    std::function<void()> f;
    void on(const lcm::ReceiveBuffer*, const std::string&) { f(); }
  } h{record};
  std::vector<std::uint8_t> raw(static_cast<size_t>(m.getEncodedSize()));
  m.encode(raw.data(), 0, m.getEncodedSize());
  const bool typed = mode != Mode::kRaw;
  if (typed) {
    rt = std::make_unique<hpr::node::Runtime>(kBenchPorts, "bench_ping", url, options(mode));
    out = rt->advertise(kPing);
    rt->subscribe(kPong, {}, [&](const humanoid::robot_sensors_t&) { record(); });
  } else {
    raw_lcm = std::make_unique<lcm::LCM>(url);
    raw_lcm->subscribe("PONG", &H::on, &h);
  }
  for (int k = 0; k < count + 100; ++k) {  // the first 100 warm up
    back = false;
    sent = now_ns();
    if (typed) {
      m.tick = k;
      out.publish(m);
      rt->spin_until([&] { return back; }, 1.0);
    } else {
      raw_lcm->publish("PING", raw.data(), static_cast<unsigned>(raw.size()));
      const std::int64_t end = sent + 1000000000LL;
      while (!back && now_ns() < end) raw_lcm->handleTimeout(100);
    }
    if (k == 99) rtt.clear();
  }
  int status = 0;
  waitpid(child, &status, 0);
  std::printf("%-12s %6zu ping-pongs of %5d bytes: half round trip median %7.1f us  p99 %7.1f us  (round trip median %7.1f us)\n",
              name(mode), rtt.size(), m.getEncodedSize(), 0.5 * hpr::percentile(rtt, 0.5),
              0.5 * hpr::percentile(rtt, 0.99), hpr::percentile(rtt, 0.5));
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  int count = 10000, joints = 27;
  double rate = 1000.0;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--count") count = std::atoi(argv[i + 1]);
    else if (a == "--rate") rate = std::atof(argv[i + 1]);
    else if (a == "--joints") joints = std::atoi(argv[i + 1]);
  }
  const std::string url = hpr::node::resolve_lcm_url("", "");
  try {
    hpr::node::check_multicast_route(url);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 3;
  }
  std::printf("LCM %s, %d messages at %.0f Hz per mode\n", url.c_str(), count, rate);
  for (const Mode mode : {Mode::kRaw, Mode::kTyped, Mode::kTypedLiblcm}) run(url, mode, count, rate, joints);
  for (const Mode mode : {Mode::kRaw, Mode::kTyped, Mode::kTypedLiblcm}) ping_pong(url, mode, count, joints);
  return 0;
}

#include "link/delay_relay.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sched.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <functional>
#include <iostream>
#include <sstream>
#include <stdexcept>

namespace dysa::testing {

using Clock = std::chrono::steady_clock;

namespace {

constexpr size_t kReadSize = size_t(256) << 10;
constexpr double kMaxDelayMs = 10000;
constexpr int kMaxQueueMib = 1024;
constexpr double kMaxRateMbit = 1e5;
// A rate-limited direction sends at most this much at once: 16 KiB take 1.3 ms at 100 Mbit/s,
// so the pacing is as smooth as a token bucket of that burst.
constexpr size_t kPaceSlice = size_t(16) << 10;

std::string Errno(const std::string& what) { return what + ": " + std::strerror(errno); }

// Opens /var/run/netns/NAME (as `ip netns add NAME` makes it); -1 for "".
int OpenNetns(const std::string& name) {
  if (name.empty()) return -1;
  const std::string path = "/var/run/netns/" + name;
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw std::runtime_error(Errno("network namespace " + name + " (" + path + ")"));
  return fd;
}

// Runs `body` on a thread inside the namespace `netns_fd` (a thread's network namespace is its
// own: the caller's stays as it was), or on the calling thread for -1. Sockets keep the
// namespace they were made in.
void RunInNetns(int netns_fd, const std::string& name, const std::function<void()>& body) {
  if (netns_fd < 0) return body();
  std::string error;
  std::exception_ptr thrown;
  std::thread([&] {
    if (setns(netns_fd, CLONE_NEWNET) != 0) {
      error = Errno("entering network namespace " + name + " (setns; needs root)");
      return;
    }
    try {
      body();
    } catch (...) {
      thrown = std::current_exception();
    }
  }).join();
  if (!error.empty()) throw std::runtime_error(error);
  if (thrown) std::rethrow_exception(thrown);
}

struct AddrInfoDeleter {
  void operator()(addrinfo* a) const { freeaddrinfo(a); }
};

std::unique_ptr<addrinfo, AddrInfoDeleter> Resolve(const std::string& host, int port,
                                                   bool passive) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_NUMERICSERV | (passive ? AI_PASSIVE : 0);
  addrinfo* result = nullptr;
  const int rc = getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &result);
  if (rc != 0) {
    throw std::runtime_error("cannot resolve " + host + ": " + gai_strerror(rc));
  }
  return std::unique_ptr<addrinfo, AddrInfoDeleter>(result);
}

void SetNoDelay(int fd) {
  const int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
}

// A connected socket to host:port, or -1 (with `error` set).
int ConnectTo(const std::string& host, int port, std::string& error) {
  try {
    auto addresses = Resolve(host, port, false);
    for (addrinfo* a = addresses.get(); a; a = a->ai_next) {
      const int fd = socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
      if (fd < 0) {
        error = Errno("socket");
        continue;
      }
      if (connect(fd, a->ai_addr, a->ai_addrlen) == 0) return fd;
      error = Errno("connect to " + host + ":" + std::to_string(port));
      close(fd);
    }
  } catch (const std::exception& e) {
    error = e.what();
  }
  return -1;
}

// "HOST:PORT" or "[HOST]:PORT" into its parts; false (with `error`) when malformed or the port
// is outside [min_port, 65535].
bool ParseHostPort(const std::string& flag, const std::string& value, int min_port,
                   std::string& host, int& port, std::string& error) {
  const std::string range = " (allowed: HOST:PORT, the port " + std::to_string(min_port) +
                            " to 65535; an IPv6 host in brackets)";
  const size_t colon = value.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == value.size()) {
    error = flag + ": expected HOST:PORT, got '" + value + "'" + range;
    return false;
  }
  host = value.substr(0, colon);
  if (host.front() == '[') {
    if (host.size() < 3 || host.back() != ']') {
      error = flag + ": unbalanced brackets in '" + value + "'" + range;
      return false;
    }
    host = host.substr(1, host.size() - 2);
  } else if (host.find(':') != std::string::npos) {
    error = flag + ": an IPv6 host needs brackets, got '" + value + "'" + range;
    return false;
  }
  const std::string digits = value.substr(colon + 1);
  long long parsed = -1;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), parsed);
  if (ec != std::errc() || end != digits.data() + digits.size()) {
    error = flag + ": port '" + digits + "' is not a number" + range;
    return false;
  }
  if (parsed < min_port || parsed > 65535) {
    error = flag + ": port " + digits + " is out of range" + range;
    return false;
  }
  port = int(parsed);
  return true;
}

bool ParseNumber(const std::string& flag, const std::string& value, double lo, double hi,
                 const std::string& unit, double& out, std::string& error) {
  std::ostringstream range;
  range << " (allowed: " << lo << " to " << hi << unit << ")";
  double parsed = 0;
  const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), parsed);
  if (value.empty() || ec != std::errc() || end != value.data() + value.size()) {
    error = flag + ": '" + value + "' is not a number" + range.str();
    return false;
  }
  if (!(parsed >= lo && parsed <= hi)) {
    error = flag + ": " + value + " is out of range" + range.str();
    return false;
  }
  out = parsed;
  return true;
}

bool ParseNetnsName(const std::string& flag, const std::string& value, std::string& out,
                    std::string& error) {
  if (value.empty() || value == "." || value == ".." || value.find('/') != std::string::npos) {
    error = flag + ": '" + value +
            "' is not a namespace name (allowed: a name under /var/run/netns, as `ip netns add "
            "NAME` makes it; no '/')";
    return false;
  }
  out = value;
  return true;
}

}  // namespace

std::string RelayUsage() {
  return "usage: dysa-delay-relay --listen HOST:PORT --upstream HOST:PORT --delay-ms N\n"
         "                        [--rate-mbit R] [--listen-netns NAME] [--upstream-netns NAME]\n"
         "                        [--max-queue-mib N] [--port-file PATH]\n"
         "Forwards each TCP connection accepted on --listen to --upstream, both ways, each\n"
         "chunk held N ms (0 to 10000; each way, so the round trip gains 2N). --rate-mbit\n"
         "paces each direction to R Mbit/s (0.1 to 100000; default: unlimited), as a link of\n"
         "that rate serialises its bytes before the delay. --listen's port\n"
         "0 picks a free one (written to --port-file). --listen-netns / --upstream-netns open\n"
         "the listening / upstream sockets in /var/run/netns/NAME (needs root). A direction\n"
         "stops reading while more than --max-queue-mib (1 to 1024, default 16) MiB wait in it.\n"
         "SIGINT or SIGTERM stops it (exit status 0).\n";
}

std::optional<RelayFlags> ParseRelayFlags(const std::vector<std::string>& args,
                                          std::string& error) {
  RelayFlags flags;
  bool have_listen = false, have_upstream = false, have_delay = false;
  for (size_t i = 0; i < args.size(); ++i) {
    std::string flag = args[i], value;
    bool has_value = false;
    if (const size_t eq = flag.find('='); flag.rfind("--", 0) == 0 && eq != std::string::npos) {
      value = flag.substr(eq + 1), flag.resize(eq), has_value = true;
    }
    static const char* const kFlags[] = {"--listen",        "--upstream",     "--delay-ms",
                                         "--rate-mbit",     "--listen-netns", "--upstream-netns",
                                         "--max-queue-mib", "--port-file"};
    if (std::find(std::begin(kFlags), std::end(kFlags), flag) == std::end(kFlags)) {
      error = "unknown argument '" + args[i] + "'";
      return std::nullopt;
    }
    if (!has_value) {
      if (i + 1 >= args.size()) {
        error = flag + ": missing its value";
        return std::nullopt;
      }
      value = args[++i];
    }
    RelayOptions& o = flags.options;
    bool ok = true;
    if (flag == "--listen") {
      ok = ParseHostPort(flag, value, 0, o.listen_host, o.listen_port, error);
      have_listen = true;
    } else if (flag == "--upstream") {
      ok = ParseHostPort(flag, value, 1, o.upstream_host, o.upstream_port, error);
      have_upstream = true;
    } else if (flag == "--delay-ms") {
      double ms = 0;
      ok = ParseNumber(flag, value, 0, kMaxDelayMs, " ms", ms, error);
      o.delay = std::chrono::microseconds(int64_t(ms * 1000 + 0.5));
      have_delay = true;
    } else if (flag == "--rate-mbit") {
      double mbit = 0;
      ok = ParseNumber(flag, value, 0.1, kMaxRateMbit, " Mbit/s", mbit, error);
      o.rate_bits_per_second = mbit * 1e6;
    } else if (flag == "--listen-netns") {
      ok = ParseNetnsName(flag, value, o.listen_netns, error);
    } else if (flag == "--upstream-netns") {
      ok = ParseNetnsName(flag, value, o.upstream_netns, error);
    } else if (flag == "--max-queue-mib") {
      double mib = 0;
      ok = ParseNumber(flag, value, 1, kMaxQueueMib, " MiB", mib, error);
      if (ok && mib != double(int64_t(mib))) {
        error = flag + ": " + value + " is not a whole number (allowed: 1 to 1024 MiB)";
        ok = false;
      }
      o.max_queued_bytes = size_t(mib) << 20;
    } else if (flag == "--port-file") {
      flags.port_file = value;
      if (value.empty()) error = flag + ": an empty path", ok = false;
    }
    if (!ok) return std::nullopt;
  }
  if (!have_listen) error = "--listen HOST:PORT is required";
  if (!have_upstream) error = "--upstream HOST:PORT is required";
  if (!have_delay) error = "--delay-ms N is required (allowed: 0 to 10000 ms)";
  if (!have_listen || !have_upstream || !have_delay) return std::nullopt;
  return flags;
}

// One accepted connection: two directions, each a reader thread (reads a chunk, stamps it
// due = now + delay, queues it) and a writer thread (writes each chunk when it is due).
struct DelayRelay::Connection {
  struct Chunk {
    Clock::time_point due;
    std::vector<char> data;
    bool eof = false;  // the sender closed (or the read failed): forward the close
  };
  struct Direction {
    int from = -1, to = -1;
    std::mutex mu;
    std::condition_variable cv;
    std::deque<Chunk> queue;
    size_t queued = 0;  // bytes in `queue` and the chunk being written
    bool stop = false;
    Clock::time_point paced_until{};  // rate-limited: when the link finishes the last slice
  };

  Connection(int client, int upstream, const RelayOptions& o, std::atomic<size_t>& peak)
      : client_fd(client),
        upstream_fd(upstream),
        delay(o.delay),
        rate(o.rate_bits_per_second),
        max_queued(o.max_queued_bytes),
        peak_queued(peak) {
    up.from = client, up.to = upstream;
    down.from = upstream, down.to = client;
    for (Direction* d : {&up, &down}) {
      threads.emplace_back([this, d] { Read(*d); });
      threads.emplace_back([this, d] { Write(*d); });
    }
  }
  ~Connection() {
    Abort();
    for (std::thread& t : threads) t.join();
    close(client_fd);
    close(upstream_fd);
  }

  // Closes both sides at once (an error, or the relay stops): blocked reads and writes return.
  void Abort() {
    for (Direction* d : {&up, &down}) {
      std::lock_guard lock(d->mu);
      d->stop = true;
      d->cv.notify_all();
    }
    shutdown(client_fd, SHUT_RDWR);
    shutdown(upstream_fd, SHUT_RDWR);
  }

  void Read(Direction& d) {
    std::vector<char> buffer(kReadSize);
    for (;;) {
      {
        std::unique_lock lock(d.mu);
        // Backpressure: while the queue is full the socket is not read, so its receive buffer
        // fills and TCP's window closes on the sender.
        d.cv.wait(lock, [&] { return d.stop || d.queued <= max_queued; });
        if (d.stop) break;
      }
      const ssize_t n = recv(d.from, buffer.data(), buffer.size(), 0);
      if (n < 0 && errno == EINTR) continue;
      Chunk chunk;
      chunk.due = Clock::now() + delay;
      if (n > 0) {
        chunk.data.assign(buffer.data(), buffer.data() + n);
      } else {
        chunk.eof = true;
      }
      {
        std::lock_guard lock(d.mu);
        d.queued += chunk.data.size();
        d.queue.push_back(std::move(chunk));
        size_t peak = peak_queued;
        while (d.queued > peak && !peak_queued.compare_exchange_weak(peak, d.queued)) {
        }
      }
      d.cv.notify_all();
      if (n <= 0) break;
    }
    Finished();
  }

  void Write(Direction& d) {
    for (;;) {
      Chunk chunk;
      {
        std::unique_lock lock(d.mu);
        d.cv.wait(lock, [&] { return d.stop || !d.queue.empty(); });
        if (d.stop) break;
        const Clock::time_point due = d.queue.front().due;  // only this thread pops
        d.cv.wait_until(lock, due, [&] { return d.stop || Clock::now() >= due; });
        if (d.stop) break;
        chunk = std::move(d.queue.front());
        d.queue.pop_front();
      }
      if (chunk.eof) {
        shutdown(d.to, SHUT_WR);  // the close, as late as the bytes before it
        break;
      }
      if (!Send(d, chunk)) {  // the receiver went (reset) or the relay stops: close both sides
        Abort();
        break;
      }
      {
        std::lock_guard lock(d.mu);
        d.queued -= chunk.data.size();
      }
      d.cv.notify_all();
    }
    Finished();
  }

  // Writes the chunk; rate-limited, slice by slice, each when a link of that rate that took it
  // at its due time (or when it finished the slice before) would deliver it:
  // t_k = max(due, t_(k-1)) + bits_k / rate. False if the receiver went or the relay stops.
  bool Send(Direction& d, const Chunk& chunk) {
    const size_t slice = rate > 0 ? kPaceSlice : chunk.data.size();
    for (size_t start = 0; start < chunk.data.size(); start += slice) {
      const size_t size = std::min(slice, chunk.data.size() - start);
      if (rate > 0) {
        const auto transmit = std::chrono::duration_cast<Clock::duration>(
            std::chrono::duration<double>(double(size) * 8 / rate));
        const Clock::time_point at = std::max(chunk.due, d.paced_until) + transmit;
        d.paced_until = at;
        std::unique_lock lock(d.mu);
        if (d.cv.wait_until(lock, at, [&] { return d.stop; })) return false;
      }
      size_t done = 0;
      while (done < size) {
        const ssize_t n = send(d.to, chunk.data.data() + start + done, size - done, MSG_NOSIGNAL);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return false;
        done += size_t(n);
      }
    }
    return true;
  }

  void Finished() { --running; }
  bool done() const { return running == 0; }

  const int client_fd, upstream_fd;
  const std::chrono::microseconds delay;
  const double rate;  // bit/s, 0: unlimited
  const size_t max_queued;
  std::atomic<size_t>& peak_queued;  // the relay's
  Direction up, down;
  std::atomic<int> running{4};
  std::vector<std::thread> threads;
};

DelayRelay::DelayRelay(const RelayOptions& options) : options_(options) {
  if (options.delay < std::chrono::microseconds(0)) {
    throw std::runtime_error("the delay must not be negative");
  }
  if (!(options.rate_bits_per_second >= 0)) {
    throw std::runtime_error("the rate must be 0 (unlimited) or positive");
  }
  int listen_netns_fd = -1;
  try {
    listen_netns_fd = OpenNetns(options.listen_netns);
    upstream_netns_fd_ = OpenNetns(options.upstream_netns);
    // Fails here, not at the first connection, where the upstream namespace cannot be entered.
    RunInNetns(upstream_netns_fd_, options.upstream_netns, [] {});
    RunInNetns(listen_netns_fd, options.listen_netns, [&] {
      auto addresses = Resolve(options.listen_host, options.listen_port, true);
      std::string error = "no address for " + options.listen_host;
      for (addrinfo* a = addresses.get(); a; a = a->ai_next) {
        const int fd = socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
        if (fd < 0) {
          error = Errno("socket");
          continue;
        }
        const int one = 1;
        setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
        if (bind(fd, a->ai_addr, a->ai_addrlen) != 0 || listen(fd, 64) != 0) {
          error = Errno("bind/listen on " + options.listen_host + ":" +
                        std::to_string(options.listen_port));
          close(fd);
          continue;
        }
        listen_fd_ = fd;
        break;
      }
      if (listen_fd_ < 0) throw std::runtime_error(error);
    });
    sockaddr_storage bound{};
    socklen_t length = sizeof bound;
    getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&bound), &length);
    port_ = ntohs(bound.ss_family == AF_INET6 ? reinterpret_cast<sockaddr_in6*>(&bound)->sin6_port
                                              : reinterpret_cast<sockaddr_in*>(&bound)->sin_port);
    if (pipe2(wake_fds_, O_CLOEXEC) != 0) throw std::runtime_error(Errno("pipe"));
  } catch (...) {
    if (listen_netns_fd >= 0) close(listen_netns_fd);
    if (upstream_netns_fd_ >= 0) close(upstream_netns_fd_);
    if (listen_fd_ >= 0) close(listen_fd_);
    throw;
  }
  if (listen_netns_fd >= 0) close(listen_netns_fd);
  acceptor_ = std::thread([this] { AcceptLoop(); });
}

DelayRelay::~DelayRelay() { Stop(); }

size_t DelayRelay::open_connections() const {
  std::lock_guard lock(mu_);
  size_t open = 0;
  for (const auto& c : connections_) open += c->done() ? 0 : 1;
  return open;
}

void DelayRelay::Stop() {
  std::call_once(stopped_, [this] {
    stopping_ = true;
    const char byte = 0;
    [[maybe_unused]] const ssize_t n = write(wake_fds_[1], &byte, 1);
    acceptor_.join();
    Reap(true);
    close(listen_fd_);
    close(wake_fds_[0]);
    close(wake_fds_[1]);
    if (upstream_netns_fd_ >= 0) close(upstream_netns_fd_);
  });
}

void DelayRelay::Reap(bool all) {
  std::list<std::unique_ptr<Connection>> finished;
  {
    std::lock_guard lock(mu_);
    for (auto it = connections_.begin(); it != connections_.end();) {
      if (all || (*it)->done()) {
        finished.push_back(std::move(*it));
        it = connections_.erase(it);
      } else {
        ++it;
      }
    }
  }
  finished.clear();  // aborts (a no-op for a finished one), joins and closes, outside the lock
}

void DelayRelay::AcceptLoop() {
  // The upstream connections are made on this thread, inside their namespace.
  if (upstream_netns_fd_ >= 0 && setns(upstream_netns_fd_, CLONE_NEWNET) != 0) {
    std::cerr << Errno("dysa-delay-relay: entering network namespace " + options_.upstream_netns)
              << "\n";
    return;
  }
  while (!stopping_) {
    pollfd fds[2] = {{listen_fd_, POLLIN, 0}, {wake_fds_[0], POLLIN, 0}};
    const int ready = poll(fds, 2, 100);
    Reap(false);
    if (ready <= 0 || stopping_ || !(fds[0].revents & POLLIN)) continue;
    const int client = accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
    if (client < 0) continue;
    std::string error;
    const int upstream = ConnectTo(options_.upstream_host, options_.upstream_port, error);
    if (upstream < 0) {
      std::cerr << "dysa-delay-relay: " << error << "; closing the accepted connection\n";
      close(client);
      continue;
    }
    SetNoDelay(client);
    SetNoDelay(upstream);
    ++accepted_;
    auto connection = std::make_unique<Connection>(client, upstream, options_, peak_queued_);
    std::lock_guard lock(mu_);
    connections_.push_back(std::move(connection));
  }
}

}  // namespace dysa::testing

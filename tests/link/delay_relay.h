// A TCP relay that adds a fixed one-way delay, and optionally a rate limit, for tests of a link
// that is far away (a laptop 10-60 ms from the server) on a kernel without netem. It accepts
// connections on a listen address and, for each, connects to an upstream address and forwards the
// bytes both ways, each chunk held until `delay` after it was read (order kept). Memory is bounded:
// a direction stops reading while more than `max_queued_bytes` wait in it, so TCP's flow control
// pushes back on the sender. A half-close (EOF) is forwarded after the delay like the bytes before
// it; a reset or an error closes both sides. The listening socket may be opened inside one network
// namespace and the upstream connections inside another (/var/run/netns/NAME, as `ip netns add`
// makes them), so the relay can bridge a shaped namespace and an unshaped one.
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace dysa::testing {

struct RelayOptions {
  std::string listen_host = "127.0.0.1";
  int listen_port = 0;  // 0: any free port (see DelayRelay::port())
  std::string upstream_host = "127.0.0.1";
  int upstream_port = 0;
  std::chrono::microseconds delay{0};  // each way
  // bit/s each way, 0: unlimited. A rate-limited direction forwards its bytes as a link of that
  // rate would (serialised in slices, then delayed): a shaped link without tc, e.g. where no
  // iproute2 is installed.
  double rate_bits_per_second = 0;
  std::string listen_netns;                    // "" : the caller's namespace
  std::string upstream_netns;                  // "" : the caller's namespace
  size_t max_queued_bytes = size_t(16) << 20;  // per direction of a connection
};

// The flags of dysa-delay-relay (--listen HOST:PORT, --upstream HOST:PORT, --delay-ms N,
// --rate-mbit R, --listen-netns NAME, --upstream-netns NAME, --max-queue-mib N,
// --port-file PATH). Returns
// nullopt and sets `error` (naming the flag and what it allows) on a bad or missing flag.
struct RelayFlags {
  RelayOptions options;
  std::string port_file;
};
std::optional<RelayFlags> ParseRelayFlags(const std::vector<std::string>& args, std::string& error);
// The usage text, for --help and errors.
std::string RelayUsage();

class DelayRelay {
 public:
  // Opens the listening socket and starts accepting; throws std::runtime_error (saying what
  // failed: a namespace, the address, bind) when it cannot.
  explicit DelayRelay(const RelayOptions& options);
  ~DelayRelay();
  DelayRelay(const DelayRelay&) = delete;
  DelayRelay& operator=(const DelayRelay&) = delete;

  // The port it listens on.
  int port() const { return port_; }
  // Connections accepted so far, and those still open.
  uint64_t accepted() const { return accepted_; }
  size_t open_connections() const;
  // The most bytes that ever waited in one direction of a connection (at most
  // max_queued_bytes plus one read).
  size_t peak_queued_bytes() const { return peak_queued_; }
  // Stops accepting, closes every connection (both sides) and joins its threads. Idempotent.
  void Stop();

 private:
  struct Connection;
  void AcceptLoop();
  void Reap(bool all);

  RelayOptions options_;
  int listen_fd_ = -1;
  int wake_fds_[2] = {-1, -1};  // Stop() writes to [1] to wake the accept loop
  int upstream_netns_fd_ = -1;
  int port_ = 0;
  std::atomic<bool> stopping_{false};
  std::atomic<uint64_t> accepted_{0};
  std::atomic<size_t> peak_queued_{0};
  mutable std::mutex mu_;
  std::list<std::unique_ptr<Connection>> connections_;  // guarded by mu_
  std::thread acceptor_;
  std::once_flag stopped_;
};

}  // namespace dysa::testing

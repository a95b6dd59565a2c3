// A listening dysa.v1.Simulation server around a SimulationHost: the gRPC wiring shared by
// dysa-server and the integration tests.
#pragma once

#include <chrono>
#include <memory>
#include <string>

#include "dysa/service/simulation_host.h"

namespace grpc {
class Server;
}

namespace dysa::service {

class SimulationService;

struct ServerOptions {
  std::string listen = "127.0.0.1:50051";  // ADDR:PORT; port 0 picks a free port
  std::string token;                       // empty: no token needed
  bool protect_watch = false;              // the token guards reading RPCs and streams too
  std::string tls_cert_pem;                // both set: TLS; both empty: plaintext
  std::string tls_key_pem;
  int max_receive_bytes = 4 << 20;  // largest request (a LoadScene text); RESOURCE_EXHAUSTED above
};

class Server {
 public:
  // Starts listening and the host's simulation thread. Throws std::runtime_error when the
  // address cannot be bound.
  Server(SimulationHost& host, const ServerOptions& options);
  ~Server();  // Shutdown()

  int port() const { return port_; }
  // Ends every frame stream with UNAVAILABLE, answers queued controls UNAVAILABLE, stops the
  // simulation thread at its next step boundary, then stops accepting calls and cancels those
  // still in flight at `deadline` (a stream's write to a stalled reader). Returns false, without
  // shutting gRPC down, when the simulation thread is still inside a solver step at `deadline`:
  // a step cannot be interrupted, so a process that must end then exits without waiting
  // (dysa-server does). Idempotent: later calls return the first one's result.
  bool Shutdown(std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::now() +
                                                                 std::chrono::seconds(2));

 private:
  SimulationHost& host_;
  std::unique_ptr<SimulationService> service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
  bool shut_down_ = false;
  bool stopped_ = false;  // the first Shutdown's result
};

}  // namespace dysa::service

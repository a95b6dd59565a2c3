#include "dysa/service/server.h"

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <stdexcept>

#include "simulation_service.h"

namespace dysa::service {

Server::Server(SimulationHost& host, const ServerOptions& options) : host_(host) {
  service_ =
      std::make_unique<SimulationService>(host, AccessPolicy{options.token, options.protect_watch});
  std::shared_ptr<grpc::ServerCredentials> credentials;
  if (!options.tls_cert_pem.empty() || !options.tls_key_pem.empty()) {
    grpc::SslServerCredentialsOptions ssl;
    ssl.pem_key_cert_pairs.push_back({options.tls_key_pem, options.tls_cert_pem});
    credentials = grpc::SslServerCredentials(ssl);
  } else {
    credentials = grpc::InsecureServerCredentials();
  }
  grpc::ServerBuilder builder;
  builder.AddListeningPort(options.listen, credentials, &port_);
  builder.RegisterService(service_.get());
  builder.SetMaxReceiveMessageSize(options.max_receive_bytes);
  server_ = builder.BuildAndStart();
  if (!server_ || port_ == 0) {
    throw std::runtime_error("cannot listen on " + options.listen +
                             " (address in use, not local, or malformed ADDR:PORT)");
  }
  host_.Start();
}

Server::~Server() { Shutdown(); }

void Server::Shutdown(int grace_ms) {
  if (shut_down_) return;
  shut_down_ = true;
  host_.hub().Close();
  host_.Stop();
  server_->Shutdown(std::chrono::system_clock::now() + std::chrono::milliseconds(grace_ms));
  server_->Wait();
}

}  // namespace dysa::service

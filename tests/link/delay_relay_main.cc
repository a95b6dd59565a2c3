// dysa-delay-relay: a TCP relay that adds a fixed one-way delay (tests/link/delay_relay.h), for
// tests and manual runs of a link far away. Runs until SIGINT or SIGTERM, then closes every
// connection and exits 0; a bad flag exits 2 naming the flag and its allowed range.
#include <signal.h>

#include <cstdio>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "link/delay_relay.h"

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  for (const std::string& a : args) {
    if (a == "--help" || a == "-h") {
      std::cout << dysa::testing::RelayUsage();
      return 0;
    }
  }
  std::string error;
  const auto flags = dysa::testing::ParseRelayFlags(args, error);
  if (!flags) {
    std::cerr << "dysa-delay-relay: " << error << "\n" << dysa::testing::RelayUsage();
    return 2;
  }
  // The signals are taken by sigwait below; every thread inherits the mask.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  try {
    dysa::testing::DelayRelay relay(flags->options);
    const auto& o = flags->options;
    if (!flags->port_file.empty()) {
      // Written whole under another name, then renamed: a reader never sees half of it.
      const std::string partial = flags->port_file + ".partial";
      std::ofstream(partial) << relay.port() << "\n";
      if (std::rename(partial.c_str(), flags->port_file.c_str()) != 0) {
        std::cerr << "dysa-delay-relay: --port-file: cannot write " << flags->port_file << "\n";
        return 1;
      }
    }
    std::cerr << "dysa-delay-relay: listening on " << o.listen_host << ":" << relay.port()
              << (o.listen_netns.empty() ? "" : " in " + o.listen_netns) << ", upstream "
              << o.upstream_host << ":" << o.upstream_port
              << (o.upstream_netns.empty() ? "" : " in " + o.upstream_netns) << ", delay "
              << double(o.delay.count()) / 1000 << " ms each way" << std::endl;
    int caught = 0;
    sigwait(&signals, &caught);
    relay.Stop();
    std::cerr << "dysa-delay-relay: stopped (" << relay.accepted() << " connections)" << std::endl;
  } catch (const std::exception& e) {
    std::cerr << "dysa-delay-relay: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

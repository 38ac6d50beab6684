// holofuse_relay: an impairing TCP relay between two hosts of a rig (or two
// network namespaces of one machine) where the kernel has no netem; see
// deploy/include/deploy/link_relay.h.
#include <CLI/CLI.hpp>
#include <cstdio>

#include "base/shutdown.h"
#include "config/command_line.h"
#include "deploy/link_relay.h"

int main(int argc, char** argv) {
  holofuse::deploy::RelayOptions options;
  holofuse::deploy::LinkImpairment& link = options.impairment;
  CLI::App app{"holofuse relay: carries TCP from --listen to --to, delayed, capped and stalled"};
  app.add_option("--listen", options.listen, "HOST:PORT to accept on (port 0: any free port)")
      ->required();
  app.add_option("--to", options.upstream, "HOST:PORT each accepted peer is carried to")
      ->required();
  app.add_option("--delay-ms", link.delay_ms, "one-way delay added to every byte")
      ->check(CLI::Range(0.0, 60000.0));
  app.add_option("--jitter-ms", link.jitter_ms, "uniform jitter around the delay (order kept)")
      ->check(CLI::Range(0.0, 60000.0));
  app.add_option("--rate-mbit", link.rate_mbit, "rate cap of each direction (0: none)")
      ->check(CLI::Range(0.0, 100000.0));
  app.add_option("--stall-every-s", link.stall_every_s,
                 "a stall of every link this often (0: none)")
      ->check(CLI::Range(0.0, 86400.0));
  app.add_option("--stall-ms", link.stall_ms, "how long each stall holds every link")
      ->check(CLI::Range(0.0, 600000.0));
  app.add_option("--seed", link.seed, "seed of the jitter");
  app.add_option("--port-file", options.port_file, "write the port it listens on here");
  HOLOFUSE_PARSE_FLAGS(app, argc, argv)
  if (link.jitter_ms > link.delay_ms) {
    std::fprintf(stderr, "--jitter-ms %g is more than --delay-ms %g: a byte cannot leave early\n",
                 link.jitter_ms, link.delay_ms);
    return 2;
  }
  holofuse::installStopSignals();
  const holofuse::Status status = holofuse::deploy::runRelay(options);
  if (!status.isOk()) {
    std::fprintf(stderr, "[relay] %s\n", status.message().c_str());
    return 1;
  }
  return 0;
}

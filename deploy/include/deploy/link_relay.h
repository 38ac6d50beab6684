// A TCP relay that impairs the link it carries, for kernels without the
// netem qdisc (this machine's): each byte is held for a delay with jitter,
// a rate cap serialises the bytes as a slower link would, and every link
// stalls now and then. The stream's order is kept (TCP never reorders what
// it delivers), so jitter moves each read's release, never past the one
// before it. Loss and reordering of packets need netem; a relay sees only
// the byte stream.
#pragma once

#include <cstdint>
#include <string>

#include "base/status.h"

namespace holofuse::deploy {

struct LinkImpairment {
  double delay_ms = 0;               // one way, added to every byte
  double jitter_ms = 0;              // uniform in [-jitter, +jitter] per read, order kept
  double rate_mbit = 0;              // 0: no cap
  double stall_every_s = 0;          // 0: never stalls
  double stall_ms = 0;               // how long each stall holds every link
  size_t max_held_bytes = 8u << 20;  // per direction; past it the relay stops reading
  uint64_t seed = 1;                 // of the jitter
};

struct RelayOptions {
  std::string listen;    // host:port the relay accepts on
  std::string upstream;  // host:port it connects each accepted peer to
  LinkImpairment impairment;
  std::string port_file;  // when set, the port it listens on is written here
};

// Runs until SIGINT or SIGTERM (see base/shutdown.h); an error when it
// cannot listen. Logs each link it opens and closes and each stall, and at
// the end the bytes it carried each way.
Status runRelay(const RelayOptions& options);

}  // namespace holofuse::deploy

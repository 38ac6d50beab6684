// The link every kind of pod (synthetic, replay, real camera) keeps to the
// fusion server: Hello as its pod id, its calibration again on every new
// connection, and nothing else taken from the server (pods expect only the
// handshake and heartbeats).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "protocol/messages.h"
#include "protocol/server_link.h"

namespace holofuse::capture {

class PodLink {
 public:
  PodLink(const protocol::Endpoint& server, uint32_t pod_id, const std::string& name,
          const std::vector<uint8_t>& key, uint8_t max_minor, protocol::Calibration calibration);

  // One turn of I/O, waiting up to timeout_ms; false once the link has
  // given up (link().fatalError() says why).
  bool pump(int timeout_ms);
  protocol::ServerLink& link() { return link_; }

 private:
  protocol::ServerLink link_;
  const protocol::Calibration calibration_;
  std::vector<protocol::Frame> received_;
};

}  // namespace holofuse::capture

// A replay pod: streams one camera of a recorded or imported dataset to a
// fusion server exactly like a live pod (handshake, Calibration on every
// connect, PodFrames), at the recorded pace or as fast as the server
// accepts. Frames keep their recorded planes byte for byte; frame ids are
// shifted per loop so a looping replay keeps moving forward, and the stage
// stamps are the replay's own (replay_read), not the recording's clock.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "protocol/frame.h"
#include "protocol/socket.h"

namespace holofuse::capture {

struct ReplayOptions {
  protocol::Endpoint server;
  std::string dataset;
  uint32_t pod_id = 0;
  double speed = 1.0;  // 1: the recorded pace; 0: as fast as the server accepts
  bool loop = false;
  std::vector<uint8_t> key;  // authenticates pod pod_id (protocol/auth.h); empty: none
  uint8_t max_minor = protocol::kVersionMinor;  // the newest protocol offered (--protocol)
};

// Parses --speed: a positive factor, or "max". Empty optional: invalid.
bool parseReplaySpeed(const std::string& text, double& speed);

// Returns the process exit code (2: the dataset or camera is unusable).
int runReplayPod(const ReplayOptions& options);

}  // namespace holofuse::capture

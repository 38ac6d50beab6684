// The settings of the live loop's three programs together: how the pods
// encode, how the server fuses, how the client renders. The launcher binds
// them to its flags and passes each program its part; eval and the sweep
// embed them, so a setting is declared once, in its program's struct and
// flag table, and reaches every tool that takes it.
#pragma once

#include <string>
#include <vector>

#include "codec/pod_frame_codec.h"
#include "config/settings.h"
#include "fusion_server/fusion_worker.h"
#include "render_client/render_settings.h"

namespace holofuse::eval {

struct LoopSettings {
  PodEncoding pods;
  fusion::FusionSettings fusion;
  render::RenderSettings render;
};

// The server's, the client's and the pods' flag tables as one, under the
// names the launcher takes. The image codec and the LZ4 settings are one
// flag each for the pods and the server alike (the pods' --codec is the
// server's --image-codec), so the images are encoded one way end to end.
const std::vector<Setting<LoopSettings>>& loopFlags();

// Who takes a flag of loopFlags(): "server", "pods", "pods and server" or
// "client".
std::string loopFlagTakers(const std::string& flag);

// Each program's flags for its part of settings: those that differ from
// its defaults.
std::vector<std::string> serverArguments(const LoopSettings& settings);
std::vector<std::string> podArguments(const LoopSettings& settings);
std::vector<std::string> clientArguments(const LoopSettings& settings);

}  // namespace holofuse::eval

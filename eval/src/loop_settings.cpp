#include "eval/loop_settings.h"

#include <algorithm>
#include <iterator>

namespace holofuse::eval {
namespace {

// The pods' name of a setting they share with the server.
const char* podsName(const std::string& flag) {
  if (flag == "--image-codec") return "--codec";
  if (flag == "--lz4-acceleration" || flag == "--lz4-hc-level") return flag.c_str();
  return nullptr;
}

std::vector<Setting<LoopSettings>> makeLoopFlags() {
  std::vector<Setting<LoopSettings>> flags;
  for (const Setting<fusion::FusionSettings>& server : fusion::fusionFlags()) {
    Setting<LoopSettings> setting = embedSetting<LoopSettings>(
        server, [](LoopSettings & s) -> auto& { return s.fusion; });
    const char* pods_flag = podsName(server.flag);
    if (pods_flag != nullptr) {
      const Setting<PodEncoding>* pods = findSetting(podEncodingFlags(), pods_flag);
      setting.set = [server = server.set, pods = pods->set](LoopSettings& s,
                                                            const std::string& text) {
        std::string error = server(s.fusion, text);
        return error.empty() ? pods(s.pods, text) : error;
      };
    }
    flags.push_back(std::move(setting));
  }
  for (const Setting<PodEncoding>& pods : podEncodingFlags()) {
    const bool shared = std::any_of(fusion::fusionFlags().begin(), fusion::fusionFlags().end(),
                                    [&](const auto& server) {
                                      const char* name = podsName(server.flag);
                                      return name != nullptr && pods.flag == name;
                                    });
    if (shared) continue;
    flags.push_back(embedSetting<LoopSettings>(
        pods, [](LoopSettings & s) -> auto& { return s.pods; }));
  }
  embedSettings(
      flags, render::renderFlags(), [](LoopSettings & s) -> auto& { return s.render; });
  return flags;
}

}  // namespace

const std::vector<Setting<LoopSettings>>& loopFlags() {
  static const std::vector<Setting<LoopSettings>> flags = makeLoopFlags();
  return flags;
}

std::string loopFlagTakers(const std::string& flag) {
  const bool server = findSetting(fusion::fusionFlags(), flag) != nullptr;
  const char* pods_flag = server ? podsName(flag) : flag.c_str();
  const bool pods = pods_flag != nullptr && findSetting(podEncodingFlags(), pods_flag) != nullptr;
  return server && pods ? "pods and server" : server ? "server" : pods ? "pods" : "client";
}

std::vector<std::string> serverArguments(const LoopSettings& settings) {
  return settingArguments(fusion::fusionFlags(), settings.fusion);
}
std::vector<std::string> podArguments(const LoopSettings& settings) {
  return settingArguments(podEncodingFlags(), settings.pods);
}
std::vector<std::string> clientArguments(const LoopSettings& settings) {
  return settingArguments(render::renderFlags(), settings.render);
}

}  // namespace holofuse::eval

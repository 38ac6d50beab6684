#include "capture_node/pod_link.h"

#include <utility>

namespace holofuse::capture {

namespace {

protocol::Hello podHello(uint32_t pod_id, const std::string& name, uint8_t max_minor) {
  protocol::Hello hello;
  hello.role = protocol::Role::kPod;
  hello.id = pod_id;
  hello.name = name;
  hello.max_minor = max_minor;
  return hello;
}

protocol::LinkOptions podLinkOptions(const std::string& name, const std::vector<uint8_t>& key) {
  protocol::LinkOptions options;
  options.log_name = name;
  options.key = key;
  return options;
}

}  // namespace

PodLink::PodLink(const protocol::Endpoint& server, uint32_t pod_id, const std::string& name,
                 const std::vector<uint8_t>& key, uint8_t max_minor,
                 protocol::Calibration calibration)
    : link_(server, podHello(pod_id, name, max_minor), podLinkOptions(name, key)),
      calibration_(std::move(calibration)) {}

bool PodLink::pump(int timeout_ms) {
  link_.poll(timeout_ms, received_);
  received_.clear();
  if (link_.takeConnectedEvent()) link_.sendMessage(calibration_);
  return !link_.fatalError();
}

}  // namespace holofuse::capture

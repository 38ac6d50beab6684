// NetnsRig: a rig of hosts on one machine. Each pod, the server and each
// client get a network namespace of their own, joined by veth pairs to a
// bridge in a switch namespace; every link (a pod or a client to the
// server) goes through an impairing relay in the switch namespace
// (deploy/link_relay.h: this kernel has no netem qdisc), so each link has
// its own delay, jitter and rate cap. Nothing touches the machine's own
// network namespace.
//
// Teardown cannot be left to the launcher alone: it may be killed. A
// reaper process, forked before anything is built, waits on a pipe whose
// only writer is the launcher; when the launcher ends in any way the pipe
// closes, and the reaper stops every process in the rig's namespaces
// (SIGTERM, then SIGKILL after a grace period) and deletes the namespaces,
// which takes their veth pairs and the bridge with them.
#pragma once

#include <sys/types.h>

#include <memory>
#include <string>
#include <vector>

#include "base/status.h"
#include "config/rig_file.h"

namespace holofuse::deploy {

struct RigPlan {
  int pods = 4;
  int clients = 1;
  RigLink link;  // every link's, but those below
  // Pod i's and client i's links, where a rig file gives them one each
  // (empty: every link is link).
  std::vector<RigLink> pod_links, client_links;
  std::string relay_bin;  // holofuse_relay
  std::string log_dir;    // relays' logs and the port files

  const RigLink& podLink(int pod) const { return pod_links.empty() ? link : pod_links.at(pod); }
  const RigLink& clientLink(int client) const {
    return client_links.empty() ? link : client_links.at(client);
  }
};

// iproute2's ip (findProgram: PATH, then where Debian puts it, which a
// user's PATH may lack); empty when there is none.
std::string ipCommand();

class NetnsRig {
 public:
  // Builds the namespaces, the bridge and the veth pairs, each named after
  // this process (hf<pid>-...); an error names the command that failed,
  // and whatever was built is gone again.
  static StatusOr<std::unique_ptr<NetnsRig>> build(const RigPlan& plan);
  // Tears the rig down (through the reaper) and waits until it is gone;
  // an error when something could not be removed (the reaper said what).
  Status tearDown();
  ~NetnsRig() { (void)tearDown(); }
  NetnsRig(const NetnsRig&) = delete;
  NetnsRig& operator=(const NetnsRig&) = delete;

  // args run inside a host's namespace (ip netns exec: the same pid).
  std::vector<std::string> inServer(std::vector<std::string> args) const;
  std::vector<std::string> inPod(int pod, std::vector<std::string> args) const;
  std::vector<std::string> inClient(int client, std::vector<std::string> args) const;
  const std::string& serverAddress() const { return server_ip_; }

  // Starts one relay per link towards the server's port; then each pod's
  // and client's endpoint is its relay's. An error says which relay did
  // not start.
  Status startRelays(const std::string& server_port);
  const std::string& podEndpoint(int pod) const { return pod_endpoints_.at(pod); }
  // Cuts pod's link (its namespace's end of the veth pair down: nothing
  // passes either way, and its connection stalls as over a pulled cable)
  // or restores it; an error names the command that failed.
  Status setPodLinkUp(int pod, bool up) const;
  const std::string& clientEndpoint(int client) const { return client_endpoints_.at(client); }

  // Every namespace of the rig, the switch last.
  const std::vector<std::string>& namespaces() const { return namespaces_; }
  std::string describe() const;

 private:
  explicit NetnsRig(const RigPlan& plan);
  Status buildNetwork();
  std::vector<std::string> inNamespace(const std::string& ns, std::vector<std::string> args) const;

  RigPlan plan_;
  std::string prefix_, subnet_, switch_, server_ns_, server_ip_;
  std::vector<std::string> pod_ns_, client_ns_, namespaces_;
  std::vector<std::string> pod_endpoints_, client_endpoints_;
  pid_t reaper_ = -1;
  int reaper_pipe_ = -1;  // our end; closing it starts the teardown
};

// Stops every process in each namespace (SIGTERM, then SIGKILL after
// grace_ms) and deletes it. What the reaper runs; "" or what failed.
std::string tearDownNamespaces(const std::vector<std::string>& namespaces, int grace_ms);

}  // namespace holofuse::deploy

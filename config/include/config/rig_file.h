// A rig file: one YAML file that names a rig's hosts, pod ids, cameras,
// server address, key files and links (docs/rig-file.md). Every program
// reads its own part of it (--rig FILE): the server its section, a pod the
// cameras' settings with its own entry on top, a client its entry; each
// part is that program's flags by their long names, so a key the file can
// hold is a flag the program has, and a flag given on the command line
// overrides the file.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "base/status.h"

namespace holofuse {

// One host's link to the server: what the network does to its traffic
// (on a rig of namespaces, what its relay does).
struct RigLink {
  double delay_ms = 0;   // one way
  double jitter_ms = 0;  // uniform around the delay, order kept
  double rate_mbit = 0;  // each way; 0: no cap
};

// A program's flag, by its long name without the dashes, with the values
// the file gives it (one, or a YAML sequence's items), and where in the
// file it was, for messages ("rig.yaml:12 (pod 3)").
struct RigOption {
  std::string name;
  std::vector<std::string> values;
  std::string where;
};

// A pod's or a client's entry: its id, the host it runs on, its link and
// its flags.
struct RigMember {
  uint32_t id = 0;
  std::string host;
  RigLink link;
  std::vector<RigOption> options;
};

struct RigFile {
  std::string path;  // as given to load(), for messages
  std::string name;  // the rig's, optional
  // Where pods and clients reach the server (HOST:PORT); the server
  // listens on it unless its section says --listen.
  std::string server_address, server_host;
  std::vector<RigOption> server;   // fusion_server's flags
  std::vector<RigOption> cameras;  // every pod's capture_node flags
  RigLink link;                    // every link's, unless a member says
  std::vector<RigMember> pods;     // ids 0..N-1, each once: the cameras
  std::vector<RigMember> clients;

  // Reads and checks a rig file: an error names the file, the line and
  // what is wrong (a key no rig has, a pod id twice, a bad address, ...).
  static StatusOr<RigFile> load(const std::string& path);
  static StatusOr<RigFile> parse(const std::string& text, const std::string& path);

  // Each program's part as its flags. What the rig implies comes first
  // (the server's --listen and --pods, a pod's --server and --pods, a
  // client's --server), unless the part names the flag itself.
  std::vector<RigOption> serverPart() const;
  StatusOr<std::vector<RigOption>> podPart(uint32_t pod_id) const;
  StatusOr<std::vector<RigOption>> clientPart(uint32_t client_id) const;
  // The id of the one pod the file puts on host (a capture PC that knows
  // its name but not its pod id), or an error naming the hosts there are.
  StatusOr<uint32_t> podOnHost(const std::string& host) const;

  // A text of one value per option: "--name value ..." (for a log line).
  static std::string describe(const std::vector<RigOption>& part);
};

}  // namespace holofuse

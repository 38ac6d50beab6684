#include "config/rig_file.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>

#include "config/settings.h"
#include "protocol/messages.h"
#include "protocol/socket.h"

namespace holofuse {
namespace {

// A rig file's error: thrown while reading, returned by parse() as a
// Status whose message names the file and the line.
struct RigError {
  std::string message;
};

class Reader {
 public:
  explicit Reader(std::string path) : path_(std::move(path)) {}

  [[noreturn]] void fail(const YAML::Node& node, const std::string& what) const {
    throw RigError{at(node) + ": " + what};
  }
  std::string at(const YAML::Node& node) const {
    const YAML::Mark mark = node.Mark();
    return mark.is_null() ? path_ : path_ + ":" + std::to_string(mark.line + 1);
  }

  // The keys of a map in file order, each once.
  std::vector<std::pair<YAML::Node, YAML::Node>> entries(const YAML::Node& map,
                                                         const std::string& what) const {
    if (!map.IsMap()) fail(map, what + " is not a map of keys to values");
    std::vector<std::pair<YAML::Node, YAML::Node>> items;
    std::set<std::string> seen;
    for (auto it = map.begin(); it != map.end(); ++it) {
      if (!it->first.IsScalar()) fail(it->first, what + ": a key is not a name");
      if (!seen.insert(it->first.Scalar()).second)
        fail(it->first, what + ": '" + it->first.Scalar() + "' is given twice");
      // (A missing value's node has no line of its own: the key's is said.)
      if (it->second.IsNull())
        fail(it->first, what + ": '" + it->first.Scalar() + "' has no value");
      items.emplace_back(it->first, it->second);
    }
    return items;
  }

  std::string text(const YAML::Node& value, const std::string& what) const {
    if (!value.IsScalar() || value.Scalar().empty()) fail(value, what + " is not a value");
    return value.Scalar();
  }

  double number(const YAML::Node& value, const std::string& what, double min, double max) const {
    double v = 0;
    if (const std::string error = parseNumberIn(text(value, what), min, max, v); !error.empty())
      fail(value, what + ": " + error);
    return v;
  }

  // A program's flag: a value or a sequence of values.
  RigOption option(const YAML::Node& key, const YAML::Node& value, const std::string& who) const {
    RigOption option{key.Scalar(), {}, at(key) + " (" + who + ")"};
    if (option.name.empty() || option.name[0] == '-')
      fail(key, who + ": '" + option.name + "' is not a flag's name (a flag without its dashes)");
    const std::string what = who + ": " + option.name;
    if (value.IsSequence()) {
      for (const YAML::Node& item : value) option.values.push_back(text(item, what + "'s item"));
      if (option.values.empty()) fail(key, what + " is an empty list");
    } else {
      if (!value.IsScalar() || value.Scalar().empty()) fail(key, what + " is not a value");
      option.values.push_back(value.Scalar());
    }
    return option;
  }

  // A link's settings over base: delay-ms, jitter-ms, rate-mbit.
  RigLink link(const YAML::Node& map, RigLink base, const std::string& who) const {
    for (const auto& [key, value] : entries(map, who + "'s link")) {
      const std::string& name = key.Scalar();
      const std::string what = who + "'s link " + name;
      if (name == "delay-ms") {
        base.delay_ms = number(value, what, 0, 10000);
      } else if (name == "jitter-ms") {
        base.jitter_ms = number(value, what, 0, 10000);
      } else if (name == "rate-mbit") {
        base.rate_mbit = number(value, what, 0, 100000);
      } else {
        fail(key, what + ": not a link setting (delay-ms, jitter-ms, rate-mbit)");
      }
    }
    if (base.jitter_ms > base.delay_ms)
      fail(map, who + "'s link: jitter " + formatNumber(base.jitter_ms) +
                    " ms is more than the delay " + formatNumber(base.delay_ms) + " ms it varies");
    return base;
  }

  // A pod's or client's entry. reserved: the flag its id stands for.
  RigMember member(const YAML::Node& node, size_t index, const std::string& kind,
                   const std::string& reserved, uint32_t max_id, const RigLink& rig_link) const {
    RigMember member;
    member.id = static_cast<uint32_t>(index);
    member.link = rig_link;
    const std::string at_index = kind + "s[" + std::to_string(index) + "]";
    if (!node.IsMap()) fail(node, at_index + " is not a map of keys to values");
    if (const YAML::Node id = node["id"]) {
      if (id.IsNull()) fail(node, at_index + ": 'id' has no value");
      member.id = static_cast<uint32_t>(number(id, at_index + "'s id", 0, max_id));
      if (std::to_string(member.id) != id.Scalar())
        fail(id, at_index + "'s id '" + id.Scalar() + "' is not a whole number");
    }
    const std::string who = kind + " " + std::to_string(member.id);
    for (const auto& [key, value] : entries(node, who)) {
      const std::string& name = key.Scalar();
      if (name == "id") continue;
      if (name == "host") {
        member.host = text(value, who + "'s host");
      } else if (name == "link") {
        member.link = link(value, rig_link, who);
      } else if (name == reserved || name == "rig") {
        fail(key, who + ": '" + name + "' is set by the rig file itself (its id, this file)");
      } else {
        member.options.push_back(option(key, value, who));
      }
    }
    return member;
  }

 private:
  std::string path_;
};

bool names(const std::vector<RigOption>& part, const std::string& name) {
  return std::any_of(part.begin(), part.end(),
                     [&](const RigOption& option) { return option.name == name; });
}

// The implied options first, each unless the part names it.
std::vector<RigOption> withImplied(const std::vector<RigOption>& implied,
                                   const std::vector<RigOption>& part) {
  std::vector<RigOption> all;
  for (const RigOption& option : implied)
    if (!names(part, option.name)) all.push_back(option);
  all.insert(all.end(), part.begin(), part.end());
  return all;
}

}  // namespace

StatusOr<RigFile> RigFile::load(const std::string& path) {
  std::ifstream in(path);
  if (!in) return Status(StatusCode::kIoError, path + ": cannot read the rig file");
  std::stringstream text;
  text << in.rdbuf();
  return parse(text.str(), path);
}

StatusOr<RigFile> RigFile::parse(const std::string& text, const std::string& path) {
  RigFile rig;
  rig.path = path;
  const Reader reader(path);
  try {
    YAML::Node root;
    try {
      root = YAML::Load(text);
    } catch (const YAML::Exception& e) {
      return Status(StatusCode::kMalformed,
                    path + ":" + std::to_string(e.mark.line + 1) + ": not YAML: " + e.msg);
    }
    if (!root.IsMap()) reader.fail(root, "a rig file is a map: rig, server, pods, ...");
    // (A default YAML::Node counts as defined: absence is nullopt.)
    std::optional<YAML::Node> server, link, cameras, pods, clients;
    for (const auto& [key, value] : reader.entries(root, "the rig file")) {
      const std::string& name = key.Scalar();
      if (name == "rig") {
        rig.name = reader.text(value, "rig");
      } else if (name == "server") {
        server = value;
      } else if (name == "link") {
        link = value;
      } else if (name == "cameras") {
        cameras = value;
      } else if (name == "pods") {
        pods = value;
      } else if (name == "clients") {
        clients = value;
      } else {
        reader.fail(key, "'" + name +
                             "' is not a key of a rig file (rig, server, link, cameras, pods, "
                             "clients)");
      }
    }
    if (!server) reader.fail(root, "no server: a rig names its server's address");
    if (!pods) reader.fail(root, "no pods: a rig names its pods, by id");
    if (link) rig.link = reader.link(*link, {}, "the rig");
    for (const auto& [key, value] : reader.entries(*server, "server")) {
      const std::string& name = key.Scalar();
      if (name == "address") {
        rig.server_address = reader.text(value, "server's address");
        auto endpoint = protocol::parseEndpoint(rig.server_address);
        if (!endpoint.isOk() || endpoint->port == 0)
          reader.fail(value, "server's address '" + rig.server_address +
                                 "' is not HOST:PORT with a port other than 0");
      } else if (name == "host") {
        rig.server_host = reader.text(value, "server's host");
      } else if (name == "rig") {
        reader.fail(key, "server: 'rig' is this file itself");
      } else {
        rig.server.push_back(reader.option(key, value, "server"));
      }
    }
    if (rig.server_address.empty())
      reader.fail(*server, "server: no address (HOST:PORT, where pods and clients reach it)");
    if (cameras) {
      for (const auto& [key, value] : reader.entries(*cameras, "cameras")) {
        if (key.Scalar() == "pod-id" || key.Scalar() == "rig")
          reader.fail(key, "cameras: '" + key.Scalar() + "' is set by the rig file itself");
        rig.cameras.push_back(reader.option(key, value, "cameras"));
      }
    }
    if (!pods->IsSequence() || pods->size() == 0)
      reader.fail(*pods, "pods is not a list of pods (- id: 0 ...)");
    if (pods->size() > protocol::kMaxCameras)
      reader.fail(*pods, std::to_string(pods->size()) + " pods: a rig has at most " +
                             std::to_string(protocol::kMaxCameras));
    std::vector<YAML::Node> pod_nodes(pods->begin(), pods->end());
    std::vector<const YAML::Node*> by_id(pod_nodes.size(), nullptr);
    for (size_t i = 0; i < pod_nodes.size(); ++i) {
      RigMember pod =
          reader.member(pod_nodes[i], i, "pod", "pod-id", protocol::kMaxCameras - 1, rig.link);
      // A pod's id is its camera's index: the ids are 0..N-1, each once.
      if (pod.id >= pod_nodes.size())
        reader.fail(pod_nodes[i], "pod " + std::to_string(pod.id) + ": with " +
                                      std::to_string(pod_nodes.size()) + " pods the ids are 0.." +
                                      std::to_string(pod_nodes.size() - 1));
      if (by_id[pod.id] != nullptr)
        reader.fail(pod_nodes[i], "pod " + std::to_string(pod.id) + " is given twice (also at " +
                                      reader.at(*by_id[pod.id]) + ")");
      by_id[pod.id] = &pod_nodes[i];
      rig.pods.push_back(std::move(pod));
    }
    std::sort(rig.pods.begin(), rig.pods.end(),
              [](const RigMember& a, const RigMember& b) { return a.id < b.id; });
    if (clients) {
      if (!clients->IsSequence()) reader.fail(*clients, "clients is not a list of clients");
      std::vector<YAML::Node> client_nodes(clients->begin(), clients->end());
      std::set<uint32_t> ids;
      for (size_t i = 0; i < client_nodes.size(); ++i) {
        RigMember client =
            reader.member(client_nodes[i], i, "client", "client-id", UINT32_MAX, rig.link);
        if (!ids.insert(client.id).second)
          reader.fail(client_nodes[i], "client " + std::to_string(client.id) + " is given twice");
        rig.clients.push_back(std::move(client));
      }
    }
  } catch (const RigError& error) {
    return Status(StatusCode::kMalformed, error.message);
  } catch (const YAML::Exception& e) {
    return Status(StatusCode::kMalformed, path + ": " + e.what());
  }
  return rig;
}

std::vector<RigOption> RigFile::serverPart() const {
  const std::string where = path + " (the rig)";
  return withImplied(
      {{"listen", {server_address}, where}, {"pods", {std::to_string(pods.size())}, where}},
      server);
}

StatusOr<std::vector<RigOption>> RigFile::podPart(uint32_t pod_id) const {
  const auto pod = std::find_if(pods.begin(), pods.end(),
                                [&](const RigMember& member) { return member.id == pod_id; });
  if (pod == pods.end())
    return Status(StatusCode::kMalformed, path + " has no pod " + std::to_string(pod_id) +
                                              " (its pods are 0.." +
                                              std::to_string(pods.size() - 1) + ")");
  // The cameras' settings, then the pod's own on top.
  std::vector<RigOption> part;
  for (const RigOption& option : cameras)
    if (!names(pod->options, option.name)) part.push_back(option);
  part.insert(part.end(), pod->options.begin(), pod->options.end());
  const std::string where = path + " (the rig)";
  std::vector<RigOption> implied = {{"server", {server_address}, where}};
  // A replay pod's camera count is its dataset's.
  if (!names(part, "replay")) implied.push_back({"pods", {std::to_string(pods.size())}, where});
  return withImplied(implied, part);
}

StatusOr<std::vector<RigOption>> RigFile::clientPart(uint32_t client_id) const {
  const auto client = std::find_if(clients.begin(), clients.end(),
                                   [&](const RigMember& member) { return member.id == client_id; });
  std::vector<RigOption> part;
  if (client != clients.end()) {
    part = client->options;
  } else if (!clients.empty()) {
    std::string ids;
    for (const RigMember& member : clients)
      ids += (ids.empty() ? "" : ", ") + std::to_string(member.id);
    return Status(StatusCode::kMalformed, path + " has no client " + std::to_string(client_id) +
                                              " (its clients: " + ids + ")");
  }
  // A rig without clients still tells a client where the server is.
  return withImplied({{"server", {server_address}, path + " (the rig)"}}, part);
}

StatusOr<uint32_t> RigFile::podOnHost(const std::string& host) const {
  std::vector<uint32_t> on_host;
  std::string hosts;
  for (const RigMember& pod : pods) {
    if (pod.host == host) on_host.push_back(pod.id);
    if (!pod.host.empty() && hosts.find(" " + pod.host + ",") == std::string::npos)
      hosts += " " + pod.host + ",";
  }
  if (on_host.size() == 1) return on_host[0];
  if (on_host.empty()) {
    if (!hosts.empty()) hosts = " (its pods' hosts:" + hosts.substr(0, hosts.size() - 1) + ")";
    return Status(StatusCode::kMalformed,
                  path + " has no pod on host " + host + hosts + ": give --pod-id or --rig-host");
  }
  std::string ids;
  for (const uint32_t id : on_host) ids += (ids.empty() ? "" : ", ") + std::to_string(id);
  return Status(StatusCode::kMalformed,
                path + " puts pods " + ids + " on host " + host + ": give --pod-id");
}

std::string RigFile::describe(const std::vector<RigOption>& part) {
  std::string text;
  for (const RigOption& option : part) {
    text += (text.empty() ? "--" : " --") + option.name;
    for (const std::string& value : option.values) text += " " + value;
  }
  return text;
}

}  // namespace holofuse

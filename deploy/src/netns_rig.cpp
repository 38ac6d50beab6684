#include "deploy/netns_rig.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <thread>

#include "base/process.h"
#include "config/settings.h"

namespace holofuse::deploy {
namespace {

// Runs a command to its end: "" when it exited 0, else the command and
// what it said (ip says why on stderr: "RTNETLINK answers: ..."). Its
// stdout goes to *output when asked for.
std::string run(const std::vector<std::string>& args, std::string* output = nullptr) {
  const FinishedProcess finished = runToEnd(args, 30000);
  if (output) *output = finished.output;
  if (finished.exit_code == 0) return "";
  const std::string said = finished.output + finished.errors;
  std::string line;
  for (const std::string& word : args) line += word + " ";
  return line + "exited " + std::to_string(finished.exit_code) + (said.empty() ? "" : ": " + said);
}

std::vector<pid_t> pidsIn(const std::string& ns) {
  std::string listed;
  if (!run({ipCommand(), "netns", "pids", ns}, &listed).empty()) return {};
  std::vector<pid_t> pids;
  std::istringstream in(listed);
  for (long pid; in >> pid;) pids.push_back(static_cast<pid_t>(pid));
  return pids;
}

}  // namespace

std::string ipCommand() { return findProgram("ip", {"/usr/sbin", "/sbin"}); }

std::string tearDownNamespaces(const std::vector<std::string>& namespaces, int grace_ms) {
  std::string failed;
  for (const std::string& ns : namespaces) {
    for (pid_t pid : pidsIn(ns)) ::kill(pid, SIGTERM);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(grace_ms);
    while (!pidsIn(ns).empty() && std::chrono::steady_clock::now() < deadline) {
      // A child of ours (the launcher gone, or this is it) is reaped here;
      // any other is reaped by whoever is its parent now.
      while (::waitpid(-1, nullptr, WNOHANG) > 0) {
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    for (pid_t pid : pidsIn(ns)) ::kill(pid, SIGKILL);
    const std::string why = run({ipCommand(), "netns", "del", ns});
    if (!why.empty()) failed += why;
  }
  return failed;
}

NetnsRig::NetnsRig(const RigPlan& plan) : plan_(plan) {
  const int pid = static_cast<int>(::getpid());
  prefix_ = "hf" + std::to_string(pid);
  subnet_ = "10." + std::to_string(200 + pid % 50) + "." + std::to_string((pid / 50) % 256) + ".";
  switch_ = prefix_ + "-switch";
  server_ns_ = prefix_ + "-server";
  server_ip_ = subnet_ + "2";
  for (int i = 0; i < plan_.pods; ++i) pod_ns_.push_back(prefix_ + "-pod" + std::to_string(i));
  for (int i = 0; i < plan_.clients; ++i)
    client_ns_.push_back(prefix_ + "-client" + std::to_string(i));
  // Hosts first, the switch last: the relays go after the peers they carry.
  namespaces_ = client_ns_;
  namespaces_.insert(namespaces_.end(), pod_ns_.begin(), pod_ns_.end());
  namespaces_.push_back(server_ns_);
  namespaces_.push_back(switch_);
}

StatusOr<std::unique_ptr<NetnsRig>> NetnsRig::build(const RigPlan& plan) {
  if (ipCommand().empty())
    return Status(StatusCode::kIoError, "ip (Debian's iproute2) is not installed");
  if (::geteuid() != 0)
    return Status(StatusCode::kIoError,
                  "network namespaces need root (CAP_NET_ADMIN and CAP_SYS_ADMIN)");
  std::unique_ptr<NetnsRig> rig(new NetnsRig(plan));
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) return Status(StatusCode::kIoError, "pipe2 failed");
  const pid_t reaper = ::fork();
  if (reaper < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    return Status(StatusCode::kIoError, "cannot fork the rig's reaper");
  }
  if (reaper == 0) {
    // The reaper: in a session of its own (a signal to the launcher's
    // process group, Ctrl-\ or a job runner's SIGKILL, does not reach it)
    // and deaf to the rest, it waits for the launcher's end of the pipe to
    // close, then tears the rig down.
    ::setsid();
    ::signal(SIGINT, SIG_IGN);
    ::signal(SIGTERM, SIG_IGN);
    ::signal(SIGHUP, SIG_IGN);
    ::close(fds[1]);
    char byte;
    while (::read(fds[0], &byte, 1) != 0) {
    }
    const std::string failed = tearDownNamespaces(rig->namespaces_, 3000);
    if (!failed.empty()) std::fprintf(stderr, "[rig] teardown: %s\n", failed.c_str());
    ::_exit(failed.empty() ? 0 : 1);
  }
  ::close(fds[0]);
  rig->reaper_ = reaper;
  rig->reaper_pipe_ = fds[1];
  if (Status built = rig->buildNetwork(); !built.isOk()) return built;  // ~NetnsRig tears down
  return rig;
}

Status NetnsRig::tearDown() {
  if (reaper_pipe_ >= 0) ::close(reaper_pipe_);
  reaper_pipe_ = -1;
  if (reaper_ <= 0) return Status::ok();
  const int code = waitProcess(reaper_, -1).value_or(-1);
  reaper_ = -1;
  if (code == 0) return Status::ok();
  return Status(StatusCode::kIoError, "the rig's teardown failed (exit " + std::to_string(code) +
                                          "); ip netns list names what is left");
}

Status NetnsRig::buildNetwork() {
  const std::string ip = ipCommand();
  std::vector<std::vector<std::string>> commands;
  for (const std::string& ns : namespaces_) {
    commands.push_back({ip, "netns", "add", ns});
    commands.push_back({ip, "-n", ns, "link", "set", "lo", "up"});
  }
  commands.push_back({ip, "-n", switch_, "link", "add", "rig", "type", "bridge"});
  commands.push_back({ip, "-n", switch_, "addr", "add", subnet_ + "1/24", "dev", "rig"});
  commands.push_back({ip, "-n", switch_, "link", "set", "rig", "up"});
  // Host addresses: the server .2, clients from .3, pods from .10.
  auto join = [&](const std::string& ns, const std::string& short_name, int host) {
    const std::string outer = prefix_ + short_name + "b", inner = prefix_ + short_name + "a";
    commands.push_back({ip, "-n", switch_, "link", "add", outer, "type", "veth", "peer", "name",
                        inner, "netns", ns});
    commands.push_back({ip, "-n", switch_, "link", "set", outer, "master", "rig"});
    commands.push_back({ip, "-n", switch_, "link", "set", outer, "up"});
    commands.push_back(
        {ip, "-n", ns, "addr", "add", subnet_ + std::to_string(host) + "/24", "dev", inner});
    commands.push_back({ip, "-n", ns, "link", "set", inner, "up"});
  };
  join(server_ns_, "s", 2);
  for (int i = 0; i < plan_.clients; ++i) join(client_ns_[i], "c" + std::to_string(i), 3 + i);
  for (int i = 0; i < plan_.pods; ++i) join(pod_ns_[i], "p" + std::to_string(i), 10 + i);
  for (const auto& command : commands) {
    if (const std::string why = run(command); !why.empty())
      return Status(StatusCode::kIoError, why);
  }
  return Status::ok();
}

Status NetnsRig::setPodLinkUp(int pod, bool up) const {
  const std::string why = run({ipCommand(), "-n", pod_ns_.at(pod), "link", "set",
                               prefix_ + "p" + std::to_string(pod) + "a", up ? "up" : "down"});
  return why.empty() ? Status::ok() : Status(StatusCode::kIoError, why);
}

std::vector<std::string> NetnsRig::inNamespace(const std::string& ns,
                                               std::vector<std::string> args) const {
  args.insert(args.begin(), {ipCommand(), "netns", "exec", ns});
  return args;
}

std::vector<std::string> NetnsRig::inServer(std::vector<std::string> args) const {
  return inNamespace(server_ns_, std::move(args));
}

std::vector<std::string> NetnsRig::inPod(int pod, std::vector<std::string> args) const {
  return inNamespace(pod_ns_.at(pod), std::move(args));
}

std::vector<std::string> NetnsRig::inClient(int client, std::vector<std::string> args) const {
  return inNamespace(client_ns_.at(client), std::move(args));
}

Status NetnsRig::startRelays(const std::string& server_port) {
  auto relay = [&](const std::string& name, const RigLink& link,
                   int seed) -> StatusOr<std::string> {
    const std::string port_file = plan_.log_dir + "/relay_" + name + ".port";
    std::remove(port_file.c_str());
    auto pid =
        spawnProcess(inNamespace(switch_, {plan_.relay_bin, "--listen", subnet_ + "1:0", "--to",
                                           server_ip_ + ":" + server_port, "--delay-ms",
                                           std::to_string(link.delay_ms), "--jitter-ms",
                                           std::to_string(link.jitter_ms), "--rate-mbit",
                                           std::to_string(link.rate_mbit), "--seed",
                                           std::to_string(seed), "--port-file", port_file}),
                     SpawnOptions{plan_.log_dir + "/relay_" + name + ".log", true, true});
    if (!pid.isOk()) return pid.status();
    // The relay writes its port once it listens: the event waited for.
    for (int i = 0; i < 3000; ++i) {
      std::string port;
      std::getline(std::ifstream(port_file) >> std::ws, port);
      if (!port.empty()) return subnet_ + "1:" + port;
      if (pollProcess(*pid))
        return Status(StatusCode::kIoError, "the relay of " + name + " exited at start-up; see " +
                                                plan_.log_dir + "/relay_" + name + ".log");
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return Status(StatusCode::kTimeout, "the relay of " + name + " did not report its port");
  };
  for (int i = 0; i < plan_.pods; ++i) {
    auto endpoint = relay("pod" + std::to_string(i), plan_.podLink(i), i + 1);
    if (!endpoint.isOk()) return endpoint.status();
    pod_endpoints_.push_back(*endpoint);
  }
  for (int i = 0; i < plan_.clients; ++i) {
    auto endpoint = relay("client" + std::to_string(i), plan_.clientLink(i), 1000 + i);
    if (!endpoint.isOk()) return endpoint.status();
    client_endpoints_.push_back(*endpoint);
  }
  return Status::ok();
}

std::string NetnsRig::describe() const {
  auto linkText = [](const RigLink& link) {
    char text[96];
    std::snprintf(text, sizeof text, "%g ms one way +- %g ms", link.delay_ms, link.jitter_ms);
    return text + (link.rate_mbit > 0 ? ", " + formatNumber(link.rate_mbit) + " Mbit/s" : "");
  };
  std::string links;
  if (plan_.pod_links.empty() && plan_.client_links.empty()) {
    links = linkText(plan_.link);
  } else {
    for (int i = 0; i < plan_.pods; ++i)
      links += (i ? "; pod " : "pod ") + std::to_string(i) + " " + linkText(plan_.podLink(i));
    for (int i = 0; i < plan_.clients; ++i)
      links += "; client " + std::to_string(i) + " " + linkText(plan_.clientLink(i));
  }
  char text[256];
  std::snprintf(text, sizeof text,
                "%d pods, the server and %d client%s in namespaces %s-*, each link through a "
                "relay: ",
                plan_.pods, plan_.clients, plan_.clients > 1 ? "s" : "", prefix_.c_str());
  return text + links;
}

}  // namespace holofuse::deploy

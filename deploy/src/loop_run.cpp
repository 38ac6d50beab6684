#include "deploy/loop_run.h"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "base/eta.h"
#include "base/process.h"
#include "deploy/heap_profile.h"
#include "deploy/netns_rig.h"
#include "deploy/soak.h"
#include "protocol/auth.h"

namespace holofuse::deploy {
namespace {

volatile sig_atomic_t g_interrupted = 0;
void onSignal(int) { g_interrupted = 1; }

// Starts a child of the loop: its output into log_path (the client's
// stdout stays the terminal, for its progress line, unless quiet), Ctrl-C
// left to the launcher, which decides when children stop. -1, said why,
// when it cannot start.
pid_t spawn(const std::vector<std::string>& args, const std::string& log_path, bool quiet = false) {
  holofuse::SpawnOptions options;
  options.log_path = log_path;
  // (In a rig the program follows ip netns exec's words.)
  options.stdout_to_log =
      quiet || std::none_of(args.begin(), args.end(), [](const std::string& word) {
        return word.find("/render_client") != std::string::npos;
      });
  options.ignore_interrupt = true;
  // A launcher killed outright (a test's time limit, an OOM kill) takes
  // its rig with it rather than leaving it to eat the machine.
  options.die_with_parent = true;
  auto pid = holofuse::spawnProcess(args, options);
  if (!pid.isOk()) {
    std::fprintf(stderr, "[loop] %s\n", pid.status().message().c_str());
    return -1;
  }
  return *pid;
}

void stop(pid_t pid, const char* what) {
  if (pid <= 0) return;
  if (holofuse::stopProcess(pid, 3000).killed) {
    std::fprintf(stderr, "[loop] %s (pid %d) ignored SIGTERM for 3 s; killed it\n", what, pid);
  }
}

// The last lines of a child's log, where a failure is explained.
void printLogTail(const std::filesystem::path& path) {
  std::ifstream log(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(log, line);) lines.push_back(line);
  for (size_t i = lines.size() > 15 ? lines.size() - 15 : 0; i < lines.size(); ++i) {
    std::fprintf(stderr, "  %s\n", lines[i].c_str());
  }
}

// The running loop's processes.
struct LoopProcesses {
  pid_t server = -1;
  std::vector<pid_t> pods, clients;

  void stopAll() {
    for (const pid_t client : clients) stop(client, "render_client");
    for (const pid_t pod : pods) stop(pod, "capture_node");
    stop(server, "fusion_server");
  }
};

// The port the server wrote into port_file, or "" after saying why not.
// It ends early when the server does; the limit is for a server alive but
// stuck, not a slow one (a sanitized build on a busy machine took over 5 s).
std::string awaitServerPort(LoopProcesses& processes, const std::string& port_file,
                            const std::string& out) {
  std::string bound;
  for (int i = 0; i < 3000 && bound.empty(); ++i) {
    std::ifstream in(port_file);
    std::getline(in, bound);
    if (bound.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (holofuse::pollProcess(processes.server)) {
      processes.server = -1;  // gone already
      std::fprintf(stderr, "[loop] fusion_server exited at start-up; see %s/logs/server.log\n",
                   out.c_str());
      return "";
    }
  }
  if (bound.empty())
    std::fprintf(stderr, "[loop] fusion_server did not report its port within 60 s\n");
  return bound;
}

// Client i's log, beside the others'.
std::filesystem::path clientLog(const LoopPlan& plan, size_t i) {
  const std::filesystem::path logs = std::filesystem::path(plan.out) / "logs";
  return logs /
         (plan.clients == 1 ? std::string("client.log") : "client" + std::to_string(i) + ".log");
}

// Polls the pods and the server between waits: a pod that fails (a replay
// pod that cannot read its dataset) or a server that stops while it should
// not fails the run, said with the end of its log.
struct Watch {
  std::vector<bool> pod_done;
  bool server_done = false, failed = false;

  void check(const LoopPlan& plan, LoopProcesses& processes) {
    const std::filesystem::path logs = std::filesystem::path(plan.out) / "logs";
    pod_done.resize(processes.pods.size(), false);
    for (size_t i = 0; i < processes.pods.size() && !failed; ++i) {
      if (pod_done[i]) continue;
      const auto code = holofuse::pollProcess(processes.pods[i]);
      if (!code) continue;
      pod_done[i] = true;
      if (*code != 0) {
        std::fprintf(stderr, "\n[loop] capture_node %zu failed; the end of %s/pod%zu.log:\n", i,
                     logs.c_str(), i);
        printLogTail(logs / ("pod" + std::to_string(i) + ".log"));
        failed = true;
      }
    }
    const auto server_code = server_done ? std::nullopt : holofuse::pollProcess(processes.server);
    if (server_code) {
      server_done = true;
      if (!replayEnds(plan) || *server_code != 0) {
        std::fprintf(stderr, "\n[loop] fusion_server stopped; the end of %s/server.log:\n",
                     logs.c_str());
        printLogTail(logs / "server.log");
        failed = true;
      }
    }
  }

  // Stops what still runs.
  void stopRest(LoopProcesses& processes, const std::vector<bool>& client_done) {
    for (size_t i = 0; i < processes.clients.size(); ++i)
      if (!client_done[i]) stop(processes.clients[i], "render_client");
    for (size_t i = 0; i < processes.pods.size(); ++i)
      if (!pod_done[i]) stop(processes.pods[i], "capture_node");
    if (!server_done) stop(processes.server, "fusion_server");
  }
};

// Waits for the clients to finish, a process to fail or Ctrl-C, then
// stops what still runs. The launcher's exit code.
int superviseLoop(const LoopPlan& plan, LoopProcesses& processes) {
  const size_t n = processes.clients.size();
  std::vector<int> client_exit(n, 0);
  std::vector<bool> client_done(n, false);
  Watch watch;
  uint64_t waited_after_server_ms = 0;
  auto all_done = [&] {
    return std::all_of(client_done.begin(), client_done.end(), [](bool done) { return done; });
  };
  while (!g_interrupted && !all_done() && !watch.failed) {
    for (size_t i = 0; i < n; ++i) {
      if (client_done[i]) continue;
      if (const auto code = holofuse::waitProcess(processes.clients[i], 100 / n)) {
        client_exit[i] = *code;
        client_done[i] = true;
      }
    }
    watch.check(plan, processes);
    // A replay ends when the server has fused and delivered everything and
    // said goodbye; the clients then finish on their own.
    if (watch.server_done && !watch.failed && (waited_after_server_ms += 100) > 60000) {
      std::fprintf(stderr,
                   "\n[loop] the client did not finish within 60 s of the end of the replay\n");
      watch.failed = true;
    }
  }
  if (!all_done()) {
    std::printf("\n[loop] %s: stopping the client%s (each writes its report)\n",
                watch.failed ? "failed" : "interrupted", n > 1 ? "s" : "");
  }
  watch.stopRest(processes, client_done);
  bool ok = !watch.failed;
  for (size_t i = 0; i < n && !watch.failed; ++i) {
    if (client_done[i] && client_exit[i] != 0) {
      // Say why right here: the end of the client's log.
      std::fprintf(stderr, "[loop] render_client failed; the end of %s:\n",
                   clientLog(plan, i).c_str());
      printLogTail(clientLog(plan, i));
      ok = false;
    }
  }
  const std::string& out = plan.out;
  if (ok) {
    std::printf("[loop] all processes stopped; frames and report.json in %s%s, logs in %s/logs\n",
                out.c_str(), n > 1 ? "/client<N>" : "", out.c_str());
  } else {
    std::printf("[loop] all processes stopped; logs in %s/logs\n", out.c_str());
  }
  return ok ? 0 : 1;
}

// A rig's links as the first client's report measured them, beside what
// they were set to.
void printLinks(const LoopPlan& plan) {
  std::ifstream in(std::filesystem::path(clientOut(plan, 0)) / "report.json");
  const auto report = nlohmann::json::parse(in, nullptr, false);
  if (report.is_discarded() || !report.contains("latency_ms")) {
    std::printf("[rig] no report.json from the client: no link was measured\n");
    return;
  }
  std::printf("[rig] one-way latency per link, p50 / p95, beside what it is set to:\n");
  for (const auto& [link, ms] : report["latency_ms"]["links"].items()) {
    int pod = -1;
    const holofuse::RigLink& set = std::sscanf(link.c_str(), "pod_%d_to_server", &pod) == 1 &&
                                           pod >= 0 && pod < static_cast<int>(plan.pod_links.size())
                                       ? plan.pod_links[pod]
                                   : link == "server_to_client" && !plan.client_links.empty()
                                       ? plan.client_links[0]
                                       : plan.link;
    std::printf("[rig]   %-24s %7.1f / %7.1f ms   (set %g +- %g ms)\n", link.c_str(),
                ms["p50"].get<double>(), ms["p95"].get<double>(), set.delay_ms, set.jitter_ms);
  }
}

// --churn: client sessions that join and leave all through a soak after
// its warm-up, and a pod that restarts. A session begins every plan.churn_seconds while
// fewer than two are live; in turn one renders 8 frames and leaves saying
// bye, the next is killed (SIGKILL, mid-frame) 6 s after it began. Every
// fifth session the last pod is stopped, cleanly and with SIGKILL in turn,
// and started again at once: the sampled pid follows it.
class Churn {
 public:
  // In a rig, sessions start in client 0's namespace through its link,
  // pods restart in their own, and every tenth session pod 0's link is
  // cut for kLinkCutSeconds.
  Churn(const LoopPlan& plan, std::string endpoint, LoopProcesses& processes,
        std::vector<pid_t>& sampled, const holofuse::deploy::NetnsRig* rig)
      : plan_(plan),
        endpoint_(std::move(endpoint)),
        processes_(processes),
        sampled_(sampled),
        rig_(rig) {}

  void step(double seconds) {
    for (auto session = live_.begin(); session != live_.end();) {
      std::optional<int> code = holofuse::pollProcess(session->pid);
      if (!code && !session->bye && seconds >= session->kill_at) {
        ::kill(session->pid, SIGKILL);
        code = holofuse::waitProcess(session->pid, -1);
      }
      if (!code) {
        ++session;
        continue;
      }
      ended(*session, *code);
      session = live_.erase(session);
    }
    if (cut_until_ && seconds >= *cut_until_) restoreLink();
    // The churn begins after the warm-up, when every pod and steady client
    // has joined: the server's descriptors and threads then are the ones
    // it must come back to.
    if (seconds < plan_.warmup_minutes * 60.0 || seconds < next_ || live_.size() >= 2) return;
    next_ = seconds + plan_.churn_seconds;
    if (counts.sessions == 0) {
      if (const auto usage = holofuse::processUsage(processes_.server)) {
        counts.descriptors_start = usage->descriptors;
        counts.threads_start = usage->threads;
      }
    }
    begin(seconds);
    if (counts.sessions % 5 == 0 && !processes_.pods.empty()) restartPod();
    if (rig_ != nullptr && counts.sessions % 10 == 3 && !cut_until_) cutLink(seconds);
  }

  // The sessions still live end (a bye one after its frames, a killed one
  // now), and the server's log is read for what it saw.
  void finish() {
    if (cut_until_) restoreLink();
    for (Session& session : live_) {
      if (!session.bye) ::kill(session.pid, SIGKILL);
      ended(session, holofuse::waitProcess(session.pid, session.bye ? 60000 : -1).value_or(-1));
    }
    live_.clear();
  }

  // The server's log: its client joins, leaves (said, or closed on an
  // error) and refusals.
  void readServerLog(const std::filesystem::path& log) {
    std::ifstream in(log);
    for (std::string line; std::getline(in, line);) {
      if (line.rfind("[server] pod ", 0) == 0 || line.rfind("[server] closing pod ", 0) == 0) {
        if (line.find(") joined") != std::string::npos) {
          ++counts.server_pod_joins;
        } else if (line.find(") left (") != std::string::npos ||
                   line.rfind("[server] closing pod ", 0) == 0) {
          ++counts.server_pod_leaves;
        }
        continue;
      }
      // A client that vanished (killed) is closed on the error its
      // connection gave, not seen to leave: both end its session.
      if (line.rfind("[server] closing client ", 0) == 0) {
        ++counts.server_client_leaves;
        continue;
      }
      if (line.rfind("[server] client ", 0) != 0) {
        const auto refused = line.find(" refused so far)");
        if (line.rfind("[server] refusing ", 0) == 0 && refused != std::string::npos) {
          const auto open = line.rfind('(', refused);
          counts.server_refusals =
              std::max<uint64_t>(counts.server_refusals, std::stoull(line.substr(open + 1)));
        }
        continue;
      }
      if (line.find(") joined") != std::string::npos) ++counts.server_client_joins;
      if (line.find(") left (") != std::string::npos) ++counts.server_client_leaves;
    }
  }

  holofuse::deploy::ChurnCounts counts;

 private:
  struct Session {
    pid_t pid;
    bool bye;
    double kill_at;
    std::filesystem::path out;
  };

  void begin(double seconds) {
    const bool bye = counts.sessions % 2 == 0;
    const std::filesystem::path out =
        std::filesystem::path(plan_.out) / "churn" / ("session" + std::to_string(counts.sessions));
    auto command = clientCommand(plan_, endpoint_, 0);
    for (size_t i = 0; i + 1 < command.size(); ++i) {
      if (command[i] == "--out") command[i + 1] = out.string();
      if (command[i] == "--frames") command[i + 1] = bye ? "8" : "0";
    }
    const pid_t pid =
        spawn(rig_ ? rig_->inClient(0, command) : command, out.string() + ".log", /*quiet=*/true);
    ++counts.sessions;
    if (pid < 0) {
      ++counts.sessions_failed;
      return;
    }
    live_.push_back({pid, bye, seconds + 6.0, out});
  }

  void ended(const Session& session, int code) {
    // A killed session's exit is 128 + 9; a bye one's 0.
    if (session.bye && code == 0) {
      ++counts.sessions_bye;
    } else if (!session.bye && code == 128 + SIGKILL) {
      ++counts.sessions_killed;
    } else {
      ++counts.sessions_failed;
      std::fprintf(stderr, "[soak] churn session %s ended with %d; see %s.log\n",
                   session.out.filename().c_str(), code, session.out.c_str());
    }
    // Its pictures are not the soak's: only its log stays.
    std::error_code ignored;
    std::filesystem::remove_all(session.out, ignored);
  }

  void restartPod() {
    const size_t pod = processes_.pods.size() - 1;
    const bool killed = counts.pod_restarts % 2 == 1;
    if (killed) {
      ::kill(processes_.pods[pod], SIGKILL);
      holofuse::waitProcess(processes_.pods[pod], -1);
      ++counts.pod_restarts_killed;
    } else {
      stop(processes_.pods[pod], "capture_node");
    }
    const int id = static_cast<int>(pod);
    const auto command = podCommand(plan_, id, rig_ ? rig_->podEndpoint(id) : endpoint_);
    const pid_t again =
        spawn(rig_ ? rig_->inPod(id, command) : command,
              (std::filesystem::path(plan_.out) / "logs" / ("pod" + std::to_string(pod) + ".log"))
                  .string());
    processes_.pods[pod] = again;
    sampled_[1 + pod] = again;
    ++counts.pod_restarts;
  }

  // Pod 0's link down; restored kLinkCutSeconds later (or when the churn
  // finishes). Pod 0, not the restarting last pod: a link cut and a
  // restart are separate faults.
  static constexpr double kLinkCutSeconds = 5;
  void cutLink(double seconds) {
    if (const holofuse::Status cut = rig_->setPodLinkUp(0, false); !cut.isOk()) {
      ++counts.link_cut_failures;
      std::fprintf(stderr, "[soak] cannot cut pod 0's link: %s\n", cut.message().c_str());
      return;
    }
    ++counts.link_cuts;
    cut_until_ = seconds + kLinkCutSeconds;
  }
  void restoreLink() {
    cut_until_.reset();
    if (const holofuse::Status restored = rig_->setPodLinkUp(0, true); !restored.isOk()) {
      std::fprintf(stderr, "[soak] cannot restore pod 0's link: %s\n", restored.message().c_str());
      return;
    }
    ++counts.link_restores;
  }

  const LoopPlan& plan_;
  const std::string endpoint_;
  LoopProcesses& processes_;
  std::vector<pid_t>& sampled_;
  const holofuse::deploy::NetnsRig* rig_;
  std::vector<Session> live_;
  double next_ = 0;
  std::optional<double> cut_until_;
};

// A soak: the loop runs for plan.soak_minutes while every process is
// sampled each plan.sample_seconds, then stops and is judged
// (deploy/soak.h). Ctrl-C ends it early with the samples so far.
int superviseSoak(const LoopPlan& plan, LoopProcesses& processes, const std::string& endpoint,
                  const holofuse::deploy::HeapProfile* profile,
                  const holofuse::deploy::NetnsRig* rig) {
  holofuse::deploy::SoakReport report;
  std::vector<pid_t> pids = {processes.server};
  report.processes = {"server"};
  for (size_t i = 0; i < processes.pods.size(); ++i) {
    pids.push_back(processes.pods[i]);
    report.processes.push_back("pod " + std::to_string(i));
  }
  for (size_t i = 0; i < processes.clients.size(); ++i) {
    pids.push_back(processes.clients[i]);
    report.processes.push_back("client " + std::to_string(i));
  }
  char settings[256];
  std::snprintf(settings, sizeof(settings),
                "%d pods at %s and %.1f fps, %d clients in mode %s, %g minutes sampled every %g s",
                plan.shape.pods, plan.size.c_str(), plan.shape.fps, plan.clients,
                holofuse::render::blendModeName(plan.client.mode).c_str(), plan.soak_minutes,
                plan.sample_seconds);
  report.settings = settings;
  if (plan.churn) {
    char seconds[32];
    std::snprintf(seconds, sizeof(seconds), "%g", plan.churn_seconds);
    report.settings += "; churn: a client session every " + std::string(seconds) +
                       " s, the last pod restarted every fifth" +
                       (rig ? ", pod 0's link cut for 5 s every tenth" : "");
  }
  report.warmup_minutes = plan.warmup_minutes;
  std::optional<Churn> churn;
  if (plan.churn) {
    churn.emplace(plan, endpoint, processes, pids, rig);
    report.restarted = {"pod " + std::to_string(processes.pods.size() - 1)};
    std::error_code error;
    std::filesystem::create_directories(std::filesystem::path(plan.out) / "churn", error);
  }
  // Sampling starts once every process has reached its main and written
  // its heap: on a loaded machine a client can still be in the loader
  // (Vulkan and LLVM) at the first sample, present but not running yet.
  const auto launched = std::chrono::steady_clock::now();
  auto allRunning = [&] {
    for (pid_t pid : pids) {
      if (holofuse::pollProcess(pid).has_value()) continue;  // ended: sampled as gone
      const auto usage = holofuse::processUsage(pid);
      if (usage && !usage->heap_kb) return false;
    }
    return true;
  };
  while (!g_interrupted && !allRunning() &&
         std::chrono::steady_clock::now() - launched < std::chrono::minutes(1)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  Watch watch;
  bool profile_marked = false;
  const auto start = std::chrono::steady_clock::now();
  auto minutes = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / 60.0;
  };
  double next_sample = plan.sample_seconds / 60.0;
  // The report is rewritten every few minutes, so a soak cut short (the
  // machine restarted, the launcher killed) still leaves its figures.
  constexpr double kReportEveryMinutes = 5;
  double next_report = kReportEveryMinutes, next_line = 0;
  while (!g_interrupted && minutes() < plan.soak_minutes + 1e-9) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (churn) churn->step(minutes() * 60.0);
    if (minutes() < next_sample) continue;
    next_sample += plan.sample_seconds / 60.0;
    holofuse::deploy::SoakSample sample;
    sample.minute = minutes();
    sample.sessions = churn ? churn->counts.sessions : 0;
    for (pid_t pid : pids) {
      // A process that ended is gone, not a zombie's numbers.
      const bool ended = holofuse::pollProcess(pid).has_value();
      sample.usage.push_back(ended ? std::nullopt : holofuse::processUsage(pid));
    }
    report.samples.push_back(sample);
    // The heap trace as it stands when judging begins: what grows after it
    // is what the profile names.
    if (profile != nullptr && !profile_marked && sample.minute >= plan.warmup_minutes) {
      if (const holofuse::Status marked = profile->mark("warm"); marked.isOk()) {
        profile_marked = true;
      } else {
        report.heap_profile_problem = marked.message();
        profile = nullptr;
      }
    }
    if (sample.minute >= next_report) {
      next_report += kReportEveryMinutes;
      report.verdict = holofuse::deploy::judgeSoak(report.processes, report.samples,
                                                   plan.warmup_minutes, report.restarted);
      holofuse::deploy::writeSoakReport(report, plan.out);
    }
    // A line a minute, whatever the sampling.
    if (sample.minute < next_line) continue;
    next_line = std::floor(sample.minute) + 1;
    uint64_t pods_kb = 0, clients_kb = 0;
    for (size_t i = 1; i < pids.size(); ++i) {
      const uint64_t kb = sample.usage[i] ? sample.usage[i]->rss_kb : 0;
      (i <= processes.pods.size() ? pods_kb : clients_kb) += kb;
    }
    const auto& server = sample.usage[0];
    std::printf(
        "[soak] minute %.0f of %g (%s): server %.1f MB, %d descriptors, %d threads; pods "
        "%.1f MB in all; clients %.1f MB in all\n",
        std::floor(sample.minute), plan.soak_minutes,
        holofuse::Eta::text(
            1.0, static_cast<size_t>(std::max(0.0, (plan.soak_minutes - sample.minute) * 60.0)))
            .c_str(),
        server ? server->rss_kb / 1024.0 : 0.0, server ? server->descriptors : 0,
        server ? server->threads : 0, pods_kb / 1024.0, clients_kb / 1024.0);
    if (churn) {
      std::printf("[soak]   churn so far: %llu client sessions, %llu pod restarts\n",
                  static_cast<unsigned long long>(churn->counts.sessions),
                  static_cast<unsigned long long>(churn->counts.pod_restarts));
    }
    std::fflush(stdout);
  }
  report.verdict = holofuse::deploy::judgeSoak(report.processes, report.samples,
                                               plan.warmup_minutes, report.restarted);
  if (churn) {
    // The last sessions end; the server then holds what it held before
    // they came: its descriptors and threads are waited for (at most 30 s)
    // to come back to where they were when the first session began.
    churn->finish();
    holofuse::deploy::ChurnCounts& counts = churn->counts;
    for (int i = 0; i < 300; ++i) {
      const auto now = holofuse::processUsage(processes.server);
      if (!now) break;
      counts.descriptors_end = now->descriptors;
      counts.threads_end = now->threads;
      if (now->descriptors <= counts.descriptors_start && now->threads <= counts.threads_start)
        break;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    if (counts.descriptors_end > counts.descriptors_start ||
        counts.threads_end > counts.threads_start) {
      report.verdict.problems.push_back(
          "the server held " + std::to_string(counts.descriptors_end) + " descriptors and " +
          std::to_string(counts.threads_end) + " threads 30 s after the last session left, " +
          std::to_string(counts.descriptors_start) + " and " +
          std::to_string(counts.threads_start) + " before the sessions");
      report.verdict.passed = report.verdict.flat = false;
    }
  }
  const bool profiled = profile != nullptr && profile_marked && [&] {
    const holofuse::Status marked = profile->mark("end");
    if (!marked.isOk()) report.heap_profile_problem = marked.message();
    return marked.isOk();
  }();
  std::printf("[soak] stopping every process\n");
  processes.stopAll();
  if (profiled) {
    std::printf("[soak] reading the server's heap trace (heaptrack_interpret, heaptrack_print)\n");
    std::fflush(stdout);
    auto growth = profile->growth("warm", "end");
    if (growth.isOk()) {
      report.heap_growth = std::move(growth.value());
      std::printf("[soak] the server's heap grew by %.1f KB after the warm-up; most by:\n",
                  report.heap_growth->total_bytes / 1e3);
      for (size_t i = 0; i < std::min<size_t>(3, report.heap_growth->sites.size()); ++i) {
        const auto& site = report.heap_growth->sites[i];
        std::printf("[soak]   %.1f KB from %s (%s)\n", site.bytes / 1e3, site.function.c_str(),
                    site.location.c_str());
      }
    } else {
      report.heap_profile_problem = growth.status().message();
    }
  } else if (profile != nullptr && report.heap_profile_problem.empty()) {
    report.heap_profile_problem = "the soak ended before its warm-up did";
  }
  if (!report.heap_profile_problem.empty())
    std::fprintf(stderr, "[soak] no heap profile: %s\n", report.heap_profile_problem.c_str());
  if (churn) {
    churn->readServerLog(std::filesystem::path(plan.out) / "logs" / "server.log");
    report.churn = churn->counts;
    const auto& c = churn->counts;
    std::printf(
        "[soak] churn: %llu client sessions (%llu bye, %llu killed, %llu otherwise), %llu pod "
        "restarts; the server logged %llu client joins and %llu leaves\n",
        static_cast<unsigned long long>(c.sessions),
        static_cast<unsigned long long>(c.sessions_bye),
        static_cast<unsigned long long>(c.sessions_killed),
        static_cast<unsigned long long>(c.sessions_failed),
        static_cast<unsigned long long>(c.pod_restarts),
        static_cast<unsigned long long>(c.server_client_joins),
        static_cast<unsigned long long>(c.server_client_leaves));
  }
  const bool written = holofuse::deploy::writeSoakReport(report, plan.out);
  std::printf("[soak] %s; report in %s/soak.md, soak.html, soak.json\n",
              report.verdict.flat     ? "flat after the warm-up"
              : report.verdict.passed ? "nothing leaking, not all decided"
                                      : "NOT passed",
              plan.out.c_str());
  for (const std::string& problem : report.verdict.problems)
    std::printf("[soak]   %s\n", problem.c_str());
  for (const std::string& line : report.verdict.undecided)
    std::printf("[soak]   %s\n", line.c_str());
  return report.verdict.passed && written ? 0 : 1;
}

}  // namespace

int runLoop(LoopPlan& plan) {
  namespace fs = std::filesystem;
  const fs::path logs = fs::path(plan.out) / "logs";
  fs::create_directories(logs);
  const std::string port_file = (logs / "server.port").string();
  fs::remove(port_file);
  plan.key_dir = (logs / "keys").string();
  fs::remove_all(plan.key_dir);
  std::vector<uint32_t> client_ids = {0};
  if (plan.rig && !plan.rig->clients.empty()) {
    client_ids.clear();
    for (const auto& client : plan.rig->clients) client_ids.push_back(client.id);
  }
  if (const auto made = holofuse::protocol::KeyRing::writeRig(
          plan.key_dir, static_cast<uint32_t>(plan.shape.pods), client_ids);
      !made.isOk()) {
    std::fprintf(stderr, "[loop] cannot make this run's keys: %s\n",
                 made.status().message().c_str());
    return 1;
  }
  // The keys are this run's only: gone when the launcher returns.
  struct RemoveKeys {
    std::string path;
    ~RemoveKeys() { std::filesystem::remove_all(path); }
  } remove_keys{plan.key_dir};

  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);

  // A rig: the namespaces and links first; they are gone when this returns,
  // or, should the launcher be killed, when its reaper sees it end.
  std::unique_ptr<holofuse::deploy::NetnsRig> rig;
  if (plan.netns) {
    auto built = holofuse::deploy::NetnsRig::build(
        {plan.shape.pods, plan.clients, plan.link, plan.pod_links, plan.client_links,
         plan.bin_dir + "/holofuse_relay", logs.string()});
    if (!built.isOk()) {
      std::fprintf(stderr, "[rig] cannot build the rig: %s\n", built.status().message().c_str());
      return 1;
    }
    rig = std::move(*built);
    plan.listen_host = rig->serverAddress();
    std::printf("[rig] %s\n", rig->describe().c_str());
  }
  // A soak's children write their heap in use for its samples to read
  // (base/process.h), beside their resident size.
  if (plan.soak_minutes > 0) {
    const std::string heap = (std::filesystem::path(plan.out) / "logs" / "heap").string();
    std::error_code error;
    std::filesystem::create_directories(heap, error);
    ::setenv(holofuse::kHeapStatsDirEnv, heap.c_str(), 1);
  }
  // Which copy runs, where a build and an install both exist.
  std::fprintf(stderr, "[loop] programs from %s\n", plan.bin_dir.c_str());
  LoopProcesses processes;
  auto server_command = serverCommand(plan, port_file);
  std::optional<holofuse::deploy::HeapProfile> profile;
  if (plan.profile) {
    auto found =
        holofuse::deploy::HeapProfile::find((std::filesystem::path(plan.out) / "profile").string());
    if (!found.isOk()) {
      std::fprintf(stderr, "[loop] %s\n", found.status().message().c_str());
      return 2;
    }
    profile = std::move(found.value());
    server_command = profile->wrap(server_command);
  }
  processes.server =
      spawn(rig ? rig->inServer(server_command) : server_command, (logs / "server.log").string());
  if (processes.server < 0) return 1;
  const std::string bound = awaitServerPort(processes, port_file, plan.out);
  if (bound.empty()) {
    processes.stopAll();
    return 1;
  }
  const std::string endpoint = plan.listen_host + ":" + bound;
  if (rig) {
    if (const holofuse::Status relays = rig->startRelays(bound); !relays.isOk()) {
      std::fprintf(stderr, "[rig] %s\n", relays.message().c_str());
      processes.stopAll();
      return 1;
    }
  }
  const std::string source = plan.replay.empty()
                                 ? "scene " + plan.scene.name
                                 : "replay of " + plan.replay + " at speed " + plan.speed;
  std::printf("[loop] server on %s, %s, %d pods at %s, %.1f fps; writing %s\n", endpoint.c_str(),
              source.c_str(), plan.shape.pods, plan.size.c_str(), plan.shape.fps, plan.out.c_str());
  std::fflush(stdout);
  for (int i = 0; i < plan.shape.pods; ++i) {
    const auto command = podCommand(plan, i, rig ? rig->podEndpoint(i) : endpoint);
    const pid_t pod = spawn(rig ? rig->inPod(i, command) : command,
                            (logs / ("pod" + std::to_string(i) + ".log")).string());
    if (pod < 0) {
      processes.stopAll();
      return 1;
    }
    processes.pods.push_back(pod);
  }
  for (int i = 0; i < plan.clients; ++i) {
    const auto command = clientCommand(plan, rig ? rig->clientEndpoint(i) : endpoint, i);
    const pid_t client =
        spawn(rig ? rig->inClient(i, command) : command, clientLog(plan, i).string());
    if (client < 0) {
      processes.stopAll();
      return 1;
    }
    processes.clients.push_back(client);
  }
  if (plan.soak_minutes > 0)
    return superviseSoak(plan, processes, rig ? rig->clientEndpoint(0) : endpoint,
                         profile ? &*profile : nullptr, rig.get());
  const int code = superviseLoop(plan, processes);
  if (rig) {
    printLinks(plan);
    if (const holofuse::Status gone = rig->tearDown(); gone.isOk()) {
      std::printf("[rig] namespaces, links and relays removed\n");
    } else {
      std::fprintf(stderr, "[rig] %s\n", gone.message().c_str());
      return 1;
    }
  }
  return code;
}

}  // namespace holofuse::deploy

#include "base/process.h"

#include <fcntl.h>
#include <malloc.h>
#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <sstream>
#include <thread>

namespace holofuse {

namespace {

void closeAll(std::initializer_list<int> fds) {
  for (const int fd : fds)
    if (fd >= 0) ::close(fd);
}

}  // namespace

std::string findProgram(const std::string& name, const std::vector<std::string>& also_in) {
  std::vector<std::string> folders;
  const char* path = std::getenv("PATH");
  std::stringstream listed(path != nullptr ? path : "/usr/bin:/bin");
  for (std::string folder; std::getline(listed, folder, ':');)
    if (!folder.empty()) folders.push_back(folder);
  folders.insert(folders.end(), also_in.begin(), also_in.end());
  for (const std::string& folder : folders) {
    const std::filesystem::path candidate = std::filesystem::path(folder) / name;
    std::error_code error;
    if (std::filesystem::is_regular_file(candidate, error) &&
        ::access(candidate.c_str(), X_OK) == 0)
      return candidate.string();
  }
  return "";
}

StatusOr<pid_t> spawnProcess(const std::vector<std::string>& args, const SpawnOptions& options,
                             ChildPipes* pipes) {
  if (args.empty() || args[0].empty()) return Status(StatusCode::kMalformed, "no program to start");
  int to_child[2] = {-1, -1}, from_child[2] = {-1, -1};
  if (pipes != nullptr &&
      (::pipe2(to_child, O_CLOEXEC) != 0 || ::pipe2(from_child, O_CLOEXEC) != 0)) {
    const int error = errno;
    closeAll({to_child[0], to_child[1], from_child[0], from_child[1]});
    return Status(StatusCode::kIoError, "cannot start " + args[0] + ": " + std::strerror(error));
  }
  int log_fd = -1;
  if (!options.log_path.empty()) {
    log_fd = ::open(options.log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (log_fd < 0) {
      const int error = errno;
      closeAll({to_child[0], to_child[1], from_child[0], from_child[1]});
      return Status(StatusCode::kIoError, "cannot start " + args[0] + ": its log " +
                                              options.log_path + ": " + std::strerror(error));
    }
  }
  // The child reports a failed exec through this pipe; a successful exec
  // closes it (close-on-exec), so the parent reads nothing.
  int report[2];
  if (::pipe2(report, O_CLOEXEC) != 0) {
    const int error = errno;
    closeAll({log_fd, to_child[0], to_child[1], from_child[0], from_child[1]});
    return Status(StatusCode::kIoError, "cannot start " + args[0] + ": " + std::strerror(error));
  }
  // Everything the child touches is made before fork: between fork and
  // exec only async-signal-safe calls.
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid == 0) {
    if (options.ignore_interrupt) ::signal(SIGINT, SIG_IGN);
    // A parent that died before the prctl took effect: go at once.
    if (options.die_with_parent &&
        (::prctl(PR_SET_PDEATHSIG, SIGTERM) != 0 || ::getppid() != parent))
      ::_exit(127);
    if (log_fd >= 0) {
      ::dup2(log_fd, STDERR_FILENO);
      if (options.stdout_to_log) ::dup2(log_fd, STDOUT_FILENO);
    }
    if (pipes != nullptr) {  // dup2 clears close-on-exec on the copies
      ::dup2(to_child[0], STDIN_FILENO);
      ::dup2(from_child[1], STDOUT_FILENO);
    }
    ::execv(argv[0], argv.data());
    const int error = errno;
    [[maybe_unused]] const ssize_t written = ::write(report[1], &error, sizeof(error));
    ::_exit(127);
  }
  const int fork_error = errno;
  ::close(report[1]);
  closeAll({log_fd, to_child[0], from_child[1]});  // the child's ends
  if (pid < 0) {
    closeAll({report[0], to_child[1], from_child[0]});
    return Status(StatusCode::kIoError,
                  "cannot start " + args[0] + ": " + std::strerror(fork_error));
  }
  int exec_error = 0;
  ssize_t got = 0;
  do {
    got = ::read(report[0], &exec_error, sizeof(exec_error));
  } while (got < 0 && errno == EINTR);
  ::close(report[0]);
  if (got == static_cast<ssize_t>(sizeof(exec_error))) {
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    closeAll({to_child[1], from_child[0]});
    return Status(StatusCode::kIoError,
                  "cannot start " + args[0] + ": " + std::strerror(exec_error));
  }
  if (pipes != nullptr) *pipes = {to_child[1], from_child[0]};
  return pid;
}

int exitCodeOf(int wait_status) {
  if (WIFEXITED(wait_status)) return WEXITSTATUS(wait_status);
  if (WIFSIGNALED(wait_status)) return 128 + WTERMSIG(wait_status);
  return -1;
}

std::optional<int> pollProcess(pid_t pid) {
  int status = 0;
  pid_t got = 0;
  do {
    got = ::waitpid(pid, &status, WNOHANG);
  } while (got < 0 && errno == EINTR);
  if (got == pid) return exitCodeOf(status);
  return std::nullopt;
}

std::optional<int> waitProcess(pid_t pid, int timeout_ms) {
  if (timeout_ms < 0) {
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0) {
      if (errno != EINTR) return -1;  // not our child: nothing to wait for
    }
    return exitCodeOf(status);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  for (;;) {
    if (const auto code = pollProcess(pid)) return code;
    if (std::chrono::steady_clock::now() >= deadline) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

FinishedProcess runToEnd(const std::vector<std::string>& args, int timeout_ms) {
  FinishedProcess finished;
  char errors_path[] = "/tmp/holofuse_run_XXXXXX";
  const int errors_fd = ::mkstemp(errors_path);
  if (errors_fd < 0) {
    finished.errors = std::string("cannot make a file for its stderr: ") + std::strerror(errno);
    return finished;
  }
  ::close(errors_fd);
  SpawnOptions options;
  options.log_path = errors_path;
  ChildPipes pipes;
  const auto pid = spawnProcess(args, options, &pipes);
  if (pid.isOk()) {
    ::close(pipes.to_child);
    char buffer[4096];
    for (ssize_t n; (n = ::read(pipes.from_child, buffer, sizeof buffer)) != 0;) {
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) break;
      finished.output.append(buffer, static_cast<size_t>(n));
    }
    ::close(pipes.from_child);
    if (const std::optional<int> code = waitProcess(*pid, timeout_ms)) {
      finished.exit_code = *code;
    } else {
      stopProcess(*pid, 0);  // past its time: killed, reaped, and -1
    }
  }
  std::ifstream errors(errors_path);
  finished.errors.assign(std::istreambuf_iterator<char>(errors), std::istreambuf_iterator<char>());
  ::unlink(errors_path);
  if (!pid.isOk()) finished.errors = pid.status().message();
  return finished;
}

StoppedProcess stopProcess(pid_t pid, int grace_ms) {
  StoppedProcess stopped;
  if (const auto code = pollProcess(pid)) {
    stopped.exit_code = *code;
    return stopped;
  }
  ::kill(pid, SIGTERM);
  if (const auto code = waitProcess(pid, grace_ms)) {
    stopped.exit_code = *code;
    return stopped;
  }
  ::kill(pid, SIGKILL);
  stopped.killed = true;
  stopped.exit_code = waitProcess(pid, -1).value_or(-1);
  return stopped;
}

std::optional<ProcessUsage> processUsage(pid_t pid) {
  const std::string dir = "/proc/" + std::to_string(pid);
  std::ifstream status(dir + "/status");
  if (!status) return std::nullopt;
  ProcessUsage usage;
  for (std::string line; std::getline(status, line);) {
    const auto field = [&](const char* name, auto& value) {
      if (line.rfind(name, 0) == 0)
        value = static_cast<std::decay_t<decltype(value)>>(
            std::strtoull(line.c_str() + std::strlen(name), nullptr, 10));
    };
    field("VmRSS:", usage.rss_kb);
    field("VmHWM:", usage.peak_rss_kb);
    field("Threads:", usage.threads);
  }
  std::error_code error;
  for (std::filesystem::directory_iterator it(dir + "/fd", error), end; !error && it != end;
       it.increment(error))
    ++usage.descriptors;
  if (error) return std::nullopt;
  if (const char* heap_dir = std::getenv(kHeapStatsDirEnv); heap_dir != nullptr) {
    std::ifstream heap(std::string(heap_dir) + "/" + std::to_string(pid));
    uint64_t bytes = 0;
    if (heap >> bytes) usage.heap_kb = bytes / 1024;
  }
  return usage;
}

namespace {

// This process's heap in use into dir/<pid>, whole or not at all (written
// aside, then renamed over the last).
void writeHeapInUse(const std::string& dir) {
  const struct mallinfo2 info = mallinfo2();
  const std::string path = dir + "/" + std::to_string(getpid());
  {
    std::ofstream out(path + ".part");
    out << info.uordblks + info.hblkhd << "\n";
    if (!out) return;
  }
  std::rename((path + ".part").c_str(), path.c_str());
}

}  // namespace

FreeMemoryReturner::FreeMemoryReturner(std::chrono::milliseconds period) {
  // Fixed thresholds also turn off glibc's dynamic ones. Buffers up to the
  // largest threshold glibc takes (32 MiB) come from the heap, and free
  // memory at its top stays until the thread returns it.
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  const char* heap_dir = std::getenv(kHeapStatsDirEnv);
  thread_ = std::thread([this, period, heap = std::string(heap_dir ? heap_dir : "")] {
    std::unique_lock lock(mutex_);
    if (!heap.empty()) writeHeapInUse(heap);
    while (!wake_.wait_for(lock, period, [this] { return stopping_; })) {
      lock.unlock();
      returnFreeMemoryNow();
      if (!heap.empty()) writeHeapInUse(heap);
      lock.lock();
    }
  });
}

FreeMemoryReturner::~FreeMemoryReturner() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_one();
  thread_.join();
}

bool returnFreeMemoryNow() { return malloc_trim(0) != 0; }

bool scheduleThisThreadAsBatch() {
  sched_param parameters{};
  parameters.sched_priority = 0;  // the only priority SCHED_BATCH has
  return pthread_setschedparam(pthread_self(), SCHED_BATCH, &parameters) == 0;
}

bool askForTimeSlice(std::chrono::nanoseconds slice) {
  constexpr uint64_t kKeepPolicy = 0x08;  // SCHED_FLAG_KEEP_POLICY (Linux 5.3)
  // glibc 2.36 has no sched_setattr wrapper; the layout is the kernel's
  // (include/uapi/linux/sched/types.h, version 1: 56 bytes).
  struct {
    uint32_t size, policy;
    uint64_t flags;
    int32_t nice;
    uint32_t priority;
    uint64_t runtime, deadline, period;
    uint32_t util_min, util_max;
  } attributes{};
  attributes.size = sizeof(attributes);
  attributes.flags = kKeepPolicy;  // a pod started under chrt keeps its policy
  attributes.nice = getpriority(PRIO_PROCESS, static_cast<id_t>(gettid()));
  attributes.runtime = static_cast<uint64_t>(slice.count());
  return syscall(SYS_sched_setattr, 0, &attributes, 0) == 0;
}

}  // namespace holofuse

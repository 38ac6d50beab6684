// Child processes, the one way every program and test starts them: the
// launcher its pods, server and client, the sweep its live runs, the
// integration tests the real executables.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "base/status.h"

namespace holofuse {

struct SpawnOptions {
  // Where the child's output goes ("" : where the parent's goes).
  std::string log_path;
  // false: only its stderr goes to the log, its stdout stays the parent's
  // (a program whose progress the user watches).
  bool stdout_to_log = true;
  // The child ignores SIGINT: a Ctrl-C at the terminal reaches the parent,
  // which decides when its children stop.
  bool ignore_interrupt = false;
  // The child is sent SIGTERM when the thread that started it ends (Linux
  // PR_SET_PDEATHSIG): a launcher killed with SIGKILL does not leave its
  // server, pods and client running on. Only for children started from a
  // thread that lives as long as they should.
  bool die_with_parent = false;
};

// A child's stdin and stdout as pipes to the parent (spawnProcess's last
// argument): to_child is written, from_child read; both close-on-exec in
// the parent, and the parent closes them.
struct ChildPipes {
  int to_child = -1;
  int from_child = -1;
};

// Starts args[0] with args: its pid, or an error naming the program and
// why it did not start (no such file, not executable, the log not
// writable); a program that cannot start is never a running child. With
// pipes, the child's stdin and stdout are pipes to the parent (its stdout
// then never goes to the log), filled in only when the child started.
StatusOr<pid_t> spawnProcess(const std::vector<std::string>& args, const SpawnOptions& options = {},
                             ChildPipes* pipes = nullptr);

// The first executable file called name in PATH's folders, then in
// also_in (folders a user's PATH may lack, such as /usr/sbin): its path,
// or "" when there is none. spawnProcess does not search PATH.
std::string findProgram(const std::string& name, const std::vector<std::string>& also_in = {});

// How a waited-for process ended: its exit code, or 128 + the signal that
// killed it (as a shell reports it).
int exitCodeOf(int wait_status);

// Its exit code once it has ended (and is reaped); nullopt while it runs.
std::optional<int> pollProcess(pid_t pid);

// Waits for it to end: its exit code, or nullopt when it still runs after
// timeout_ms (negative: no limit).
std::optional<int> waitProcess(pid_t pid, int timeout_ms);

// A short program run to its end: what it said on stdout and on stderr,
// and its exit code (-1 when it did not start, errors then saying why, or
// did not end within timeout_ms, when it is killed).
struct FinishedProcess {
  int exit_code = -1;
  std::string output, errors;
};
FinishedProcess runToEnd(const std::vector<std::string>& args, int timeout_ms);

struct StoppedProcess {
  int exit_code = 0;
  bool killed = false;  // it ignored SIGTERM for the grace period and got SIGKILL
};

// SIGTERM, then SIGKILL after grace_ms; reaped either way. A process that
// had already ended is only reaped.
StoppedProcess stopProcess(pid_t pid, int grace_ms);

// What a running process holds, read from /proc/<pid>: resident memory
// now and at its peak, open descriptors, threads; nullopt once it is gone.
// The fault tests and the soak compare these with a baseline.
struct ProcessUsage {
  uint64_t rss_kb = 0;       // VmRSS
  uint64_t peak_rss_kb = 0;  // VmHWM
  int descriptors = 0;       // entries of /proc/<pid>/fd
  int threads = 0;           // Threads
  // The heap the program holds (malloc's bytes in use, mallinfo2), as its
  // FreeMemoryReturner last wrote it under kHeapStatsDirEnv; nullopt when
  // it writes none. Beside RSS it tells the allocator's retained pages
  // from what the program holds.
  std::optional<uint64_t> heap_kb;
};
std::optional<ProcessUsage> processUsage(pid_t pid);

// Where a FreeMemoryReturner writes its process's heap in use each period
// (a file named by the pid, its decimal bytes), when set in its
// environment; processUsage reads it from the same variable's folder.
inline constexpr const char* kHeapStatsDirEnv = "HOLOFUSE_HEAP_STATS_DIR";

// For the long-running programs: freed buffers (images, meshes, frames)
// stay with the process and the next frame reuses them, and once a period
// a thread hands whatever is free back to the system (malloc_trim), so the
// resident size follows what is held, not the worst moment. Unmapping each
// buffer as it is freed instead makes every frame fault its buffers in
// again page by page: in the demo loop a third of all CPU time went to the
// kernel's page faults (docs/reliability.md "Memory").
class FreeMemoryReturner {
 public:
  explicit FreeMemoryReturner(std::chrono::milliseconds period = std::chrono::seconds(1));
  ~FreeMemoryReturner();
  FreeMemoryReturner(const FreeMemoryReturner&) = delete;
  FreeMemoryReturner& operator=(const FreeMemoryReturner&) = delete;

 private:
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::thread thread_;
};

// What the returner does each period: every arena's free pages go back to
// the system. Returns whether any did.
bool returnFreeMemoryNow();

// Marks the calling thread as throughput work (Linux SCHED_BATCH): it gets
// its fair share of the cores, but waking it never preempts the thread
// that woke it. For a thread that works off a queue behind a latency-
// critical one (the client's picture writer): on a loaded machine, waking
// it would otherwise take the core from the frame loop mid-frame. Returns
// false where the system refuses; the thread then runs as before.
bool scheduleThisThreadAsBatch();

// Asks the scheduler for a longer time slice for the calling thread
// (Linux 6.12 and later: EEVDF's custom slice, sched_attr::sched_runtime,
// 0.1 to 100 ms; the default is 0.7 ms times 1 + log2 of the cores). Its
// fair share is unchanged, and its policy and nice are kept. A thread that
// works in short bursts (a pod's frame) then finishes a burst in one run,
// not cut at the next tick once the default slice is spent; a waking
// thread with a shorter slice may still preempt it, and a longer slice
// also makes it wait longer to be picked when it wakes. Returns false
// where the system refuses the call; kernels before 6.12 take it and
// ignore the slice.
bool askForTimeSlice(std::chrono::nanoseconds slice);
// The slices Linux keeps: it clamps a request to this range.
constexpr std::chrono::nanoseconds kMinTimeSlice = std::chrono::microseconds(100);
constexpr std::chrono::nanoseconds kMaxTimeSlice = std::chrono::milliseconds(100);

}  // namespace holofuse

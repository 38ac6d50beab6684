// The one way the project starts child processes: output where asked, exit
// codes as a shell reports them, a program that cannot start named as an
// error, and a stop that ends even a child that ignores SIGTERM.
#include <gtest/gtest.h>
#include <sched.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "base/process.h"

namespace holofuse {
namespace {

namespace fs = std::filesystem;

fs::path logIn(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("holofuse_process_" + std::to_string(getpid()));
  fs::create_directories(dir);
  return dir / name;
}

std::string contents(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// findProgram: PATH's folders first, then the ones given; only an
// executable file counts; "" when there is none.
TEST(Process, FindProgramSearchesPathThenTheFoldersGiven) {
  const fs::path dir = fs::temp_directory_path() / ("find_program_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "first");
  fs::create_directories(dir / "second");
  auto write = [](const fs::path& file, fs::perms perms) {
    std::ofstream(file) << "#!/bin/sh\n";
    fs::permissions(file, perms);
  };
  write(dir / "first" / "tool", fs::perms::owner_read | fs::perms::owner_exec);
  write(dir / "second" / "tool", fs::perms::owner_read | fs::perms::owner_exec);
  write(dir / "first" / "plain", fs::perms::owner_read);  // not executable
  write(dir / "second" / "extra", fs::perms::owner_read | fs::perms::owner_exec);
  const char* was = std::getenv("PATH");
  const std::string saved = was != nullptr ? was : "";
  ::setenv("PATH", ((dir / "first").string() + ":" + (dir / "second").string()).c_str(), 1);
  EXPECT_EQ(findProgram("tool"), (dir / "first" / "tool").string());
  EXPECT_EQ(findProgram("plain"), "");
  EXPECT_EQ(findProgram("extra"), (dir / "second" / "extra").string());
  ::setenv("PATH", (dir / "first").string().c_str(), 1);
  EXPECT_EQ(findProgram("extra"), "");
  EXPECT_EQ(findProgram("extra", {(dir / "second").string()}), (dir / "second" / "extra").string());
  EXPECT_EQ(findProgram("no_such_program_anywhere", {(dir / "second").string()}), "");
  ::setenv("PATH", saved.c_str(), 1);
  fs::remove_all(dir);
}

TEST(Process, OutputGoesToTheLogAndTheExitCodeComesBack) {
  const fs::path log = logIn("both.log");
  SpawnOptions options;
  options.log_path = log.string();
  const auto pid =
      spawnProcess({"/bin/sh", "-c", "echo to-stdout; echo to-stderr >&2; exit 3"}, options);
  ASSERT_TRUE(pid.isOk()) << pid.status().message();
  EXPECT_EQ(waitProcess(*pid, -1), 3);
  const std::string text = contents(log);
  EXPECT_NE(text.find("to-stdout"), std::string::npos) << text;
  EXPECT_NE(text.find("to-stderr"), std::string::npos) << text;
}

TEST(Process, StdoutCanStayTheParentsWhileStderrIsLogged) {
  const fs::path log = logIn("stderr.log");
  SpawnOptions options;
  options.log_path = log.string();
  options.stdout_to_log = false;
  const auto pid =
      spawnProcess({"/bin/sh", "-c", "echo to-stdout >/dev/null; echo to-stderr >&2"}, options);
  ASSERT_TRUE(pid.isOk());
  EXPECT_EQ(waitProcess(*pid, -1), 0);
  EXPECT_EQ(contents(log), "to-stderr\n");
}

TEST(Process, AProgramThatCannotStartIsAnErrorThatNamesIt) {
  const auto missing = spawnProcess({"/nonexistent/holofuse_program", "--flag"});
  ASSERT_FALSE(missing.isOk());
  EXPECT_NE(missing.status().message().find("/nonexistent/holofuse_program"), std::string::npos);
  EXPECT_NE(missing.status().message().find("No such file"), std::string::npos)
      << missing.status().message();
  SpawnOptions unwritable;
  unwritable.log_path = "/nonexistent/folder/log.txt";
  const auto no_log = spawnProcess({"/bin/true"}, unwritable);
  ASSERT_FALSE(no_log.isOk());
  EXPECT_NE(no_log.status().message().find("/nonexistent/folder/log.txt"), std::string::npos);
  EXPECT_FALSE(spawnProcess({}).isOk());
}

TEST(Process, AnIgnoredInterruptLeavesTheChildRunning) {
  SpawnOptions ignoring;
  ignoring.ignore_interrupt = true;
  const auto kept = spawnProcess({"/bin/sh", "-c", "kill -INT $$; exit 7"}, ignoring);
  ASSERT_TRUE(kept.isOk());
  EXPECT_EQ(waitProcess(*kept, -1), 7);
  const auto interrupted = spawnProcess({"/bin/sh", "-c", "kill -INT $$; exit 7"});
  ASSERT_TRUE(interrupted.isOk());
  EXPECT_EQ(waitProcess(*interrupted, -1), 128 + SIGINT);
}

// A child started to die with its parent is sent SIGTERM when the thread
// that started it ends (a launcher killed outright leaves no rig running);
// one started without it runs on.
TEST(Process, AChildThatDiesWithItsParentGoesWhenItsStarterEnds) {
  pid_t tied = -1, free = -1;
  std::thread starter([&] {
    SpawnOptions options;
    options.die_with_parent = true;
    const auto started = spawnProcess({"/bin/sleep", "60"}, options);
    if (started.isOk()) tied = *started;
    const auto other = spawnProcess({"/bin/sleep", "60"});
    if (other.isOk()) free = *other;
  });
  starter.join();
  ASSERT_GT(tied, 0);
  ASSERT_GT(free, 0);
  EXPECT_EQ(waitProcess(tied, 10000), 128 + SIGTERM) << "still running after its starter ended";
  EXPECT_EQ(waitProcess(free, 0), std::nullopt) << "the other one runs on";
  stopProcess(free, 0);
}

TEST(Process, StopEndsAChildAndKillsOneThatIgnoresTerm) {
  const auto polite = spawnProcess({"/bin/sleep", "100"});
  ASSERT_TRUE(polite.isOk());
  EXPECT_FALSE(pollProcess(*polite)) << "sleep 100 is still running";
  const StoppedProcess stopped = stopProcess(*polite, 60000);
  EXPECT_FALSE(stopped.killed);
  EXPECT_EQ(stopped.exit_code, 128 + SIGTERM);
  // An ignored signal stays ignored across fork and exec: this sleep
  // ignores TERM from its first instruction.
  const auto previous = std::signal(SIGTERM, SIG_IGN);
  const auto stubborn = spawnProcess({"/bin/sleep", "100"});
  std::signal(SIGTERM, previous);
  ASSERT_TRUE(stubborn.isOk());
  const StoppedProcess killed = stopProcess(*stubborn, 200);
  EXPECT_TRUE(killed.killed);
  EXPECT_EQ(killed.exit_code, 128 + SIGKILL);
}

// What a process holds, as the fault tests and the soak watch it: each
// field moves with what it counts, and a process that is gone has none.
TEST(Process, UsageCountsDescriptorsThreadsAndMemory) {
  const auto before = processUsage(getpid());
  ASSERT_TRUE(before.has_value());
  EXPECT_GT(before->rss_kb, 0u);
  EXPECT_GE(before->peak_rss_kb, before->rss_kb);
  const int fd = ::dup(STDERR_FILENO);
  ASSERT_GE(fd, 0);
  std::vector<char> touched(64u << 20, 1);  // 64 MiB written: resident
  bool release = false;
  std::mutex mutex;
  std::condition_variable changed;
  std::thread sleeper([&] {
    std::unique_lock lock(mutex);
    changed.wait(lock, [&] { return release; });
  });
  const auto during = processUsage(getpid());
  {
    std::lock_guard lock(mutex);
    release = true;
  }
  changed.notify_all();
  sleeper.join();
  ::close(fd);
  ASSERT_TRUE(during.has_value());
  EXPECT_EQ(during->descriptors, before->descriptors + 1);
  EXPECT_EQ(during->threads, before->threads + 1);
  EXPECT_GE(during->rss_kb, before->rss_kb + 60u * 1024) << touched[touched.size() / 2];

  const pid_t child = fork();
  if (child == 0) _exit(0);
  ASSERT_EQ(waitProcess(child, 10000), std::optional<int>(0));
  EXPECT_FALSE(processUsage(child).has_value()) << "a process that is gone holds nothing";
}

// A freed frame buffer stays resident for the next frame, so reusing it
// faults nothing in; the returner's pass hands it back to the system. (The
// period is an hour here: the pass is called by hand, not waited for.)
TEST(FreeMemory, AFreedBufferStaysForReuseUntilFreeMemoryIsReturned) {
  const FreeMemoryReturner returner(std::chrono::hours(1));
  const auto residentKb = [] { return processUsage(::getpid()).value().rss_kb; };
  constexpr size_t kBytes = 24u << 20;
  const uint64_t before = residentKb();
  {
    std::vector<uint8_t> frame(kBytes, 1);
    EXPECT_GE(residentKb(), before + (kBytes >> 10) * 9 / 10) << "the buffer is resident";
  }
  const uint64_t after_free = residentKb();
  EXPECT_GE(after_free, before + (kBytes >> 10) * 9 / 10) << "freed, it stays for reuse";
  EXPECT_TRUE(returnFreeMemoryNow());
  EXPECT_LE(residentKb(), after_free - (kBytes >> 10) * 9 / 10) << "returned to the system";
}

// Where asked (the soak's children), the returner writes the heap the
// program holds each period, and processUsage reads it back beside the
// resident size: a buffer held shows, and is gone from it once freed
// (whether or not its pages went back). The test waits for the written
// value to change, not for a time.
TEST(FreeMemory, TheHeapInUseIsWrittenForTheSoakToRead) {
  const std::string dir = ::testing::TempDir() + "heap_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  ::setenv(kHeapStatsDirEnv, dir.c_str(), 1);
  const auto heapKb = [] { return processUsage(::getpid()).value().heap_kb; };
  const auto waitFor = [&](auto ready) {
    for (int i = 0; i < 2000 && !ready(); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    return ready();
  };
  constexpr size_t kBytes = 24u << 20;
  {
    const FreeMemoryReturner returner(std::chrono::milliseconds(10));
    ASSERT_TRUE(waitFor([&] { return heapKb().has_value(); })) << "written at once";
    const uint64_t before = *heapKb();
    auto frame = std::make_unique<std::vector<uint8_t>>(kBytes, 1);
    EXPECT_TRUE(waitFor([&] { return heapKb().value_or(0) >= before + (kBytes >> 10) * 9 / 10; }))
        << "a held buffer is in the heap: " << heapKb().value_or(0) << " KB from " << before;
    frame.reset();
    EXPECT_TRUE(waitFor([&] {
      return heapKb().value_or(UINT64_MAX) < before + (kBytes >> 10) / 10;
    })) << "a freed one is not: "
        << heapKb().value_or(0) << " KB from " << before;
  }
  ::unsetenv(kHeapStatsDirEnv);
  EXPECT_FALSE(processUsage(::getpid()).value().heap_kb.has_value()) << "asked for no more";
  std::filesystem::remove_all(dir);
}

// Only the thread that asks becomes batch work: the one that started it
// (a frame loop) keeps its policy, and a woken batch thread never preempts
// it. A system may refuse the policy (the function says so, and the
// writer then runs as before): the test is skipped there, by name.
TEST(Scheduling, OnlyTheThreadThatAsksRunsAsBatchWork) {
  const int starter_policy = sched_getscheduler(0);  // Linux: the calling thread's
  int policy_in_thread = -1;
  bool marked = false;
  std::thread worker([&] {
    marked = scheduleThisThreadAsBatch();
    policy_in_thread = sched_getscheduler(0);
  });
  worker.join();
  if (!marked) GTEST_SKIP() << "this system refuses SCHED_BATCH to an unprivileged thread";
  EXPECT_EQ(policy_in_thread, SCHED_BATCH);
  EXPECT_NE(starter_policy, SCHED_BATCH);
  EXPECT_EQ(sched_getscheduler(0), starter_policy);
}

// The slice the scheduler keeps for a thread, in ns; -1 where the kernel
// shows none (its sched debug file has "se.slice" from Linux 6.14, and
// from earlier stable releases that took the change back).
long long sliceOfThisThread() {
  std::ifstream sched("/proc/thread-self/sched");
  std::string line;
  while (std::getline(sched, line)) {
    if (line.rfind("se.slice", 0) == 0) return std::stoll(line.substr(line.find(':') + 1));
  }
  return -1;
}

// Whether this kernel keeps a custom slice for a fair thread (Linux 6.12).
bool kernelKeepsCustomSlices() {
  utsname names{};
  int major = 0, minor = 0;
  if (uname(&names) != 0 || std::sscanf(names.release, "%d.%d", &major, &minor) != 2) return false;
  return major > 6 || (major == 6 && minor >= 12);
}

// The slice asked for is the asking thread's own; the starting thread
// keeps the default. Older kernels take the call and keep theirs: the test
// is skipped there, by name.
TEST(Scheduling, OnlyTheThreadThatAsksGetsTheLongerTimeSlice) {
  if (!kernelKeepsCustomSlices()) GTEST_SKIP() << "custom time slices need Linux 6.12 or later";
  const long long starter_slice = sliceOfThisThread();
  if (starter_slice < 0) GTEST_SKIP() << "this kernel does not show a thread's slice (se.slice)";
  long long slice_in_thread = -1;
  bool asked = false;
  std::thread worker([&] {
    asked = askForTimeSlice(std::chrono::milliseconds(12));
    slice_in_thread = sliceOfThisThread();
  });
  worker.join();
  EXPECT_TRUE(asked);
  EXPECT_EQ(slice_in_thread, 12'000'000);
  EXPECT_EQ(sliceOfThisThread(), starter_slice);
  EXPECT_NE(starter_slice, 12'000'000);
}

}  // namespace
}  // namespace holofuse

// A rig file read by the real programs (--rig): each takes its part, a
// flag on the command line wins over the file, and a mistake in the file
// is refused with the file, the line and the program before anything runs.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "config/command_line.h"
#include "loop_test.h"

namespace holofuse {
namespace {

using namespace holofuse::test;

fs::path writeRig(const fs::path& dir, const std::string& text) {
  const fs::path path = dir / "rig.yaml";
  std::ofstream(path) << text;
  return path;
}

// The launcher starts every process with its part of the file: pod 0
// films at its own rate and pod 1 at the cameras' (pod 0's own does not
// reach it), the client renders at its own size, the launcher's --mode and
// --mesh-codec override the file's, even the latter at its default, and
// --scene does not change the file's two pods into the scene's eight.
TEST(RigFile, TheLoopsProgramsEachReadTheirPartAndFlagsOverrideIt) {
  const fs::path out = freshDir("rig_file_loop");
  const fs::path rig = writeRig(out, R"(rig: test
server:
  address: 127.0.0.1:7300
  sync-deadline-ms: 250
  mesh-codec: fp16-lz4
cameras:
  size: 64x48
  fps: 8
pods:
  - id: 0
    fps: 4
  - id: 1
clients:
  - id: 3
    mode: montage4d
    size: 80x60
)");
  const pid_t launcher =
      spawn({kBin + "/holofuse_loop", "--rig", rig.string(), "--frames", "6", "--mode", "normal",
             "--mesh-codec", "draco", "--scene", "clean", "--out", (out / "run").string()},
            out / "launcher.log");
  ASSERT_EQ(waitExit(launcher, 240), 0) << readFile(out / "launcher.log");
  const auto report = nlohmann::json::parse(readFile(out / "run" / "report.json"));
  EXPECT_EQ(report["frames_rendered"].get<int>(), 6);
  EXPECT_EQ(report["settings"]["size"], "80x60") << "the client's size, from its entry";
  EXPECT_EQ(report["settings"]["mode"], "normal") << "the launcher's --mode wins over the file";
  const fs::path logs = out / "run" / "logs";
  EXPECT_NE(readFile(logs / "pod0.log").find("[pod-0] 64x48 at 4 fps"), std::string::npos)
      << readFile(logs / "pod0.log");
  EXPECT_NE(readFile(logs / "pod1.log").find("[pod-1] 64x48 at 8 fps"), std::string::npos)
      << readFile(logs / "pod1.log");
  EXPECT_FALSE(fs::exists(logs / "pod2.log")) << "the scene's cameras, not the rig's pods";
  // The server took its section and the rig's two pods, but the
  // launcher's address and mesh codec.
  const std::string server = readFile(logs / "server.log");
  EXPECT_NE(
      server.find("from the rig file " + fs::absolute(rig).string() + ": --sync-deadline-ms 250\n"),
      std::string::npos)
      << server;
  EXPECT_NE(server.find("meshes draco"), std::string::npos) << server;
  fs::remove_all(out);
}

// The program refuses to start (exit 2) and its log says `why`.
void expectRefused(const std::vector<std::string>& args, const fs::path& log,
                   const std::string& why) {
  const int code = waitExit(spawn(args, log), 60);
  const std::string said = readFile(log);
  EXPECT_EQ(code, 2) << said;
  EXPECT_NE(said.find(why), std::string::npos) << "expected: " << why << "\n" << said;
}

TEST(RigFile, AKeyTheProgramHasNoFlagForIsRefusedWithItsLine) {
  const fs::path out = freshDir("rig_file_unknown");
  const fs::path rig = writeRig(out, R"(server:
  address: 127.0.0.1:7300
pods:
  - id: 0
    colour: red
)");
  expectRefused({kBin + "/capture_node", "--rig", rig.string(), "--pod-id", "0"}, out / "pod.log",
                rig.string() + ":5 (pod 0): 'colour' is not a capture_node flag");
  // The file's own mistakes are the same message for every program.
  std::ofstream(rig) << "server:\n  address: 127.0.0.1:7300\npods:\n  - id: 0\n  - id: 0\n";
  expectRefused({kBin + "/fusion_server", "--rig", rig.string()}, out / "server.log",
                rig.string() + ":5: pod 0 is given twice");
  fs::remove_all(out);
}

TEST(RigFile, ABadValueInTheFileIsRefusedWithWhereItIs) {
  const fs::path out = freshDir("rig_file_value");
  const fs::path rig = writeRig(out, R"(server:
  address: 127.0.0.1:7300
  sync-deadline-ms: 0
pods:
  - id: 0
)");
  expectRefused({kBin + "/fusion_server", "--rig", rig.string()}, out / "server.log",
                "(--sync-deadline-ms from " + rig.string() + ":3 (server))");
  // A pod not told its id looks for this machine in the file.
  expectRefused({kBin + "/capture_node", "--rig", rig.string()}, out / "pod.log",
                "--rig: " + rig.string() + " has no pod on host " + hostName() +
                    ": give --pod-id or --rig-host");
  expectRefused({kBin + "/capture_node", "--rig", (out / "none.yaml").string(), "--pod-id", "0"},
                out / "missing.log",
                "--rig: " + (out / "none.yaml").string() + " was not readable");
  fs::remove_all(out);
}

// The command line wins: the file's bad deadline and unreachable address
// are never applied when flags give them, so the server starts, and its
// two pods (their --server given, and --no-auth, which drops the file's
// key file) send their frames. Pod 1 is not told its id: the file puts it
// on this machine.
TEST(RigFile, FlagsGivenOverrideTheFilesValues) {
  const fs::path out = freshDir("rig_file_override");
  const fs::path rig = writeRig(out, R"(server:
  address: 192.0.2.1:7300
  sync-deadline-ms: 0
  no-auth: true
cameras:
  key-file: /nonexistent/pod.key
pods:
  - id: 0
    host: some-other-host
  - id: 1
    host: )" + hostName() + "\n");
  pid_t server = -1;
  const std::string endpoint = test::startServer(
      kBin, out, 2, &server,
      {"--rig", rig.string(), "--sync-deadline-ms", "30", "--exit-when-pods-done"});
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  std::vector<pid_t> pods;
  for (const std::string id : {"0", "1"}) {
    std::vector<std::string> args = {kBin + "/capture_node",
                                     "--rig",
                                     rig.string(),
                                     "--server",
                                     endpoint,
                                     "--no-auth",
                                     "--frames",
                                     "3",
                                     "--size",
                                     "64x48"};
    if (id == "0") args.insert(args.end(), {"--pod-id", "0"});
    pods.push_back(spawn(args, out / ("pod" + id + ".log")));
  }
  for (const pid_t pod : pods) EXPECT_EQ(waitExit(pod, 120), 0);
  EXPECT_EQ(waitExit(server, 60), 0) << readFile(out / "server.log");
  EXPECT_NE(readFile(out / "pod1.log").find("[pod-1] sent 3 frames"), std::string::npos)
      << readFile(out / "pod1.log");
  const std::string server_said = readFile(out / "server.log");
  EXPECT_NE(server_said.find("from the rig file " + rig.string() + ": --no-auth true"),
            std::string::npos)
      << server_said;
  fs::remove_all(out);
}

}  // namespace
}  // namespace holofuse

// The rig file: each program's part, what the rig implies, and every
// mistake refused with the file, the line and what is wrong.
#include <gtest/gtest.h>

#include <map>

#include "config/rig_file.h"

namespace holofuse {
namespace {

const char* kRig = R"(rig: studio-a
server:
  host: fusion-01
  address: 10.0.0.10:7300
  key-file: /etc/holofuse/keys/server.keys
  sync-deadline-ms: 40
link:
  delay-ms: 2
  jitter-ms: 0.5
cameras:
  size: 640x480
  fps: 15
pods:
  - id: 1
    host: capture-01
    key-file: /etc/holofuse/keys/pod-1.key
    fps: 30
    link: {delay-ms: 8, rate-mbit: 1000}
  - id: 0
    host: capture-00
    key-file: /etc/holofuse/keys/pod-0.key
clients:
  - id: 7
    host: viewer
    mode: montage4d
    exclude-camera: [1, 0]
)";

// A part as flag -> values, for comparing.
std::map<std::string, std::vector<std::string>> flags(const std::vector<RigOption>& part) {
  std::map<std::string, std::vector<std::string>> out;
  for (const RigOption& option : part) {
    EXPECT_TRUE(out.emplace(option.name, option.values).second) << option.name << " twice";
  }
  return out;
}

using Values = std::vector<std::string>;

TEST(RigFile, EachProgramReadsItsPartWithWhatTheRigImplies) {
  const auto rig = RigFile::parse(kRig, "rig.yaml");
  ASSERT_TRUE(rig.isOk()) << rig.status().message();
  EXPECT_EQ(rig->name, "studio-a");
  EXPECT_EQ(rig->server_host, "fusion-01");
  ASSERT_EQ(rig->pods.size(), 2u);
  EXPECT_EQ(rig->pods[0].id, 0u) << "sorted by id, the camera index";
  EXPECT_EQ(rig->pods[0].host, "capture-00");

  // The server listens where the rig reaches it and expects every pod.
  EXPECT_EQ(flags(rig->serverPart()),
            (std::map<std::string, Values>{{"listen", {"10.0.0.10:7300"}},
                                           {"pods", {"2"}},
                                           {"key-file", {"/etc/holofuse/keys/server.keys"}},
                                           {"sync-deadline-ms", {"40"}}}));
  // A pod: the cameras' settings, its own on top, the server's address.
  const auto pod1 = rig->podPart(1);
  ASSERT_TRUE(pod1.isOk()) << pod1.status().message();
  EXPECT_EQ(flags(*pod1),
            (std::map<std::string, Values>{{"server", {"10.0.0.10:7300"}},
                                           {"pods", {"2"}},
                                           {"size", {"640x480"}},
                                           {"fps", {"30"}},
                                           {"key-file", {"/etc/holofuse/keys/pod-1.key"}}}));
  EXPECT_EQ(flags(*rig->podPart(0)).at("fps"), Values{"15"});
  // A client: its entry (a list stays a list) and the server's address.
  const auto client = rig->clientPart(7);
  ASSERT_TRUE(client.isOk()) << client.status().message();
  EXPECT_EQ(flags(*client), (std::map<std::string, Values>{{"server", {"10.0.0.10:7300"}},
                                                           {"mode", {"montage4d"}},
                                                           {"exclude-camera", {"1", "0"}}}));
  // Links: the rig's, a member's keys on top of it.
  EXPECT_EQ(rig->pods[0].link.delay_ms, 2.0);
  EXPECT_EQ(rig->pods[0].link.jitter_ms, 0.5);
  EXPECT_EQ(rig->pods[1].link.delay_ms, 8.0);
  EXPECT_EQ(rig->pods[1].link.jitter_ms, 0.5);
  EXPECT_EQ(rig->pods[1].link.rate_mbit, 1000.0);
  EXPECT_EQ(rig->clients[0].link.delay_ms, 2.0);
  // Messages say where a value came from.
  EXPECT_EQ(pod1->back().where, "rig.yaml:17 (pod 1)");
}

TEST(RigFile, APartNamingAnImpliedFlagKeepsItsOwn) {
  const auto rig = RigFile::parse(R"(server:
  address: fusion:7300
  listen: 0.0.0.0:7300
pods:
  - id: 0
    server: 10.1.0.10:7300
  - id: 1
    replay: /data/temple
)",
                                  "rig.yaml");
  ASSERT_TRUE(rig.isOk()) << rig.status().message();
  EXPECT_EQ(flags(rig->serverPart()).at("listen"), Values{"0.0.0.0:7300"});
  EXPECT_EQ(flags(*rig->podPart(0)).at("server"), Values{"10.1.0.10:7300"});
  // A replay pod's cameras are its dataset's: no --pods for it.
  EXPECT_EQ(flags(*rig->podPart(1)).count("pods"), 0u);
  EXPECT_EQ(flags(*rig->podPart(1)).at("server"), Values{"fusion:7300"});
  // No clients listed: any client still learns where the server is.
  EXPECT_EQ(flags(*rig->clientPart(3)),
            (std::map<std::string, Values>{{"server", {"fusion:7300"}}}));
}

TEST(RigFile, AnAbsentMemberIsRefusedByName) {
  const auto rig = RigFile::parse(kRig, "rig.yaml");
  ASSERT_TRUE(rig.isOk());
  const auto pod = rig->podPart(2);
  ASSERT_FALSE(pod.isOk());
  EXPECT_EQ(pod.status().message(), "rig.yaml has no pod 2 (its pods are 0..1)");
  const auto client = rig->clientPart(0);
  ASSERT_FALSE(client.isOk());
  EXPECT_EQ(client.status().message(), "rig.yaml has no client 0 (its clients: 7)");
}

// Every mistake is refused with the line it is on.
TEST(RigFile, MistakesAreRefusedWithTheirLine) {
  const std::string server = "server:\n  address: fusion:7300\n";
  const std::string pods = "pods:\n  - id: 0\n";
  struct Case {
    std::string text, message;
  };
  const std::vector<Case> cases = {
      {"server: [\n", ": not YAML"},
      {"- a\n", "rig.yaml:1: a rig file is a map"},
      {server + pods + "camera:\n  fps: 3\n",
       "rig.yaml:5: 'camera' is not a key of a rig file (rig, server, link, cameras, pods, "
       "clients)"},
      {pods, "rig.yaml:1: no server: a rig names its server's address"},
      {server, "rig.yaml:1: no pods"},
      {"server:\n  host: a\n" + pods, "rig.yaml:2: server: no address"},
      {"server:\n  address: fusion\n" + pods,
       "rig.yaml:2: server's address 'fusion' is not HOST:PORT with a port other than 0"},
      {"server:\n  address: fusion:0\n" + pods, "is not HOST:PORT with a port other than 0"},
      {server + "pods:\n  - id: 0\n  - id: 0\n",
       "rig.yaml:5: pod 0 is given twice (also at rig.yaml:4)"},
      {server + "pods:\n  - id: 0\n  - id: 2\n", "rig.yaml:5: pod 2: with 2 pods the ids are 0..1"},
      {server + "pods:\n  - id: 1.5\n", "rig.yaml:4: pods[0]'s id '1.5' is not a whole number"},
      {server + "pods:\n  - id: -1\n",
       "rig.yaml:4: pods[0]'s id: '-1' is not a number in [0, 127]"},
      {server + "pods: []\n", "rig.yaml:3: pods is not a list of pods"},
      {server + "pods:\n  - id: 0\n    pod-id: 3\n",
       "rig.yaml:5: pod 0: 'pod-id' is set by the rig file itself"},
      {server + "pods:\n  - id: 0\n    fps:\n", "rig.yaml:5: pod 0: 'fps' has no value"},
      {"server:\n  address:\n  listen: x\n" + pods, "rig.yaml:2: server: 'address' has no value"},
      {server + "pods:\n  - id: 0\n    size: {w: 3}\n", "rig.yaml:5: pod 0: size is not a value"},
      {server + "pods:\n  - id: 0\n    --fps: 3\n",
       "rig.yaml:5: pod 0: '--fps' is not a flag's name (a flag without its dashes)"},
      {server + "pods:\n  - id: 0\n    fps: 3\n    fps: 4\n",
       "rig.yaml:6: pod 0: 'fps' is given twice"},
      {server + pods + "link:\n  delay-ms: 1\n  jitter-ms: 2\n",
       "rig.yaml:6: the rig's link: jitter 2 ms is more than the delay 1 ms it varies"},
      {server + pods + "link:\n  delay: 1\n",
       "rig.yaml:6: the rig's link delay: not a link setting (delay-ms, jitter-ms, rate-mbit)"},
      {server + "pods:\n  - id: 0\n    link: {rate-mbit: fast}\n",
       "rig.yaml:5: pod 0's link rate-mbit: 'fast' is not a number in [0, 100000]"},
      {server + pods + "clients:\n  - id: 1\n  - id: 1\n", "rig.yaml:7: client 1 is given twice"},
      {server + pods + "cameras:\n  rig: other.yaml\n",
       "rig.yaml:6: cameras: 'rig' is set by the rig file itself"},
  };
  for (const Case& c : cases) {
    const auto rig = RigFile::parse(c.text, "rig.yaml");
    ASSERT_FALSE(rig.isOk()) << c.text;
    EXPECT_NE(rig.status().message().find(c.message), std::string::npos)
        << "for\n"
        << c.text << "said: " << rig.status().message() << "\nexpected: " << c.message;
  }
}

TEST(RigFile, AFileThatIsNotThereIsNamed) {
  const auto rig = RigFile::load("/nonexistent/rig.yaml");
  ASSERT_FALSE(rig.isOk());
  EXPECT_EQ(rig.status().message(), "/nonexistent/rig.yaml: cannot read the rig file");
}

}  // namespace
}  // namespace holofuse

// Clients that ask for fused frames (protocol 1.9 FrameRequest): a real
// server and pod, and clients on ServerLink so that the test decides when
// each one reads. While every client asks, the server fuses only what one
// asked for and holds the rest; a client that does not ask (before 1.9)
// is sent every group again. Each step waits on the event it needs: the
// server's health file, the frames a client has received.
#include <gtest/gtest.h>
#include <signal.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "loop_test.h"
#include "protocol/server_link.h"

namespace holofuse {
namespace {

using namespace holofuse::test;

struct Counts {
  uint64_t fused = 0;
  uint64_t not_asked_for = 0;
  uint64_t fusing = 0;  // submitted, their output not yet sent
};

// The server's health file (rewritten whole every second); zeros until
// it is there.
Counts healthCounts(const fs::path& health) {
  std::ifstream in(health);
  const auto json = nlohmann::json::parse(in, nullptr, false);
  if (json.is_discarded() || !json.contains("groups_not_asked_for")) return {};
  return {json["groups_fused"].get<uint64_t>(), json["groups_not_asked_for"].get<uint64_t>(),
          json["groups_fusing"].get<uint64_t>()};
}

// A client of the given minor on its own link; polled only when the test
// says, as a client busy rendering would.
struct Client {
  std::unique_ptr<protocol::ServerLink> link;
  size_t meshes = 0;

  Client(const std::string& endpoint, uint32_t id, uint8_t max_minor, uint32_t frames_ahead) {
    protocol::Hello hello;
    hello.role = protocol::Role::kClient;
    hello.id = id;
    hello.max_minor = max_minor;
    protocol::LinkOptions options;
    options.frames_ahead = frames_ahead;
    link =
        std::make_unique<protocol::ServerLink>(*protocol::parseEndpoint(endpoint), hello, options);
  }
  // Polls until it has received `more` meshes more; false if they do not come.
  bool receive(size_t more) {
    const size_t want = meshes + more;
    std::vector<protocol::Frame> received;
    return waitFor([&] {
      received.clear();
      link->poll(20, received);
      for (const auto& frame : received)
        meshes += frame.header.type == static_cast<uint16_t>(protocol::MessageType::kMeshFrame);
      return meshes >= want;
    });
  }
};

TEST(FrameRequests, TheServerFusesOnlyWhatAClientAskedForUntilOneThatDoesNotAskJoins) {
  const fs::path out = freshDir("frame_requests");
  const fs::path health = out / "health.json";
  pid_t server = 0;
  // The asking client is not polled while the test waits for groups: on a
  // loaded machine that can outlast the default idle timeout (5 s), and a
  // server that closed it has no client pacing it and fuses every group.
  const std::string endpoint =
      startServer(out, 1, &server,
                  {"--no-auth", "--health-file", health.string(), "--idle-timeout-ms", "600000"});
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  const pid_t pod = spawn({kBin + "/capture_node", "--server", endpoint, "--pod-id", "0", "--pods",
                           "1", "--size", "64x48", "--fps", "30", "--no-auth"},
                          out / "pod.log");
  constexpr uint32_t kAhead = 2;
  Client asking(endpoint, 1, protocol::kVersionMinor, kAhead);
  ASSERT_TRUE(asking.receive(3)) << readFile(out / "server.log");

  // It stops reading, as a client still rendering does: the server sends
  // what it asked for and fuses nothing more, however many groups the pod
  // completes meanwhile.
  Counts before;
  ASSERT_TRUE(waitFor([&] {
    before = healthCounts(health);
    return before.not_asked_for >= 5 && before.fusing == 0;
  })) << readFile(health);
  Counts later;
  ASSERT_TRUE(waitFor([&] {
    return (later = healthCounts(health)).not_asked_for >= before.not_asked_for + 15;
  })) << readFile(health);
  EXPECT_EQ(later.fused, before.fused) << "groups fused while no client asked for one";

  // A client of 1.8 cannot ask: every group is fused again (it gets them
  // all: fused after the first one's two), while the first still has none
  // asked for.
  Client old(endpoint, 2, 8, 0);
  ASSERT_TRUE(old.receive(5)) << readFile(out / "server.log");
  old.link->close("done");

  // The asking client reads again: what it had asked for, then one more
  // per mesh as they arrive.
  ASSERT_TRUE(asking.receive(5)) << readFile(out / "server.log");
  asking.link->close("done");

  kill(pod, SIGTERM);
  EXPECT_EQ(waitExit(pod, 20), 0);
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 20), 0);
  const std::string log = readFile(out / "server.log");
  EXPECT_NE(log.find("not fused: no client asked for them"), std::string::npos) << log;
  EXPECT_EQ(log.find("heard nothing for"), std::string::npos) << log;
}

}  // namespace
}  // namespace holofuse

// Trust no peer (SECURITY.md): real servers, pods and clients on loopback.
// Only a peer that proves it holds its identity's key joins; a wrong key,
// no key and an answer replayed from another connection are refused by
// name before any frame is parsed; a pod is not replaced but by a peer
// holding its key; a peer that never finishes its handshake is closed.
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "loop_test.h"
#include "peer_by_hand.h"
#include "protocol/auth.h"
#include "protocol/connection.h"
#include "protocol/socket.h"

namespace holofuse {
namespace {

using namespace holofuse::test;

// The honest client rendered all its frames; then pod and server stop.
void expectEveryFrameRenderedThenStop(const fs::path& out, pid_t client, pid_t pod, pid_t server,
                                      int frames) {
  ASSERT_EQ(waitExit(client, 120), 0) << readFile(out / "client.log");
  kill(pod, SIGTERM);
  waitExit(pod, 10);
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 10), 0);
  std::ifstream report(out / "client" / "report.json");
  EXPECT_EQ(nlohmann::json::parse(report)["frames_rendered"].get<int>(), frames);
}

TEST(Auth, WrongMissingAndReplayedAnswersAreRefusedByName) {
  const fs::path out = freshDir("auth");
  pid_t server = 0;
  const std::string endpoint = startServer(out, 2, &server);
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");

  // A pod with another key: refused, both sides say why, and it stops.
  const fs::path other_key = out / "other.key";
  ASSERT_TRUE(protocol::KeyRing::writeNew(other_key.string()).isOk());
  const pid_t wrong = spawn({kBin + "/capture_node", "--server", endpoint, "--pod-id", "0",
                             "--pods", "2", "--size", "64x48", "--key-file", other_key.string()},
                            out / "wrong.log");
  EXPECT_NE(waitExit(wrong, 60), 0) << readFile(out / "wrong.log");
  EXPECT_NE(readFile(out / "wrong.log").find("authentication failed for pod 0"), std::string::npos)
      << readFile(out / "wrong.log");

  // A client without a key: told to give one; the server's log says it gave up.
  const pid_t keyless = spawn({kBin + "/render_client", "--server", endpoint, "--out",
                               (out / "keyless").string(), "--frames", "1", "--no-auth"},
                              out / "keyless.log");
  EXPECT_NE(waitExit(keyless, 60), 0) << readFile(out / "keyless.log");
  EXPECT_NE(readFile(out / "keyless.log").find("the server requires a key"), std::string::npos)
      << readFile(out / "keyless.log");

  // An answer recorded on one connection, replayed on another with the same
  // Hello: the server's challenge is new, so the old answer fails.
  auto key = protocol::loadPeerKey(test::testKeyFile(), protocol::Role::kPod, 1);
  ASSERT_TRUE(key.isOk()) << key.status().message();
  auto parsed = protocol::parseEndpoint(endpoint);
  ASSERT_TRUE(parsed.isOk());
  protocol::Hello hello;
  hello.role = protocol::Role::kPod;
  hello.id = 1;
  hello.nonce = 42;
  protocol::AuthBytes recorded{};
  for (int attempt = 0; attempt < 2; ++attempt) {
    auto socket = protocol::connectTcp(*parsed, 1000);
    ASSERT_TRUE(socket.isOk());
    protocol::Connection c(std::move(*socket), "by hand");
    c.sendMessage(hello);
    flush(c);
    const protocol::Frame challenge_frame = nextFrame(c);
    protocol::Auth challenge;
    ASSERT_TRUE(protocol::decodeFrame(challenge_frame, challenge).isOk());
    ASSERT_EQ(challenge.step, protocol::AuthStep::kChallenge);
    protocol::Auth answer;
    answer.step = protocol::AuthStep::kResponse;
    answer.value = attempt == 0 ? protocol::authMac(*key, protocol::AuthStep::kResponse, hello,
                                                    challenge_frame.header.major,
                                                    challenge_frame.header.minor, challenge.value)
                                : recorded;
    recorded = answer.value;
    c.sendMessage(answer);
    flush(c);
    const protocol::Frame reply = nextFrame(c);
    if (attempt == 0) {
      protocol::Auth proof;
      ASSERT_TRUE(protocol::decodeFrame(reply, proof).isOk()) << "the server proves its key";
      EXPECT_TRUE(protocol::sameMac(
          proof.value,
          protocol::authMac(*key, protocol::AuthStep::kProof, hello, challenge_frame.header.major,
                            challenge_frame.header.minor, challenge.value)));
      protocol::HelloAck ack;
      EXPECT_TRUE(protocol::decodeFrame(nextFrame(c), ack).isOk()) << "then admits the pod";
    } else {
      protocol::ErrorMessage error;
      ASSERT_TRUE(protocol::decodeFrame(reply, error).isOk()) << "refused, with the reason";
      EXPECT_EQ(error.code, static_cast<uint16_t>(StatusCode::kUnauthenticated));
      EXPECT_NE(error.message.find("replayed"), std::string::npos) << error.message;
    }
  }
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 10), 0);
  const std::string log = readFile(out / "server.log");
  EXPECT_NE(log.find("authentication failed for pod 0"), std::string::npos) << log;
  EXPECT_NE(log.find("client 0 gave up authenticating: the server requires a key"),
            std::string::npos)
      << log;
  EXPECT_NE(log.find("authentication failed for pod 1"), std::string::npos) << log;
  EXPECT_EQ(log.find("pod 0 (127.0.0.1"), std::string::npos) << "pod 0 never joined\n" << log;
  fs::remove_all(out);
}

// Keys per identity, as --new-key writes them by default: the server's
// ring holds every identity, each pod and client file only its own. A
// peer holding pod 1's key that says it is pod 0 is refused while the
// real pod 0 keeps serving the client, which renders every frame it asked
// for. --new-key never writes over a key, and --shared-key warns.
TEST(Auth, APodIsBoundToItsKeyAndCannotBeReplaced) {
  const fs::path out = freshDir("auth_bound");
  const fs::path keys = out / "keys";
  ASSERT_EQ(waitExit(spawn({kBin + "/fusion_server", "--new-key", keys.string(), "--pods", "2"},
                           out / "new_key.log"),
                     30),
            0)
      << readFile(out / "new_key.log");
  for (const char* name : {"server.keys", "pod-0.key", "pod-1.key", "client-0.key"}) {
    struct stat st {};
    ASSERT_EQ(::stat((keys / name).c_str(), &st), 0) << name << "\n"
                                                     << readFile(out / "new_key.log");
    EXPECT_EQ(st.st_mode & 0777, 0600u) << name;
  }
  // Each peer's file authenticates its identity and no other.
  const auto ring = protocol::KeyRing::load((keys / "server.keys").string());
  ASSERT_TRUE(ring.isOk()) << ring.status().message();
  const auto pod0 = protocol::KeyRing::load((keys / "pod-0.key").string());
  ASSERT_TRUE(pod0.isOk()) << pod0.status().message();
  ASSERT_NE(pod0->keyFor(protocol::Role::kPod, 0), nullptr);
  EXPECT_EQ(pod0->keyFor(protocol::Role::kPod, 1), nullptr);
  EXPECT_EQ(pod0->keyFor(protocol::Role::kClient, 0), nullptr);
  EXPECT_EQ(*pod0->keyFor(protocol::Role::kPod, 0), *ring->keyFor(protocol::Role::kPod, 0));
  EXPECT_NE(*ring->keyFor(protocol::Role::kPod, 0), *ring->keyFor(protocol::Role::kPod, 1));
  // Written once: a second --new-key into the folder changes nothing.
  const std::string before = readFile(keys / "pod-0.key");
  EXPECT_EQ(waitExit(spawn({kBin + "/fusion_server", "--new-key", keys.string(), "--pods", "2"},
                           out / "again.log"),
                     30),
            2);
  EXPECT_NE(readFile(out / "again.log").find("server.keys: exists; not overwritten"),
            std::string::npos)
      << readFile(out / "again.log");
  EXPECT_EQ(readFile(keys / "pod-0.key"), before);
  EXPECT_EQ(waitExit(spawn({kBin + "/fusion_server", "--new-key", (out / "shared.key").string(),
                            "--shared-key"},
                           out / "shared.log"),
                     30),
            0);
  EXPECT_NE(readFile(out / "shared.log").find("can claim any pod"), std::string::npos)
      << readFile(out / "shared.log");

  pid_t server = 0;
  const std::string endpoint =
      startServer(out, 1, &server, {"--key-file", (keys / "server.keys").string()});
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  const pid_t pod =
      spawn({kBin + "/capture_node", "--server", endpoint, "--pod-id", "0", "--pods", "1", "--size",
             "64x48", "--fps", "10", "--key-file", (keys / "pod-0.key").string()},
            out / "pod.log");
  const pid_t client =
      spawn({kBin + "/render_client", "--server", endpoint, "--out", (out / "client").string(),
             "--frames", "6", "--size", "64x48", "--key-file", (keys / "client-0.key").string()},
            out / "client.log");
  // The impostor: a pod 1 gone bad, with pod 1's key, claiming pod 0.
  const std::string pod1 = readFile(keys / "pod-1.key");
  const std::string pod1_hex = pod1.substr(pod1.find("pod:1 ") + 6, 64);
  const fs::path stolen = out / "impostor.key";
  { std::ofstream(stolen) << "pod:0 " << pod1_hex << "\n"; }
  fs::permissions(stolen, fs::perms::owner_read | fs::perms::owner_write);
  const pid_t impostor = spawn({kBin + "/capture_node", "--server", endpoint, "--pod-id", "0",
                                "--pods", "1", "--size", "64x48", "--key-file", stolen.string()},
                               out / "impostor.log");
  EXPECT_NE(waitExit(impostor, 60), 0) << readFile(out / "impostor.log");
  EXPECT_NE(readFile(out / "impostor.log").find("authentication failed for pod 0"),
            std::string::npos)
      << readFile(out / "impostor.log");
  expectEveryFrameRenderedThenStop(out, client, pod, server, 6);
  const std::string log = readFile(out / "server.log");
  EXPECT_NE(log.find("authentication failed for pod 0"), std::string::npos) << log;
  EXPECT_EQ(log.find("dropping its old connection"), std::string::npos) << log;
  fs::remove_all(out);
}

// A server that will not start: without a key (unless --no-auth), with
// --no-auth on an interface other than loopback, or with a key file that
// others may read.
TEST(Auth, AServerWithoutAKeyOrWithAnOpenKeyFileDoesNotStart) {
  const fs::path out = freshDir("auth_start");
  const std::string server = kBin + "/fusion_server";
  EXPECT_EQ(
      waitExit(spawn({"/usr/bin/env", "-u", "HOLOFUSE_KEY_FILE", server, "--listen", "127.0.0.1:0"},
                     out / "nokey.log"),
               30),
      2);
  EXPECT_NE(readFile(out / "nokey.log").find("no key: give --key-file PATH"), std::string::npos)
      << readFile(out / "nokey.log");
  EXPECT_EQ(waitExit(spawn({server, "--listen", "0.0.0.0:0", "--no-auth"}, out / "open.log"), 30),
            2);
  EXPECT_NE(readFile(out / "open.log").find("--no-auth serves only loopback"), std::string::npos)
      << readFile(out / "open.log");
  const fs::path readable = out / "readable.key";
  ASSERT_TRUE(protocol::KeyRing::writeNew(readable.string()).isOk());
  ::chmod(readable.c_str(), 0644);
  EXPECT_EQ(waitExit(spawn({server, "--listen", "127.0.0.1:0", "--key-file", readable.string()},
                           out / "readable.log"),
                     30),
            2);
  EXPECT_NE(readFile(out / "readable.log").find("readable by others (mode 0644)"),
            std::string::npos)
      << readFile(out / "readable.log");
  fs::remove_all(out);
}

// Before its handshake a peer may send 256 bytes a frame and has the
// handshake deadline to finish: a header claiming 60 MiB is refused at
// once, and a peer that says nothing is closed at the deadline, each
// named in the log, while nothing of theirs is ever allocated or parsed.
TEST(Limits, BeforeItsHandshakeAPeerGetsAFewBytesAndALittleTime) {
  const fs::path out = freshDir("limits");
  pid_t server = 0;
  const std::string endpoint = startServer(out, 1, &server, {"--handshake-timeout-ms", "300"});
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  auto parsed = protocol::parseEndpoint(endpoint);
  ASSERT_TRUE(parsed.isOk());
  auto silent = protocol::connectTcp(*parsed, 1000);
  ASSERT_TRUE(silent.isOk());
  auto huge = protocol::connectTcp(*parsed, 1000);
  ASSERT_TRUE(huge.isOk());
  protocol::Connection greedy(std::move(*huge), "huge");
  uint8_t header[protocol::kHeaderSize] = {'H', 'F', 'U', 'S', 1, 4, 1,    0,
                                           0,   0,   0,   0,   0, 0, 0xC0, 0x03};  // payload 60 MiB
  ASSERT_EQ(::write(greedy.fd(), header, sizeof(header)), static_cast<ssize_t>(sizeof(header)));
  protocol::ErrorMessage refusal;  // the reason, then the close
  ASSERT_TRUE(protocol::decodeFrame(nextFrame(greedy), refusal).isOk());
  EXPECT_NE(refusal.message.find("above cap 256"), std::string::npos) << refusal.message;
  Status greedy_closed;
  EXPECT_TRUE(nextFrame(greedy, &greedy_closed).bytes.empty());
  EXPECT_FALSE(greedy_closed.isOk()) << "closed for its header";
  protocol::Connection quiet(std::move(*silent), "silent");
  Status quiet_closed;
  EXPECT_TRUE(nextFrame(quiet, &quiet_closed).bytes.empty());
  EXPECT_FALSE(quiet_closed.isOk()) << "closed at the deadline";
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 10), 0);
  const std::string log = readFile(out / "server.log");
  EXPECT_NE(log.find("no handshake within 300 ms"), std::string::npos) << log;
  EXPECT_NE(log.find("above cap 256"), std::string::npos) << log;
  fs::remove_all(out);
}

// No peer's traffic starves the others: an admitted peer flooding
// heartbeats or clock probes is closed for it, one claiming a huge frame is refused at its
// header, a pod whose calibration claims a huge image
// is refused before anything of that size exists, and a client beside
// them renders every frame it asked for.
TEST(FairService, AFloodingPeerIsClosedAndTheOthersAreStillServed) {
  const fs::path out = freshDir("fair");
  pid_t server = 0;
  const std::string endpoint = startServer(out, 3, &server);
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  const pid_t pod = spawn({kBin + "/capture_node", "--server", endpoint, "--pod-id", "0", "--pods",
                           "3", "--size", "64x48", "--fps", "10"},
                          out / "pod.log");
  const pid_t client = spawn({kBin + "/render_client", "--server", endpoint, "--out",
                              (out / "client").string(), "--frames", "6", "--size", "64x48"},
                             out / "client.log");
  auto flooder = admittedByHand(endpoint, protocol::Role::kPod, 1);
  ASSERT_NE(flooder, nullptr) << readFile(out / "server.log");
  for (int i = 0; i < 5000; ++i) flooder->sendMessage(protocol::Heartbeat{1});
  flush(*flooder);
  protocol::ErrorMessage refusal;
  // Under way, the server's own heartbeats may come first.
  ASSERT_TRUE(protocol::decodeFrame(nextError(*flooder), refusal).isOk());
  EXPECT_NE(refusal.message.find("heartbeats closer together than 50 ms"), std::string::npos)
      << refusal.message;
  // Clock probes (protocol 1.8) are held to the same floor, and an answer
  // to no probe of the server's is told in the log and changes nothing.
  auto prober = admittedByHand(endpoint, protocol::Role::kClient, 9);
  ASSERT_NE(prober, nullptr) << readFile(out / "server.log");
  prober->sendMessage(protocol::ClockProbe{protocol::ProbeStep::kReply, 12345, 1, 2});
  for (int i = 0; i < 5000; ++i)
    prober->sendMessage(protocol::ClockProbe{protocol::ProbeStep::kRequest, 1, 0, 0});
  flush(*prober);
  ASSERT_TRUE(protocol::decodeFrame(nextError(*prober), refusal).isOk());
  EXPECT_NE(refusal.message.find("clock probes closer together than 50 ms"), std::string::npos)
      << refusal.message;
  EXPECT_TRUE(
      test::logSays(out / "server.log", "ignored clock probe answer 1 from client 9 (127.0.0.1"))
      << readFile(out / "server.log");
  // Admitted is not trusted with memory: a header claiming 60 MiB of
  // anything but a PodFrame its calibration allows is refused at the header.
  auto claimer = admittedByHand(endpoint, protocol::Role::kClient, 7);
  ASSERT_NE(claimer, nullptr) << readFile(out / "server.log");
  const uint8_t header[protocol::kHeaderSize] = {'H', 'F', 'U', 'S', 1, 4, 7,    0,
                                                 0,   0,   0,   0,   0, 0, 0xC0, 0x03};
  ASSERT_EQ(::write(claimer->fd(), header, sizeof(header)), static_cast<ssize_t>(sizeof(header)));
  // A client is sent the rig's frames too: its refusal is the Error among them.
  ASSERT_TRUE(protocol::decodeFrame(nextError(*claimer), refusal).isOk());
  EXPECT_NE(refusal.message.find("62914560 bytes above cap 65536"), std::string::npos)
      << refusal.message;
  auto giant = admittedByHand(endpoint, protocol::Role::kPod, 2);
  ASSERT_NE(giant, nullptr) << readFile(out / "server.log");
  protocol::Calibration calibration;
  calibration.camera_id = 2;
  calibration.width = calibration.height = 9362;
  calibration.fx = calibration.fy = 5000;
  calibration.cx = calibration.cy = 4681;
  calibration.rotation = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  giant->sendMessage(calibration);
  flush(*giant);
  // The server's clock probes may come first (protocol 1.8).
  ASSERT_TRUE(protocol::decodeFrame(nextError(*giant), refusal).isOk());
  EXPECT_NE(refusal.message.find("9362x9362 is above --max-image-side 4096"), std::string::npos)
      << refusal.message;
  expectEveryFrameRenderedThenStop(out, client, pod, server, 6);
  fs::remove_all(out);
}

// Out of file descriptors, the server says so, stops polling its listener
// for a moment instead of spinning on it, and admits a peer again once
// descriptors are free.
TEST(FairService, OutOfDescriptorsTheServerPausesAcceptingAndRecovers) {
  const fs::path out = freshDir("emfile");
  pid_t server = 0;
  const std::string endpoint = test::startServer(
      kBin, out, 1, &server, {"--max-handshaking", "100", "--max-handshaking-per-address", "100"},
      {"/usr/bin/prlimit", "--nofile=32"});
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  auto parsed = protocol::parseEndpoint(endpoint);
  ASSERT_TRUE(parsed.isOk());
  std::vector<protocol::Socket> crowd;
  for (int i = 0; i < 40; ++i) {
    auto socket = protocol::connectTcp(*parsed, 1000);
    if (socket.isOk()) crowd.push_back(std::move(*socket));
  }
  // The log line is the event to wait for.
  for (int i = 0;
       i < 200 && readFile(out / "server.log").find("cannot accept") == std::string::npos; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_NE(readFile(out / "server.log").find("cannot accept (Too many open files)"),
            std::string::npos)
      << readFile(out / "server.log");
  crowd.clear();  // descriptors free again: the crowd's are closed at the deadline
  auto late = admittedByHand(endpoint, protocol::Role::kClient, 0);
  EXPECT_NE(late, nullptr) << "admitted once descriptors are free\n"
                           << readFile(out / "server.log");
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 10), 0);
  fs::remove_all(out);
}

// Strangers that connect and say nothing take handshake slots: past the
// cap for one address the next is refused at once, told why, and the log
// names the flag; a peer from that address gets in once the crowd's
// handshake deadline has closed it.
TEST(Limits, PastTheHandshakeCapForOneAddressAConnectionIsRefusedByName) {
  const fs::path out = freshDir("caps");
  pid_t server = 0;
  const std::string endpoint = startServer(
      out, 1, &server, {"--max-handshaking-per-address", "4", "--handshake-timeout-ms", "1000"});
  ASSERT_FALSE(endpoint.empty()) << readFile(out / "server.log");
  auto parsed = protocol::parseEndpoint(endpoint);
  ASSERT_TRUE(parsed.isOk());
  std::vector<std::unique_ptr<protocol::Connection>> crowd;
  for (int i = 0; i < 4; ++i) {
    auto socket = protocol::connectTcp(*parsed, 1000);
    ASSERT_TRUE(socket.isOk());
    crowd.push_back(std::make_unique<protocol::Connection>(std::move(*socket), "crowd"));
  }
  // The server accepts in order: the crowd holds the 4 slots by the time
  // the fifth is accepted.
  auto fifth = protocol::connectTcp(*parsed, 1000);
  ASSERT_TRUE(fifth.isOk());
  protocol::Connection refused(std::move(*fifth), "fifth");
  const protocol::Frame error = nextFrame(refused);
  ASSERT_EQ(error.header.type, static_cast<uint16_t>(protocol::MessageType::kError))
      << readFile(out / "server.log");
  protocol::ErrorMessage said;
  ASSERT_TRUE(protocol::decodeFrame(error, said).isOk());
  EXPECT_NE(said.message.find("--max-handshaking-per-address"), std::string::npos) << said.message;
  EXPECT_NE(readFile(out / "server.log").find("already in their handshake"), std::string::npos);
  // The crowd is closed at its deadline; then the address is welcome again.
  for (auto& c : crowd) {
    Status closed;
    EXPECT_EQ(nextFrame(*c, &closed).bytes.size(), 0u);
    EXPECT_FALSE(closed.isOk()) << "closed by the server, not still open after 10 s";
  }
  auto late = admittedByHand(endpoint, protocol::Role::kClient, 0);
  EXPECT_NE(late, nullptr) << readFile(out / "server.log");
  kill(server, SIGTERM);
  EXPECT_EQ(waitExit(server, 10), 0);
  fs::remove_all(out);
}

}  // namespace
}  // namespace holofuse

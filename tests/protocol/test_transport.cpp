// Connection over real sockets: partial reads and writes, the bounded send
// queue, and version negotiation.
#include <gtest/gtest.h>
#include <poll.h>

#include <deque>

#include "protocol/connection.h"
#include "protocol/handshake.h"
#include "protocol/messages.h"
#include "protocol/socket.h"

namespace holofuse::protocol {
namespace {

Bytes bigPodFrame(uint64_t id, size_t bytes) {
  static std::deque<std::vector<uint8_t>> storage;
  storage.emplace_back(bytes);
  for (size_t i = 0; i < bytes; ++i) storage.back()[i] = static_cast<uint8_t>(i * 13 + id);
  PodFrame f;
  f.frame_id = id;
  Plane p;
  p.kind = PlaneKind::kColor;
  p.format = PixelFormat::kGray8;
  p.width = 1000;  // callers pass multiples of 1000
  p.height = static_cast<uint32_t>(bytes / 1000);
  p.raw_size = static_cast<uint32_t>(bytes);
  p.data = storage.back();
  f.planes.push_back(p);
  return encodeFrame(f, id);
}

// Pumps both ends until the sender's queue is empty; returns received frames.
std::vector<Frame> pump(Connection& sender, Connection& receiver) {
  std::vector<Frame> got;
  for (int i = 0; i < 100000 && (sender.wantsWrite() || got.empty()); ++i) {
    EXPECT_TRUE(sender.onWritable().isOk());
    const Status s = receiver.onReadable();
    EXPECT_TRUE(s.isOk()) << s.toString();
    while (receiver.hasFrame()) got.push_back(receiver.takeFrame());
    if (!sender.wantsWrite()) {
      (void)receiver.onReadable();
      while (receiver.hasFrame()) got.push_back(receiver.takeFrame());
      break;
    }
  }
  return got;
}

TEST(Transport, LargeFramesSurvivePartialWritesAndReads) {
  auto pair = socketPair();
  ASSERT_TRUE(pair.isOk());
  setBufferSizes(pair->first, 4096, 4096);
  setBufferSizes(pair->second, 4096, 4096);
  ConnectionLimits limits;
  limits.max_queued_droppable = 100;
  Connection a(std::move(pair->first), "a", limits), b(std::move(pair->second), "b", limits);
  for (uint64_t id = 1; id <= 5; ++id) {
    a.send(std::make_shared<const OutgoingFrame>(bigPodFrame(id, 200000)));
  }
  const auto got = pump(a, b);
  ASSERT_EQ(got.size(), 5u);
  for (size_t i = 0; i < got.size(); ++i) {
    PodFrame f;
    ASSERT_TRUE(decodeFrame(got[i], f).isOk());
    EXPECT_EQ(f.frame_id, i + 1);
    EXPECT_EQ(f.planes[0].data[1000], static_cast<uint8_t>(1000 * 13 + i + 1));
  }
}

TEST(Transport, BorrowedPartsGoOutInPlaceAndByteIdenticalThroughPartialWrites) {
  // Planes large enough to be borrowed, sent through tiny socket buffers so
  // every write ends somewhere inside a part.
  auto owner = std::make_shared<std::vector<uint8_t>>(3 * kBorrowMinBytes + 16);  // 4 rows of 3076
  for (size_t i = 0; i < owner->size(); ++i) (*owner)[i] = static_cast<uint8_t>(i * 29 + 5);
  PodFrame f;
  f.frame_id = 77;
  for (int k = 0; k < 2; ++k) {
    Plane p;
    p.kind = k == 0 ? PlaneKind::kColor : PlaneKind::kFeather;
    p.format = PixelFormat::kGray8;
    p.width = static_cast<uint32_t>(owner->size() / 4);
    p.height = 4;
    p.raw_size = static_cast<uint32_t>(owner->size());
    p.data = *owner;
    f.planes.push_back(p);
  }
  const OutgoingFrame outgoing = encodeOutgoing(f, 5, owner);
  EXPECT_GE(outgoing.parts().size(), 4u) << "own, plane, own, plane, own";
  EXPECT_EQ(outgoing.flatten(), encodeFrame(f, 5))
      << "borrowing must not change the bytes on the wire";

  auto pair = socketPair();
  ASSERT_TRUE(pair.isOk());
  setBufferSizes(pair->first, 1024, 1024);
  setBufferSizes(pair->second, 1024, 1024);
  ConnectionLimits limits;
  limits.max_queued_droppable = 100;
  Connection a(std::move(pair->first), "a", limits), b(std::move(pair->second), "b", limits);
  auto shared = std::make_shared<const OutgoingFrame>(encodeOutgoing(f, 5, owner));
  for (int i = 0; i < 3; ++i) a.send(shared);
  a.sendMessage(Heartbeat{9});
  const auto got = pump(a, b);
  ASSERT_EQ(got.size(), 4u);
  for (int i = 0; i < 3; ++i) {
    PodFrame back;
    const Status decoded = decodeFrame(got[i], back);
    ASSERT_TRUE(decoded.isOk()) << decoded.toString();
    ASSERT_EQ(back.planes.size(), 2u);
    EXPECT_TRUE(std::equal(back.planes[1].data.begin(), back.planes[1].data.end(), owner->begin(),
                           owner->end()));
  }
}

TEST(Transport, SlowPeerLosesTheOldestFramesButNeverControlMessages) {
  auto pair = socketPair();
  ASSERT_TRUE(pair.isOk());
  ConnectionLimits limits;
  limits.max_queued_droppable = 2;
  Connection a(std::move(pair->first), "a", limits), b(std::move(pair->second), "b");
  // Nothing is written while the peer "is slow": queue everything first.
  a.sendMessage(
      Calibration{});  // default calibration does not decode (size 0) but is never dropped
  for (uint64_t id = 1; id <= 6; ++id) {
    a.send(std::make_shared<const OutgoingFrame>(bigPodFrame(id, 1000)));
    a.sendMessage(Heartbeat{id});
  }
  EXPECT_EQ(a.framesDropped(), 4u);
  const auto got = pump(a, b);
  std::vector<uint64_t> frame_ids, heartbeats;
  int calibrations = 0;
  for (const auto& f : got) {
    if (f.header.type == static_cast<uint16_t>(MessageType::kPodFrame)) {
      PodFrame p;
      ASSERT_TRUE(decodeFrame(f, p).isOk());
      frame_ids.push_back(p.frame_id);
    } else if (f.header.type == static_cast<uint16_t>(MessageType::kHeartbeat)) {
      Heartbeat h;
      ASSERT_TRUE(decodeFrame(f, h).isOk());
      heartbeats.push_back(h.send_time_ns);
    } else if (f.header.type == static_cast<uint16_t>(MessageType::kCalibration)) {
      ++calibrations;
    }
  }
  EXPECT_EQ(frame_ids, (std::vector<uint64_t>{5, 6}));
  EXPECT_EQ(heartbeats, (std::vector<uint64_t>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(calibrations, 1);
}

TEST(Transport, APeerThatClosesIsReportedAsClosed) {
  auto pair = socketPair();
  ASSERT_TRUE(pair.isOk());
  Connection b(std::move(pair->second), "peer");
  pair->first.close();
  const Status s = b.onReadable();
  EXPECT_EQ(s.code(), StatusCode::kClosed);
  EXPECT_NE(s.message().find("peer"), std::string::npos);
}

TEST(Transport, GarbageFromAPeerNamesTheProblem) {
  auto pair = socketPair();
  ASSERT_TRUE(pair.isOk());
  Connection b(std::move(pair->second), "hostile");
  const std::string junk = "GET / HTTP/1.1\r\nHost: x\r\n\r\n";
  iovec part{const_cast<char*>(junk.data()), junk.size()};
  ASSERT_EQ(pair->first.writeVector(&part, 1).bytes, junk.size());
  const Status s = b.onReadable();
  EXPECT_EQ(s.code(), StatusCode::kBadMagic);
  EXPECT_NE(s.message().find("hostile"), std::string::npos);
  EXPECT_NE(s.message().find("magic"), std::string::npos);
}

TEST(Transport, ListenAndConnectOnLoopback) {
  auto listener = listenTcp(Endpoint{"127.0.0.1", 0});
  ASSERT_TRUE(listener.isOk()) << listener.status().toString();
  const uint16_t port = listener->localPort();
  ASSERT_NE(port, 0);
  auto client = connectTcp(Endpoint{"127.0.0.1", port}, 1000);
  ASSERT_TRUE(client.isOk());
  pollfd p{listener->fd(), POLLIN, 0};
  ASSERT_EQ(::poll(&p, 1, 1000), 1);
  Socket accepted = listener->acceptOne(nullptr);
  EXPECT_TRUE(accepted.valid());
  // A port nobody listens on: a clear error naming the endpoint.
  listener->close();
  auto refused = connectTcp(Endpoint{"127.0.0.1", port}, 500);
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.status().message().find(std::to_string(port)), std::string::npos);
}

TEST(Endpoint, ParsesAndRejectsWithReasons) {
  auto e = parseEndpoint("127.0.0.1:7300");
  ASSERT_TRUE(e.isOk());
  EXPECT_EQ(e->port, 7300);
  EXPECT_EQ(parseEndpoint("[::1]:80")->host, "::1");
  EXPECT_FALSE(parseEndpoint("localhost").isOk());
  EXPECT_FALSE(parseEndpoint("host:99999").isOk());
  EXPECT_FALSE(parseEndpoint("host:12ab").isOk());
}

TEST(Handshake, PicksTheHighestCommonVersionAndRefusesOtherMajors) {
  Hello hello;
  auto ack = negotiate(hello);
  ASSERT_TRUE(ack.isOk());
  EXPECT_EQ(ack->major, kVersionMajor);
  EXPECT_TRUE(checkAck(hello, *ack).isOk());
  Hello future;
  future.min_major = future.max_major = kVersionMajor + 1;
  auto refused = negotiate(future);
  ASSERT_FALSE(refused.isOk());
  EXPECT_EQ(refused.status().code(), StatusCode::kUnsupportedVersion);
  EXPECT_NE(refused.status().message().find("2.0"), std::string::npos);
  HelloAck wrong;
  wrong.major = kVersionMajor + 1;
  EXPECT_FALSE(checkAck(hello, wrong).isOk());
}

// A server standing in for an older release (--protocol 1.4) agrees on at
// most that minor, and refuses a peer that needs a newer one by name.
TEST(Handshake, AServerHeldToAnOlderMinorAgreesOnItAndNoNewer) {
  Hello newest;
  auto ack = negotiate(newest, 4);
  ASSERT_TRUE(ack.isOk());
  EXPECT_EQ(ack->minor, 4);
  EXPECT_TRUE(checkAck(newest, *ack).isOk());
  Hello old;
  old.max_minor = 2;
  EXPECT_EQ(negotiate(old, 4)->minor, 2);
  Hello needs_new;
  needs_new.min_minor = 6;
  const auto refused = negotiate(needs_new, 4);
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.status().message().find("this server speaks 1.0..1.4"), std::string::npos)
      << refused.status().message();
  EXPECT_EQ(*parseProtocolVersion("1.4"), 4);
  EXPECT_EQ(*parseProtocolVersion("1." + std::to_string(kVersionMinor)), kVersionMinor);
  for (const char* bad : {"2.0", "1.", "1.99", "1.4x", "four"}) {
    const auto parsed = parseProtocolVersion(bad);
    ASSERT_FALSE(parsed.isOk()) << bad;
    EXPECT_NE(parsed.status().message().find(bad), std::string::npos) << parsed.status().message();
  }
}

}  // namespace
}  // namespace holofuse::protocol

#include "peer_by_hand.h"

#include <poll.h>

#include "process_harness.h"
#include "protocol/auth.h"
#include "protocol/socket.h"

namespace holofuse::test {

protocol::Frame nextFrame(protocol::Connection& c, Status* closed, int timeout_ms) {
  for (int waited = 0; waited < timeout_ms; waited += 50) {
    if (c.hasFrame()) return c.takeFrame();
    pollfd p{c.fd(), POLLIN, 0};
    ::poll(&p, 1, 50);
    const Status s = c.onReadable();
    if (c.hasFrame()) return c.takeFrame();
    if (!s.isOk()) {
      if (closed) *closed = s;
      return {};
    }
  }
  return {};
}

void flush(protocol::Connection& c) {
  while (c.wantsWrite()) {
    pollfd p{c.fd(), POLLOUT, 0};
    ::poll(&p, 1, 100);
    if (!c.onWritable().isOk()) return;
  }
}

std::unique_ptr<protocol::Connection> admittedByHand(const std::string& endpoint,
                                                     protocol::Role role, uint32_t id) {
  auto parsed = protocol::parseEndpoint(endpoint);
  auto key = protocol::loadPeerKey(test::testKeyFile(), role, id);
  if (!parsed.isOk() || !key.isOk()) return nullptr;
  auto socket = protocol::connectTcp(*parsed, 1000);
  if (!socket.isOk()) return nullptr;
  auto c = std::make_unique<protocol::Connection>(std::move(*socket), "by hand");
  protocol::Hello hello;
  hello.role = role;
  hello.id = id;
  hello.nonce = protocol::randomNonce();
  c->sendMessage(hello);
  flush(*c);
  const protocol::Frame challenge_frame = nextFrame(*c);
  protocol::Auth challenge;
  if (!protocol::decodeFrame(challenge_frame, challenge).isOk()) return nullptr;
  protocol::Auth answer;
  answer.step = protocol::AuthStep::kResponse;
  answer.value =
      protocol::authMac(*key, protocol::AuthStep::kResponse, hello, challenge_frame.header.major,
                        challenge_frame.header.minor, challenge.value);
  c->sendMessage(answer);
  flush(*c);
  protocol::Auth proof;
  protocol::HelloAck ack;
  if (!protocol::decodeFrame(nextFrame(*c), proof).isOk() ||
      !protocol::decodeFrame(nextFrame(*c), ack).isOk())
    return nullptr;
  return c;
}

protocol::Frame nextError(protocol::Connection& c) {
  protocol::Frame frame = nextFrame(c);
  while (!frame.bytes.empty() &&
         frame.header.type != static_cast<uint16_t>(protocol::MessageType::kError))
    frame = nextFrame(c);
  return frame;
}

}  // namespace holofuse::test

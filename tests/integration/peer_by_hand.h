// Peers driven byte by byte from a test: the next frame from a connection
// (or how it closed), a flush of what is queued, and a peer admitted by
// hand with this test process's key, whose every later byte is the
// test's to choose.
#pragma once

#include <memory>
#include <string>

#include "base/status.h"
#include "protocol/connection.h"
#include "protocol/messages.h"

namespace holofuse::test {

// The next frame from c, or an empty frame when the peer closed (closed,
// when given, says how) or took longer than timeout_ms (a failed test,
// never a pass).
protocol::Frame nextFrame(protocol::Connection& c, Status* closed = nullptr,
                          int timeout_ms = 10000);

// The next Error frame, skipping whatever else the server sends before it
// (heartbeats, a client's frames); empty when c closes first.
protocol::Frame nextError(protocol::Connection& c);

// Sends everything c has queued.
void flush(protocol::Connection& c);

// Hello, the answer to the challenge, HelloAck: a peer the server
// admitted as role and id; null when it did not.
std::unique_ptr<protocol::Connection> admittedByHand(const std::string& endpoint,
                                                     protocol::Role role, uint32_t id);

}  // namespace holofuse::test

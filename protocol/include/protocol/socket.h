// RAII TCP socket: every raw socket call of the project lives in socket.cpp.
#pragma once

#include <sys/uio.h>

#include <cstdint>
#include <span>
#include <string>

#include "base/status.h"

namespace holofuse::protocol {

struct Endpoint {
  std::string host = "127.0.0.1";
  uint16_t port = 0;
  std::string toString() const { return host + ":" + std::to_string(port); }
};

// Parses "HOST:PORT" (port 0..65535; "[::1]:PORT" for IPv6).
StatusOr<Endpoint> parseEndpoint(const std::string& text);

// Whether the endpoint's host is this machine's loopback only (127.0.0.0/8,
// ::1, localhost): what a server without authentication may bind.
bool isLoopback(const Endpoint& endpoint);

// Outcome of one non-blocking read or write.
struct IoResult {
  size_t bytes = 0;
  bool would_block = false;
  bool closed = false;  // orderly shutdown by the peer (read returned 0)
  int error = 0;        // errno for a hard error, 0 otherwise
};

class Socket {
 public:
  Socket() = default;
  explicit Socket(int fd) : fd_(fd) {}
  ~Socket();
  Socket(Socket&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }
  Socket& operator=(Socket&& other) noexcept;
  Socket(const Socket&) = delete;
  Socket& operator=(const Socket&) = delete;

  int fd() const { return fd_; }
  bool valid() const { return fd_ >= 0; }
  void close();
  // Sends FIN after everything written so far; reading goes on.
  void shutdownWrite();

  // Retries on EINTR; EAGAIN becomes would_block.
  IoResult readSome(std::span<uint8_t> into);
  IoResult writeVector(const iovec* parts, int count);
  // Accepts one pending connection (non-blocking, TCP_NODELAY set), or an
  // invalid Socket when none is pending.
  // The next pending connection, or an invalid Socket; error (when given)
  // gets accept's errno then (EAGAIN: none pending; EMFILE: out of
  // descriptors, and the connection waits in the backlog).
  Socket acceptOne(std::string* peer, int* error = nullptr);
  // The local port (after binding to port 0).
  uint16_t localPort() const;

 private:
  int fd_ = -1;
};

// A non-blocking listening socket with SO_REUSEADDR.
StatusOr<Socket> listenTcp(const Endpoint& endpoint, int backlog = 64);
// Connects with a timeout, then makes the socket non-blocking with TCP_NODELAY.
StatusOr<Socket> connectTcp(const Endpoint& endpoint, int timeout_ms);
// A connected pair of non-blocking stream sockets (tests of partial I/O).
StatusOr<std::pair<Socket, Socket>> socketPair();
// Shrinks the kernel buffers (tests that need partial writes).
void setBufferSizes(const Socket& socket, int send_bytes, int receive_bytes);

}  // namespace holofuse::protocol

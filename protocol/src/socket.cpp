#include "protocol/socket.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstring>

namespace holofuse::protocol {
namespace {

void setNonBlocking(int fd) {
  const int flags = fcntl(fd, F_GETFL, 0);
  fcntl(fd, F_SETFL, flags | O_NONBLOCK);
}

void setNoDelay(int fd) {
  int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
}

Status ioError(const std::string& what, const Endpoint& endpoint, int err) {
  return Status(StatusCode::kIoError, what + " " + endpoint.toString() + ": " + std::strerror(err));
}

StatusOr<addrinfo*> resolve(const Endpoint& endpoint, bool passive) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = passive ? AI_PASSIVE : 0;
  addrinfo* result = nullptr;
  const std::string port = std::to_string(endpoint.port);
  const int rc = getaddrinfo(endpoint.host.c_str(), port.c_str(), &hints, &result);
  if (rc != 0) {
    return Status(StatusCode::kIoError,
                  "cannot resolve '" + endpoint.host + "': " + gai_strerror(rc));
  }
  return result;
}

}  // namespace

StatusOr<Endpoint> parseEndpoint(const std::string& text) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == text.size()) {
    return Status(StatusCode::kMalformed, "endpoint '" + text + "' is not HOST:PORT");
  }
  Endpoint e;
  e.host = text.substr(0, colon);
  if (e.host.size() > 2 && e.host.front() == '[' && e.host.back() == ']') {
    e.host = e.host.substr(1, e.host.size() - 2);
  }
  const std::string port = text.substr(colon + 1);
  if (port.find_first_not_of("0123456789") != std::string::npos || port.size() > 5) {
    return Status(StatusCode::kMalformed,
                  "endpoint '" + text + "': port '" + port + "' is not a number in 0..65535");
  }
  const unsigned long value = std::stoul(port);
  if (value > 65535) {
    return Status(StatusCode::kMalformed, "endpoint '" + text + "': port above 65535");
  }
  e.port = static_cast<uint16_t>(value);
  return e;
}

Socket::~Socket() { close(); }

Socket& Socket::operator=(Socket&& other) noexcept {
  if (this != &other) {
    close();
    fd_ = other.fd_;
    other.fd_ = -1;
  }
  return *this;
}

void Socket::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

void Socket::shutdownWrite() {
  if (fd_ >= 0) ::shutdown(fd_, SHUT_WR);
}

IoResult Socket::readSome(std::span<uint8_t> into) {
  IoResult r;
  for (;;) {
    const ssize_t n = ::read(fd_, into.data(), into.size());
    if (n > 0) {
      r.bytes = static_cast<size_t>(n);
    } else if (n == 0) {
      r.closed = !into.empty();
    } else if (errno == EINTR) {
      continue;
    } else if (errno == EAGAIN || errno == EWOULDBLOCK) {
      r.would_block = true;
    } else {
      r.error = errno;
    }
    return r;
  }
}

IoResult Socket::writeVector(const iovec* parts, int count) {
  IoResult r;
  msghdr msg{};
  msg.msg_iov = const_cast<iovec*>(parts);
  msg.msg_iovlen = static_cast<size_t>(count);
  for (;;) {
    // MSG_NOSIGNAL: a dead peer is an error return, never a SIGPIPE.
    const ssize_t n = ::sendmsg(fd_, &msg, MSG_NOSIGNAL);
    if (n >= 0) {
      r.bytes = static_cast<size_t>(n);
    } else if (errno == EINTR) {
      continue;
    } else if (errno == EAGAIN || errno == EWOULDBLOCK) {
      r.would_block = true;
    } else {
      r.error = errno;
    }
    return r;
  }
}

Socket Socket::acceptOne(std::string* peer, int* error) {
  sockaddr_storage addr{};
  socklen_t len = sizeof(addr);
  int fd;
  do {
    fd = ::accept4(fd_, reinterpret_cast<sockaddr*>(&addr), &len, SOCK_NONBLOCK | SOCK_CLOEXEC);
  } while (fd < 0 && errno == EINTR);
  if (fd < 0) {
    if (error != nullptr) *error = errno;
    return Socket();
  }
  setNoDelay(fd);
  if (peer != nullptr) {
    char host[NI_MAXHOST] = {};
    char port[NI_MAXSERV] = {};
    getnameinfo(reinterpret_cast<sockaddr*>(&addr), len, host, sizeof(host), port, sizeof(port),
                NI_NUMERICHOST | NI_NUMERICSERV);
    *peer = std::string(host) + ":" + port;
  }
  return Socket(fd);
}

uint16_t Socket::localPort() const {
  sockaddr_storage addr{};
  socklen_t len = sizeof(addr);
  if (getsockname(fd_, reinterpret_cast<sockaddr*>(&addr), &len) != 0) return 0;
  if (addr.ss_family == AF_INET) return ntohs(reinterpret_cast<sockaddr_in*>(&addr)->sin_port);
  if (addr.ss_family == AF_INET6) return ntohs(reinterpret_cast<sockaddr_in6*>(&addr)->sin6_port);
  return 0;
}

StatusOr<Socket> listenTcp(const Endpoint& endpoint, int backlog) {
  auto resolved = resolve(endpoint, true);
  if (!resolved.isOk()) return resolved.status();
  Status last(StatusCode::kIoError, "no address for " + endpoint.toString());
  for (addrinfo* ai = *resolved; ai != nullptr; ai = ai->ai_next) {
    Socket s(::socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC, ai->ai_protocol));
    if (!s.valid()) {
      last = ioError("socket for", endpoint, errno);
      continue;
    }
    int one = 1;
    setsockopt(s.fd(), SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
    if (::bind(s.fd(), ai->ai_addr, ai->ai_addrlen) != 0) {
      last = ioError("cannot bind", endpoint, errno);
      continue;
    }
    if (::listen(s.fd(), backlog) != 0) {
      last = ioError("cannot listen on", endpoint, errno);
      continue;
    }
    setNonBlocking(s.fd());
    freeaddrinfo(*resolved);
    return s;
  }
  freeaddrinfo(*resolved);
  return last;
}

StatusOr<Socket> connectTcp(const Endpoint& endpoint, int timeout_ms) {
  auto resolved = resolve(endpoint, false);
  if (!resolved.isOk()) return resolved.status();
  Status last(StatusCode::kIoError, "no address for " + endpoint.toString());
  for (addrinfo* ai = *resolved; ai != nullptr; ai = ai->ai_next) {
    Socket s(::socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC, ai->ai_protocol));
    if (!s.valid()) continue;
    setNonBlocking(s.fd());
    int rc = ::connect(s.fd(), ai->ai_addr, ai->ai_addrlen);
    if (rc != 0 && errno == EINPROGRESS) {
      pollfd p{s.fd(), POLLOUT, 0};
      do {
        rc = ::poll(&p, 1, timeout_ms);
      } while (rc < 0 && errno == EINTR);
      if (rc == 0) {
        last = Status(StatusCode::kTimeout, "connect to " + endpoint.toString() + " timed out");
        continue;
      }
      int err = 0;
      socklen_t len = sizeof(err);
      getsockopt(s.fd(), SOL_SOCKET, SO_ERROR, &err, &len);
      if (err != 0) {
        last = ioError("cannot connect to", endpoint, err);
        continue;
      }
    } else if (rc != 0) {
      last = ioError("cannot connect to", endpoint, errno);
      continue;
    }
    setNoDelay(s.fd());
    freeaddrinfo(*resolved);
    return s;
  }
  freeaddrinfo(*resolved);
  return last;
}

StatusOr<std::pair<Socket, Socket>> socketPair() {
  int fds[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0, fds) != 0) {
    return Status(StatusCode::kIoError, std::string("socketpair: ") + std::strerror(errno));
  }
  return std::make_pair(Socket(fds[0]), Socket(fds[1]));
}

void setBufferSizes(const Socket& socket, int send_bytes, int receive_bytes) {
  setsockopt(socket.fd(), SOL_SOCKET, SO_SNDBUF, &send_bytes, sizeof(send_bytes));
  setsockopt(socket.fd(), SOL_SOCKET, SO_RCVBUF, &receive_bytes, sizeof(receive_bytes));
}

bool isLoopback(const Endpoint& endpoint) {
  const std::string& h = endpoint.host;
  return h == "localhost" || h == "::1" || h == "[::1]" || h.rfind("127.", 0) == 0;
}

}  // namespace holofuse::protocol

#include "deploy/link_relay.h"

#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <fstream>
#include <memory>
#include <random>
#include <vector>

#include "base/shutdown.h"
#include "protocol/clock.h"
#include "protocol/socket.h"

namespace holofuse::deploy {
namespace {

using protocol::monotonicNs;

constexpr size_t kReadBytes = 64 * 1024;

// What one read took in, and when it may go out.
struct Held {
  uint64_t release_ns = 0;
  std::vector<uint8_t> bytes;
  size_t sent = 0;
};

// One direction of a link: bytes read from `from`, held, written to `to`.
struct Direction {
  int from = -1, to = -1;
  std::deque<Held> held;
  size_t held_bytes = 0;
  uint64_t last_release_ns = 0;  // releases never go backwards: the stream's order
  uint64_t line_free_ns = 0;     // when the rate-capped line has sent what it holds
  bool reading_done = false;     // `from` reached its end (or failed)
  bool shut = false;             // the end passed on to `to`
  bool blocked = false;          // `to` took no more: wait for it to be writable
  uint64_t carried = 0;
};

struct Link {
  protocol::Socket down, up;  // the accepted peer, the upstream connection
  Direction to_upstream, to_peer;
  std::string name;
  bool broken = false;
};

class Relay {
 public:
  explicit Relay(const RelayOptions& options)
      : options_(options), impair_(options.impairment), random_(impair_.seed) {}

  Status run() {
    auto listen_at = protocol::parseEndpoint(options_.listen);
    if (!listen_at.isOk()) return listen_at.status();
    auto upstream = protocol::parseEndpoint(options_.upstream);
    if (!upstream.isOk()) return upstream.status();
    upstream_ = *upstream;
    auto listener = protocol::listenTcp(*listen_at, SOMAXCONN);
    if (!listener.isOk()) return listener.status();
    listener_ = std::move(*listener);
    if (!options_.port_file.empty()) std::ofstream(options_.port_file) << listener_.localPort();
    char rate[32] = "uncapped";
    if (impair_.rate_mbit > 0) std::snprintf(rate, sizeof(rate), "%g Mbit/s", impair_.rate_mbit);
    std::fprintf(
        stderr, "[relay] %s:%u -> %s: delay %g ms +- %g, rate %s, stall %g ms every %g s\n",
        listen_at->host.c_str(), listener_.localPort(), options_.upstream.c_str(), impair_.delay_ms,
        impair_.jitter_ms, rate, impair_.stall_ms, impair_.stall_every_s);
    start_ns_ = monotonicNs();
    while (!stopRequested()) {
      const uint64_t now = monotonicNs();
      noteStalls(now);
      std::vector<pollfd> fds = {{listener_.fd(), POLLIN, 0}};
      for (const auto& link : links_) {
        fds.push_back({link->down.fd(), eventsFor(link->to_upstream, link->to_peer), 0});
        fds.push_back({link->up.fd(), eventsFor(link->to_peer, link->to_upstream), 0});
      }
      ::poll(fds.data(), fds.size(), timeoutMs(now));
      if (fds[0].revents & POLLIN) acceptAll();
      for (size_t i = 0; i < links_.size(); ++i) {
        Link& link = *links_[i];
        if (1 + 2 * i + 1 < fds.size()) {
          if (fds[1 + 2 * i].revents & (POLLIN | POLLHUP | POLLERR))
            readInto(link, link.to_upstream);
          if (fds[2 + 2 * i].revents & (POLLIN | POLLHUP | POLLERR)) readInto(link, link.to_peer);
        }
        writeDue(link, link.to_upstream);
        writeDue(link, link.to_peer);
      }
      closeFinished();
    }
    std::fprintf(stderr, "[relay] stopping: %llu bytes towards %s, %llu back, %llu stalls\n",
                 static_cast<unsigned long long>(carried_up_), options_.upstream.c_str(),
                 static_cast<unsigned long long>(carried_down_),
                 static_cast<unsigned long long>(stalls_));
    return Status::ok();
  }

 private:
  // Stall k holds every link from k * every to k * every + stall_ms.
  bool stalled(uint64_t now) const {
    if (impair_.stall_every_s <= 0 || impair_.stall_ms <= 0) return false;
    const uint64_t every = static_cast<uint64_t>(impair_.stall_every_s * 1e9);
    const uint64_t since = now - start_ns_;
    return since >= every && since % every < static_cast<uint64_t>(impair_.stall_ms * 1e6);
  }
  uint64_t stallEndsNs(uint64_t now) const {
    const uint64_t every = static_cast<uint64_t>(impair_.stall_every_s * 1e9);
    const uint64_t since = now - start_ns_;
    return now + static_cast<uint64_t>(impair_.stall_ms * 1e6) - since % every;
  }
  void noteStalls(uint64_t now) {
    const bool now_stalled = stalled(now);
    if (now_stalled && !was_stalled_) {
      ++stalls_;
      std::fprintf(stderr, "[relay] stall %llu: holding every link for %g ms\n",
                   static_cast<unsigned long long>(stalls_), impair_.stall_ms);
    }
    was_stalled_ = now_stalled;
  }

  // A socket is read while the direction from it holds less than the cap
  // (past it TCP's window holds the sender back), and waited on for
  // writing while the direction into it is blocked.
  short eventsFor(const Direction& reading, const Direction& writing) const {
    short events = 0;
    if (!reading.reading_done && reading.held_bytes < impair_.max_held_bytes) events |= POLLIN;
    if (writing.blocked) events |= POLLOUT;
    return events;
  }

  // Until the next held bytes are due or a stall ends, at most 50 ms.
  int timeoutMs(uint64_t now) const {
    uint64_t next = now + 50'000'000ull;
    if (stalled(now)) next = std::min(next, stallEndsNs(now));
    for (const auto& link : links_) {
      for (const Direction* d : {&link->to_upstream, &link->to_peer}) {
        if (!d->held.empty() && !d->blocked)
          next = std::min(next, std::max(now, d->held.front().release_ns));
      }
    }
    return static_cast<int>((next - now + 999'999) / 1'000'000);
  }

  void acceptAll() {
    for (;;) {
      std::string name;
      protocol::Socket down = listener_.acceptOne(&name);
      if (!down.valid()) return;
      auto up = protocol::connectTcp(upstream_, 2000);
      if (!up.isOk()) {
        std::fprintf(stderr, "[relay] %s: cannot reach %s (%s); closing it\n", name.c_str(),
                     options_.upstream.c_str(), up.status().message().c_str());
        continue;
      }
      auto link = std::make_unique<Link>();
      link->down = std::move(down);
      link->up = std::move(*up);
      link->name = name;
      link->to_upstream.from = link->down.fd();
      link->to_upstream.to = link->up.fd();
      link->to_peer.from = link->up.fd();
      link->to_peer.to = link->down.fd();
      std::fprintf(stderr, "[relay] %s linked to %s\n", name.c_str(), options_.upstream.c_str());
      links_.push_back(std::move(link));
    }
  }

  // When bytes read now may leave: after the line has serialised them at
  // the capped rate, plus the delay and its jitter, never before the bytes
  // read earlier.
  uint64_t releaseOf(Direction& d, size_t bytes, uint64_t now) {
    uint64_t sent_ns = now;
    if (impair_.rate_mbit > 0) {
      const double serialise_ns =
          static_cast<double>(bytes) * 8.0 / (impair_.rate_mbit * 1e6) * 1e9;
      d.line_free_ns = std::max(d.line_free_ns, now) + static_cast<uint64_t>(serialise_ns);
      sent_ns = d.line_free_ns;
    }
    double delay_ms = impair_.delay_ms;
    if (impair_.jitter_ms > 0) {
      std::uniform_real_distribution<double> jitter(-impair_.jitter_ms, impair_.jitter_ms);
      delay_ms = std::max(0.0, delay_ms + jitter(random_));
    }
    const uint64_t release = sent_ns + static_cast<uint64_t>(delay_ms * 1e6);
    d.last_release_ns = std::max(d.last_release_ns, release);
    return d.last_release_ns;
  }

  void readInto(Link& link, Direction& d) {
    while (!d.reading_done && d.held_bytes < impair_.max_held_bytes) {
      Held held;
      held.bytes.resize(kReadBytes);
      const ssize_t n = ::read(d.from, held.bytes.data(), held.bytes.size());
      if (n > 0) {
        held.bytes.resize(static_cast<size_t>(n));
        held.release_ns = releaseOf(d, held.bytes.size(), monotonicNs());
        d.held_bytes += held.bytes.size();
        d.held.push_back(std::move(held));
        continue;
      }
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
      if (n < 0 && errno == EINTR) continue;
      d.reading_done = true;  // its end, or an error: the rest still goes out
      if (n < 0) link.broken = true;
    }
  }

  void writeDue(Link& link, Direction& d) {
    const uint64_t now = monotonicNs();
    while (!link.broken && !d.blocked && !d.held.empty() && d.held.front().release_ns <= now &&
           !stalled(now)) {
      Held& front = d.held.front();
      const ssize_t n = ::send(d.to, front.bytes.data() + front.sent,
                               front.bytes.size() - front.sent, MSG_NOSIGNAL);
      if (n < 0) {
        if (errno == EAGAIN || errno == EWOULDBLOCK) {
          d.blocked = true;
          return;
        }
        if (errno == EINTR) continue;
        link.broken = true;
        return;
      }
      front.sent += static_cast<size_t>(n);
      d.carried += static_cast<uint64_t>(n);
      if (front.sent < front.bytes.size()) {
        d.blocked = true;  // the socket took part: its buffer is full
        return;
      }
      d.held_bytes -= front.bytes.size();
      d.held.pop_front();
    }
    if (d.reading_done && d.held.empty() && !d.shut) {
      ::shutdown(d.to, SHUT_WR);  // the end, passed on after the last byte
      d.shut = true;
    }
  }

  void closeFinished() {
    for (size_t i = 0; i < links_.size();) {
      Link& link = *links_[i];
      if (link.broken || (link.to_upstream.shut && link.to_peer.shut)) {
        carried_up_ += link.to_upstream.carried;
        carried_down_ += link.to_peer.carried;
        std::fprintf(stderr, "[relay] %s closed%s: %llu bytes up, %llu down\n", link.name.c_str(),
                     link.broken ? " (an end failed)" : "",
                     static_cast<unsigned long long>(link.to_upstream.carried),
                     static_cast<unsigned long long>(link.to_peer.carried));
        links_.erase(links_.begin() + static_cast<std::ptrdiff_t>(i));
        continue;
      }
      ++i;
    }
  }

  RelayOptions options_;
  LinkImpairment impair_;
  std::mt19937_64 random_;
  protocol::Endpoint upstream_;
  protocol::Socket listener_;
  std::vector<std::unique_ptr<Link>> links_;
  uint64_t start_ns_ = 0, stalls_ = 0, carried_up_ = 0, carried_down_ = 0;
  bool was_stalled_ = false;
};

}  // namespace

Status runRelay(const RelayOptions& options) { return Relay(options).run(); }

}  // namespace holofuse::deploy

#include "protocol/connection.h"

#include <poll.h>

#include <atomic>
#include <cstring>

#include "protocol/clock.h"

namespace holofuse::protocol {

uint64_t nextSequence() {
  static std::atomic<uint64_t> counter{0};
  return counter.fetch_add(1, std::memory_order_relaxed);
}

Connection::Connection(Socket socket, std::string peer_name, ConnectionLimits limits)
    : socket_(std::move(socket)),
      peer_name_(std::move(peer_name)),
      limits_(limits),
      decoder_(limits.max_payload) {
  last_receive_ns_ = monotonicNs();
  last_send_ns_ = last_receive_ns_;
}

void Connection::send(SharedFrame frame, Keep keep) {
  Outgoing out;
  out.droppable = keep == Keep::kAsFlagged && frame->droppable();
  queued_bytes_ += frame->size();
  out.frame = std::move(frame);
  if (out.droppable) ++queued_droppable_;
  queue_.push_back(std::move(out));
  while (queued_droppable_ - startedDroppable() > limits_.max_queued_droppable) {
    dropOldestDroppable();
  }
}

size_t Connection::startedDroppable() const {
  return (!queue_.empty() && queue_.front().droppable && queue_.front().offset != 0) ? 1 : 0;
}

void Connection::dropOldestDroppable() {
  // The head may be half written: it must finish or the stream breaks.
  for (size_t i = 0; i < queue_.size(); ++i) {
    auto& out = queue_[i];
    if (!out.droppable || out.offset != 0) continue;
    queued_bytes_ -= out.frame->size();
    --queued_droppable_;
    ++frames_dropped_;
    queue_.erase(queue_.begin() + static_cast<std::ptrdiff_t>(i));
    return;
  }
}

Status Connection::onWritable() {
  constexpr int kMaxParts = 32;
  while (!queue_.empty()) {
    // Gather the unsent parts of the queued frames: borrowed bulk ranges go
    // out in place.
    iovec parts[kMaxParts];
    int count = 0;
    for (const auto& out : queue_) {
      size_t skip = out.offset;
      for (const auto& part : out.frame->parts()) {
        if (count == kMaxParts) break;
        if (skip >= part.size()) {
          skip -= part.size();
          continue;
        }
        parts[count].iov_base = const_cast<uint8_t*>(part.data() + skip);
        parts[count].iov_len = part.size() - skip;
        skip = 0;
        ++count;
      }
      if (count == kMaxParts) break;
    }
    const IoResult r = socket_.writeVector(parts, count);
    if (r.error != 0) {
      return Status(StatusCode::kIoError,
                    "write to " + peer_name_ + " failed: " + std::strerror(r.error));
    }
    if (r.would_block) break;
    bytes_out_ += r.bytes;
    last_send_ns_ = monotonicNs();
    size_t left = r.bytes;
    while (left > 0 && !queue_.empty()) {
      auto& head = queue_.front();
      const size_t rest = head.frame->size() - head.offset;
      if (left < rest) {
        head.offset += left;
        left = 0;
        break;
      }
      left -= rest;
      queued_bytes_ -= head.frame->size();
      if (head.droppable) --queued_droppable_;
      queue_.pop_front();
    }
  }
  if (queued_bytes_ > limits_.max_queued_bytes) {
    return Status(StatusCode::kIoError, "peer " + peer_name_ +
                                            " is not reading: " + std::to_string(queued_bytes_) +
                                            " bytes of control messages queued");
  }
  return Status::ok();
}

Status Connection::onReadable(size_t budget, size_t max_frames) {
  for (size_t read = 0; read < budget && decoder_.framesWaiting() < max_frames;) {
    auto into = decoder_.writableSpan();
    if (!decoder_.status().isOk()) {
      return Status(decoder_.status().code(),
                    "from " + peer_name_ + ": " + decoder_.status().message());
    }
    // The frames read so far are to be handled first (a header waits
    // for them); the rest stays in the socket, which polls readable.
    if (into.empty()) return Status::ok();
    const IoResult r = socket_.readSome(into);
    if (r.error != 0) {
      return Status(StatusCode::kIoError,
                    "read from " + peer_name_ + " failed: " + std::strerror(r.error));
    }
    if (r.closed) return Status(StatusCode::kClosed, peer_name_ + " closed the connection");
    if (r.would_block) return Status::ok();
    last_receive_ns_ = monotonicNs();
    read += r.bytes;
    decoder_.commit(r.bytes);
    if (!decoder_.status().isOk()) {
      return Status(decoder_.status().code(),
                    "from " + peer_name_ + ": " + decoder_.status().message());
    }
  }
  return Status::ok();
}

void Connection::drain(int timeout_ms) {
  const uint64_t deadline = monotonicNs() + static_cast<uint64_t>(timeout_ms) * 1000000ull;
  while (wantsWrite()) {
    if (!onWritable().isOk()) return;
    if (!wantsWrite()) return;
    const uint64_t now = monotonicNs();
    if (now >= deadline) return;
    pollfd p{fd(), POLLOUT, 0};
    ::poll(&p, 1, static_cast<int>((deadline - now) / 1000000ull) + 1);
  }
}

void Connection::closeGracefully(int timeout_ms) {
  const uint64_t deadline = monotonicNs() + static_cast<uint64_t>(timeout_ms) * 1000000ull;
  drain(timeout_ms);
  if (wantsWrite()) return;  // the peer is not reading: give up
  socket_.shutdownWrite();
  uint8_t scratch[4096];
  for (;;) {
    const IoResult r = socket_.readSome(scratch);
    if (r.closed || r.error != 0) return;
    if (!r.would_block) continue;
    const uint64_t now = monotonicNs();
    if (now >= deadline) return;
    pollfd p{fd(), POLLIN, 0};
    ::poll(&p, 1, static_cast<int>((deadline - now) / 1000000ull) + 1);
  }
}

}  // namespace holofuse::protocol

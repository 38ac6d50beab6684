// Connection: one framed, non-blocking peer. Reads frames straight into
// their buffers, writes with sendmsg from a bounded queue that drops the
// oldest droppable frame for a slow peer (never control messages).
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "base/status.h"
#include "protocol/frame.h"
#include "protocol/messages.h"
#include "protocol/socket.h"

namespace holofuse::protocol {

struct ConnectionLimits {
  uint32_t max_payload = kDefaultMaxPayload;
  // Droppable frames allowed in the queue before the oldest is dropped.
  size_t max_queued_droppable = 4;
  // Hard cap on queued bytes of any kind; beyond it the peer is too slow to
  // keep and the connection fails.
  size_t max_queued_bytes = 512u << 20;
};

// The sender's running frame count (SPEC.md section 2), shared by every
// connection of a process so fanned-out frames carry one number.
uint64_t nextSequence();

class Connection {
 public:
  Connection(Socket socket, std::string peer_name, ConnectionLimits limits = {});

  int fd() const { return socket_.fd(); }
  const std::string& peerName() const { return peer_name_; }
  void setPeerName(std::string name) { peer_name_ = std::move(name); }
  // The peer's host address alone, for caps per address.
  const std::string& address() const { return address_; }
  void setAddress(std::string address) { address_ = std::move(address); }

  // Queues an encoded frame. The flags in its header say whether it may be
  // dropped, unless kept says it may not (a frame a client asked for).
  enum class Keep { kAsFlagged, kAlways };
  void send(SharedFrame frame, Keep keep = Keep::kAsFlagged);
  template <typename Message>
  void sendMessage(const Message& m) {
    send(std::make_shared<const OutgoingFrame>(encodeOutgoing(m, nextSequence())));
  }

  bool wantsWrite() const { return !queue_.empty(); }
  // Writes as much as the socket takes. An error status means the
  // connection is dead.
  Status onWritable();
  // Reads until the socket would block, budget bytes have been read this
  // call, or max_frames complete frames wait in the inbox (the rest waits
  // in the kernel for the next: one peer's flood, of large frames or of
  // tiny ones, cannot take a whole turn of a server's loop). Complete
  // frames go to the inbox. An error status (malformed stream, EOF, I/O
  // error) means close it.
  Status onReadable(size_t budget = SIZE_MAX, size_t max_frames = SIZE_MAX);
  // Writes for up to timeout_ms until the queue is empty (used before close).
  void drain(int timeout_ms);
  // An orderly close within timeout_ms: drain, send FIN, then read (and
  // drop) until the peer closes too. Closing with unread bytes would send
  // a reset, and a reset discards whatever the kernel had not yet sent.
  void closeGracefully(int timeout_ms);

  void setMaxPayload(uint32_t max_payload) { decoder_.setMaxPayload(max_payload); }
  void setTypeCap(MessageType type, uint32_t cap) {
    decoder_.setTypeCap(static_cast<uint16_t>(type), cap);
  }
  bool hasFrame() const { return decoder_.hasFrame(); }
  // Called once every frame taken so far was handled: a header those
  // frames held back (they may raise its cap) is judged by the caps now in
  // force, and reading goes on, without waiting for the socket to poll
  // readable again (its peer may have gone quiet). Ok when none waited.
  Status readOnIfHeaderWaits(size_t budget = SIZE_MAX, size_t max_frames = SIZE_MAX) {
    if (decoder_.hasFrame() || !decoder_.headerWaits()) return Status::ok();
    return onReadable(budget, max_frames);
  }
  Frame takeFrame() { return decoder_.takeFrame(); }

  uint64_t lastReceiveNs() const { return last_receive_ns_; }
  uint64_t lastSendNs() const { return last_send_ns_; }
  uint64_t bytesIn() const { return decoder_.bytesConsumed(); }
  uint64_t bytesOut() const { return bytes_out_; }
  uint64_t framesDropped() const { return frames_dropped_; }
  size_t queuedFrames() const { return queue_.size(); }
  // What this peer holds in the process's memory: frames coming in and
  // frames queued to go out (a fanned-out frame counts for every peer).
  size_t bufferedBytes() const { return decoder_.bufferedBytes() + queued_bytes_; }

 private:
  struct Outgoing {
    SharedFrame frame;
    size_t offset = 0;  // bytes of the frame already written
    bool droppable = false;
  };
  void dropOldestDroppable();
  size_t startedDroppable() const;

  Socket socket_;
  std::string peer_name_;
  std::string address_;
  ConnectionLimits limits_;
  StreamDecoder decoder_;
  std::deque<Outgoing> queue_;
  size_t queued_bytes_ = 0;
  size_t queued_droppable_ = 0;
  uint64_t bytes_out_ = 0;
  uint64_t frames_dropped_ = 0;
  uint64_t last_receive_ns_ = 0;
  uint64_t last_send_ns_ = 0;
};

}  // namespace holofuse::protocol

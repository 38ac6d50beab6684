// The client's pictures written off the render path: PNG encoding costs a
// few milliseconds a frame (more when the disk is slow), which the next
// frame need not wait for. One thread, a bounded queue; a picture that
// finds the queue full is dropped and counted, never the frame (it is
// rendered and reported all the same).
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>

#include "image/image.h"

namespace holofuse::render {

class PictureWriter {
 public:
  explicit PictureWriter(size_t capacity = 4);
  // Writes what is queued, then stops.
  ~PictureWriter();
  PictureWriter(const PictureWriter&) = delete;
  PictureWriter& operator=(const PictureWriter&) = delete;

  // Queues picture for path: false when the queue is full (the picture is
  // dropped and counted). It is written aside and renamed, so whoever
  // watches the folder never reads half a picture.
  bool submit(Image8 picture, std::filesystem::path path);
  // Returns once every picture queued so far is written (or failed).
  void flush();

  uint64_t written() const;
  uint64_t dropped() const;
  uint64_t failed() const;  // a write or rename that failed (said on stderr)

 private:
  struct Job {
    Image8 picture;
    std::filesystem::path path;
  };
  void run();

  const size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable wake_, idle_;
  std::deque<Job> queue_;
  bool busy_ = false, stopping_ = false;
  uint64_t written_ = 0, dropped_ = 0, failed_ = 0;
  std::thread thread_;  // last: started once the rest is ready
};

// Writes picture to path through a file beside it, renamed into place:
// whether it was written (an error is said on stderr).
bool writePictureAtomically(const Image8& picture, const std::filesystem::path& path);

}  // namespace holofuse::render

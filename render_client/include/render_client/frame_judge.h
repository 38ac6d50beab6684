// The live judge: a separate program that knows the truth the pods film
// (eval's holofuse_judge, which the launcher starts with --quality), so
// that the client itself links no scene and no metric. The client hands it
// each written frame, and reads back the frame's quality; one line of JSON
// each way over the judge's stdin and stdout (docs/report-json.md, "Live
// quality").
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <optional>
#include <string>

#include "base/status.h"
#include "geometry/camera.h"
#include "report/latency_report.h"

namespace holofuse::render {

// A frame to judge: the PNG the client wrote, the user camera it was
// rendered from, and the frame id of its mesh (the pods' clock).
struct JudgeRequest {
  std::string picture;
  uint64_t frame_id = 0;
  Camera view;
};

// The judge's answer: the frame's quality; none when the true view holds
// nothing of the subject; or an error that names what went wrong with
// this frame (a picture of another size than the view, say).
struct JudgeAnswer {
  std::optional<report::FrameQuality> quality;
  std::string error;
};

std::string encodeJudgeRequest(const JudgeRequest& request);
StatusOr<JudgeRequest> decodeJudgeRequest(const std::string& line);
std::string encodeJudgeAnswer(const JudgeAnswer& answer);
StatusOr<JudgeAnswer> decodeJudgeAnswer(const std::string& line);

// The judge as the client runs it: a child process started from a shell
// command line, its stderr the client's.
class FrameJudge {
 public:
  // An error when the command cannot start. A judge that takes longer
  // than answer_timeout_ms over one frame counts as gone: the client must
  // not hang on it.
  static StatusOr<FrameJudge> start(const std::string& command, int answer_timeout_ms = 30000);
  FrameJudge(FrameJudge&& other) noexcept;
  FrameJudge& operator=(FrameJudge&&) = delete;
  FrameJudge(const FrameJudge&) = delete;
  // Closes its stdin, so it ends, and reaps it.
  ~FrameJudge();

  // The frame's answer; an error when the judge is gone (it exited, wrote
  // something that is not an answer, or did not answer in time), after
  // which every call fails.
  StatusOr<JudgeAnswer> judge(const JudgeRequest& request);

 private:
  FrameJudge(pid_t pid, int to_judge, int from_judge, std::string command, int timeout_ms);
  pid_t pid_ = -1;
  int timeout_ms_ = 0;
  int to_judge_ = -1, from_judge_ = -1;
  std::string command_;
  std::string pending_;  // read past the last answer's newline
};

}  // namespace holofuse::render

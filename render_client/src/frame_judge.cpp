#include "render_client/frame_judge.h"

#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <nlohmann/json.hpp>

#include "base/process.h"

namespace nlohmann {

// glm's matrices and vectors as JSON arrays (a matrix by columns, as glm
// stores it), so that the type macros below can name them.
template <>
struct adl_serializer<glm::dvec3> {
  static void to_json(json& j, const glm::dvec3& v) { j = {v.x, v.y, v.z}; }
  static void from_json(const json& j, glm::dvec3& v) {
    v = {j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>()};
  }
};

template <>
struct adl_serializer<glm::dmat3> {
  static void to_json(json& j, const glm::dmat3& m) { j = {m[0], m[1], m[2]}; }
  static void from_json(const json& j, glm::dmat3& m) {
    for (int c = 0; c < 3; ++c) m[c] = j.at(c).get<glm::dvec3>();
  }
};

}  // namespace nlohmann

namespace holofuse {

NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(Camera, id, width, height, fx, fy, cx, cy, skew, distortion,
                                   rotation, translation)

namespace report {
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(FrameQuality, psnr_db, ssim)
}  // namespace report

namespace render {

NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(JudgeRequest, picture, frame_id, view)

namespace {

// JSON's own errors (a missing key, a string where a number goes) as a
// status that says which message it was.
template <typename Parse>
auto parseLine(const std::string& line, const char* what, Parse parse)
    -> StatusOr<decltype(parse(nlohmann::json()))> {
  try {
    return parse(nlohmann::json::parse(line));
  } catch (const nlohmann::json::exception& e) {
    return Status(StatusCode::kMalformed,
                  std::string("judge ") + what + " '" + line.substr(0, 200) + "': " + e.what());
  }
}

}  // namespace

std::string encodeJudgeRequest(const JudgeRequest& request) {
  return nlohmann::json(request).dump();
}

StatusOr<JudgeRequest> decodeJudgeRequest(const std::string& line) {
  return parseLine(line, "request", [](const nlohmann::json& j) { return j.get<JudgeRequest>(); });
}

// {"quality": {...}}, {"quality": null} (nothing to judge), or {"error": "..."}.
std::string encodeJudgeAnswer(const JudgeAnswer& answer) {
  nlohmann::json j;
  if (!answer.error.empty()) {
    j["error"] = answer.error;
  } else {
    j["quality"] = answer.quality ? nlohmann::json(*answer.quality) : nlohmann::json(nullptr);
  }
  return j.dump();
}

StatusOr<JudgeAnswer> decodeJudgeAnswer(const std::string& line) {
  return parseLine(line, "answer", [](const nlohmann::json& j) {
    JudgeAnswer answer;
    if (j.contains("error")) {
      answer.error = j.at("error").get<std::string>();
    } else if (!j.at("quality").is_null()) {
      answer.quality = j.at("quality").get<report::FrameQuality>();
    }
    return answer;
  });
}

StatusOr<FrameJudge> FrameJudge::start(const std::string& command, int answer_timeout_ms) {
  if (command.empty()) return Status(StatusCode::kMalformed, "no judge command");
  ChildPipes pipes;
  // Through the shell, so the launcher can quote its words; the judge
  // ends when its stdin does, and the shell with it.
  auto pid = spawnProcess({"/bin/sh", "-c", command}, {}, &pipes);
  if (!pid.isOk()) return pid.status();
  return FrameJudge(*pid, pipes.to_child, pipes.from_child, command, answer_timeout_ms);
}

FrameJudge::FrameJudge(pid_t pid, int to_judge, int from_judge, std::string command, int timeout_ms)
    : pid_(pid),
      timeout_ms_(timeout_ms),
      to_judge_(to_judge),
      from_judge_(from_judge),
      command_(std::move(command)) {}

FrameJudge::FrameJudge(FrameJudge&& other) noexcept
    : pid_(std::exchange(other.pid_, -1)),
      timeout_ms_(other.timeout_ms_),
      to_judge_(std::exchange(other.to_judge_, -1)),
      from_judge_(std::exchange(other.from_judge_, -1)),
      command_(std::move(other.command_)),
      pending_(std::move(other.pending_)) {}

FrameJudge::~FrameJudge() {
  if (to_judge_ >= 0) ::close(to_judge_);
  if (from_judge_ >= 0) ::close(from_judge_);
  // Its stdin closed, the judge ends on its own; one that does not is stopped.
  if (pid_ > 0) stopProcess(pid_, 2000);
}

StatusOr<JudgeAnswer> FrameJudge::judge(const JudgeRequest& request) {
  const auto gone = [&](const std::string& why) {
    if (to_judge_ >= 0) ::close(to_judge_);
    to_judge_ = -1;
    return Status(StatusCode::kIoError, "the judge (" + command_ + ") " + why);
  };
  if (to_judge_ < 0) return gone("is gone");
  const std::string line = encodeJudgeRequest(request) + "\n";
  // A judge that has ended closes the pipe: the write fails with EPIPE, and
  // the SIGPIPE it raises (blocked here, then taken) must not end a process
  // that does not ignore it.
  sigset_t pipe_only, before;
  sigemptyset(&pipe_only);
  sigaddset(&pipe_only, SIGPIPE);
  pthread_sigmask(SIG_BLOCK, &pipe_only, &before);
  int write_error = 0;
  for (size_t sent = 0; sent < line.size();) {
    const ssize_t n = ::write(to_judge_, line.data() + sent, line.size() - sent);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      write_error = n < 0 ? errno : EIO;
      break;
    }
    sent += static_cast<size_t>(n);
  }
  if (write_error == EPIPE) {
    const timespec now{};
    while (sigtimedwait(&pipe_only, nullptr, &now) == SIGPIPE) {
    }
  }
  pthread_sigmask(SIG_SETMASK, &before, nullptr);
  if (write_error != 0) return gone(std::string("does not read: ") + std::strerror(write_error));
  for (;;) {
    if (const size_t end = pending_.find('\n'); end != std::string::npos) {
      const std::string answer = pending_.substr(0, end);
      pending_.erase(0, end + 1);
      auto decoded = decodeJudgeAnswer(answer);
      if (!decoded.isOk()) return gone(decoded.status().message());
      return decoded;
    }
    pollfd readable{from_judge_, POLLIN, 0};
    const int ready = ::poll(&readable, 1, timeout_ms_);
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) return gone("did not answer within " + std::to_string(timeout_ms_) + " ms");
    std::array<char, 4096> chunk;
    const ssize_t n = ::read(from_judge_, chunk.data(), chunk.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return gone(std::string("cannot be read: ") + std::strerror(errno));
    if (n == 0) return gone("ended without answering");
    pending_.append(chunk.data(), static_cast<size_t>(n));
  }
}

}  // namespace render
}  // namespace holofuse

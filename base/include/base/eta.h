// Time left of a long run of similar steps (a sweep's points, an eval's
// views), from the pace of the steps done so far.
#pragma once

#include <chrono>
#include <cstddef>
#include <string>

namespace holofuse {

class Eta {
 public:
  Eta() : start_(std::chrono::steady_clock::now()) {}
  // A step of real work finished; steps that cost nothing (a sweep point
  // already on disk) are left out, so they do not shorten the estimate.
  void stepDone() { ++steps_; }
  // "ETA 2 min 30 s" for `left` more steps at the pace so far; "" before
  // the first step, when there is no pace yet.
  std::string text(size_t left) const;
  // For work measured in shares of steps rather than whole steps counted
  // by stepDone: `done` of them done since construction, `left` to go.
  std::string textOfShares(double done, double left) const;
  // The same from a pace given in seconds per step.
  static std::string text(double seconds_per_step, size_t left);
  // A count against its total at a pace of `per_second` steps: "12/40
  // (ETA 7 s)"; "12/40" with no pace yet or when done; "12" with no total.
  static std::string countOf(size_t done, size_t total, double per_second);

 private:
  std::chrono::steady_clock::time_point start_;
  size_t steps_ = 0;
};

}  // namespace holofuse

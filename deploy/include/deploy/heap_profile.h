// Where a soak's server heap goes (./holofuse soak --profile): the server
// runs with heaptrack's preload library (Debian package heaptrack), which
// streams every allocation and free to a trace file. The trace is copied
// as it stands at two moments (the warm-up's end and the last sample),
// each copy interpreted by heaptrack_interpret, and heaptrack_print, told
// to take the later against the earlier (--diff), names the allocation
// sites whose memory still held grew between them: what a leak's report
// needs, from the tool made for it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "base/status.h"

namespace holofuse::deploy {

struct HeapGrowthSite {
  double bytes = 0;    // held at the later moment minus at the earlier
  uint64_t calls = 0;  // allocations the site made between the two moments
  // The first frame of its backtrace outside the standard library and the
  // allocator (the code that asked), and where it is.
  std::string function, location;
};

struct HeapGrowth {
  double total_bytes = 0;             // the heap held, later minus earlier
  std::vector<HeapGrowthSite> sites;  // largest growth first
  std::string account;                // heaptrack_print's full account, a file
};

// The sites heaptrack_print lists under MEMORY LEAKS (with --diff: what
// grew), at most `most` of them, and its total.
HeapGrowth parseHeaptrackGrowth(const std::string& printed, size_t most = 10);

// "483.33K", "1.2M", "512B", "-20.5K": heaptrack's sizes, in bytes.
double heaptrackBytes(const std::string& size);

class HeapProfile {
 public:
  // heaptrack found where its package puts it; an error naming the package
  // otherwise. The trace and its accounts go into folder.
  static StatusOr<HeapProfile> find(const std::string& folder);

  // command, run with the preload library tracing into the folder (through
  // env(1), so the process is the program's own, as the soak samples it).
  std::vector<std::string> wrap(const std::vector<std::string>& command) const;
  // The trace as it stands, copied under `name` ("warm", "end").
  Status mark(const std::string& name) const;
  // The sites whose held memory grew from mark `from` to mark `to`; the
  // account is written to server-growth.txt in the folder. The trace and
  // the marks' raw copies are removed (read, and compressed, into
  // server-<mark>.gz, which heaptrack_print and heaptrack_gui open).
  StatusOr<HeapGrowth> growth(const std::string& from, const std::string& to) const;

 private:
  std::string folder_, preload_, interpreter_, printer_, env_;
  std::string tracePath() const { return folder_ + "/server.raw"; }
};

}  // namespace holofuse::deploy

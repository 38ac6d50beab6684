#include "deploy/heap_profile.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "base/process.h"

namespace holofuse::deploy {
namespace fs = std::filesystem;

namespace {

// A frame of the standard library or the allocator: not the code that
// asked. Its name is read up to its parameters, past a return type
// ("Outgoing& std::deque<>::emplace_back<>(...)" is the deque's).
bool allocatorFrame(const std::string& function) {
  std::string name = function.substr(0, function.find('('));
  if (const size_t space = name.rfind(' '); space != std::string::npos)
    name = name.substr(space + 1);
  for (const char* prefix : {"std::", "__gnu_cxx::", "operator new", "malloc", "calloc", "realloc",
                             "posix_memalign", "aligned_alloc", "<unresolved"})
    if (name.rfind(prefix, 0) == 0) return true;
  return false;
}

std::string trimmed(const std::string& line) {
  const size_t first = line.find_first_not_of(' ');
  return first == std::string::npos ? std::string() : line.substr(first);
}

// findProgram's path, resolved, since heaptrack's own files lie beside
// where its launcher really is: empty when none.
fs::path inPath(const std::string& name) {
  const std::string found = findProgram(name);
  std::error_code error;
  return found.empty() ? fs::path() : fs::canonical(found, error);
}

}  // namespace

double heaptrackBytes(const std::string& size) {
  char* end = nullptr;
  const double value = std::strtod(size.c_str(), &end);
  if (end == nullptr || *end == '\0' || *end == 'B') return value;
  switch (*end) {
    case 'K':
      return value * 1e3;
    case 'M':
      return value * 1e6;
    case 'G':
      return value * 1e9;
    case 'T':
      return value * 1e12;
    default:
      return value;
  }
}

HeapGrowth parseHeaptrackGrowth(const std::string& printed, size_t most) {
  // A site opens with "SIZE leaked over N calls from" and its allocating
  // frame on the next lines; "SIZE leaked over N calls from:" then lists a
  // backtrace that reaches it, callers indented. Either way frames are a
  // function line, then "at FILE:LINE" and "in LIBRARY".
  static const std::regex kSite(R"(^(-?[0-9.]+[BKMGT]?) leaked over (-?[0-9]+) calls from(:?)$)");
  static const std::regex kTotal(R"(total memory leaked: (-?[0-9.]+[BKMGT]?))");
  HeapGrowth growth;
  std::smatch match;
  if (std::regex_search(printed, match, kTotal)) growth.total_bytes = heaptrackBytes(match[1]);
  std::vector<HeapGrowthSite> sites;
  std::vector<std::pair<std::string, std::string>> frames;  // of the current site
  bool in_leaks = false;
  auto close = [&] {
    if (sites.empty() || frames.empty()) return;
    const auto asking = std::find_if(frames.begin(), frames.end(),
                                     [](const auto& f) { return !allocatorFrame(f.first); });
    const auto& chosen = asking != frames.end() ? *asking : frames.front();
    sites.back().function = chosen.first;
    sites.back().location = chosen.second;
    frames.clear();
  };
  std::stringstream lines(printed);
  for (std::string line; std::getline(lines, line);) {
    if (line == "MEMORY LEAKS") {
      in_leaks = true;
      continue;
    }
    if (!in_leaks) continue;
    if (line.rfind("total ", 0) == 0) break;
    const std::string text = trimmed(line);
    if (std::regex_match(text, match, kSite)) {
      if (match[3].length() == 0) {  // a new site; a ':' continues this one
        close();
        HeapGrowthSite site;
        site.bytes = heaptrackBytes(match[1]);
        site.calls = static_cast<uint64_t>(std::max(0LL, std::stoll(match[2])));
        sites.push_back(site);
      }
      continue;
    }
    if (text.empty() || sites.empty()) continue;
    if (text.rfind("at ", 0) == 0) {
      if (!frames.empty() && frames.back().second.empty()) frames.back().second = text.substr(3);
    } else if (text.rfind("in ", 0) != 0) {
      frames.emplace_back(text, "");
    }
  }
  close();
  sites.erase(std::remove_if(sites.begin(), sites.end(),
                             [](const HeapGrowthSite& s) { return s.bytes <= 0; }),
              sites.end());
  std::stable_sort(
      sites.begin(), sites.end(),
      [](const HeapGrowthSite& a, const HeapGrowthSite& b) { return a.bytes > b.bytes; });
  if (sites.size() > most) sites.resize(most);
  growth.sites = std::move(sites);
  return growth;
}

StatusOr<HeapProfile> HeapProfile::find(const std::string& folder) {
  const fs::path launcher = inPath("heaptrack"), printer = inPath("heaptrack_print");
  const fs::path env = inPath("env");
  const fs::path lib =
      launcher.empty() ? fs::path() : launcher.parent_path() / ".." / "lib" / "heaptrack";
  HeapProfile profile;
  profile.folder_ = folder;
  profile.printer_ = printer.string();
  profile.env_ = env.empty() ? "/usr/bin/env" : env.string();
  profile.preload_ = (lib / "libheaptrack_preload.so").string();
  profile.interpreter_ = (lib / "libexec" / "heaptrack_interpret").string();
  std::error_code error;
  if (launcher.empty() || printer.empty() || !fs::is_regular_file(profile.preload_, error) ||
      !fs::is_regular_file(profile.interpreter_, error)) {
    return Status(StatusCode::kIoError,
                  "--profile needs heaptrack (its preload library, heaptrack_interpret and "
                  "heaptrack_print): apt-get install heaptrack");
  }
  fs::create_directories(folder, error);
  if (error)
    return Status(StatusCode::kIoError, "cannot create " + folder + ": " + error.message());
  fs::remove(profile.tracePath(), error);
  return profile;
}

std::vector<std::string> HeapProfile::wrap(const std::vector<std::string>& command) const {
  std::vector<std::string> wrapped = {env_, "LD_PRELOAD=" + preload_,
                                      "DUMP_HEAPTRACK_OUTPUT=" + tracePath()};
  wrapped.insert(wrapped.end(), command.begin(), command.end());
  return wrapped;
}

Status HeapProfile::mark(const std::string& name) const {
  std::error_code error;
  const std::string copy = folder_ + "/server-" + name + ".raw";
  fs::copy_file(tracePath(), copy, fs::copy_options::overwrite_existing, error);
  if (error) {
    return Status(StatusCode::kIoError,
                  "cannot copy the heap trace " + tracePath() + ": " + error.message());
  }
  return Status::ok();
}

StatusOr<HeapGrowth> HeapProfile::growth(const std::string& from, const std::string& to) const {
  constexpr int kHourMs = 3600 * 1000;
  for (const std::string& name : {from, to}) {
    const std::string raw = folder_ + "/server-" + name + ".raw";
    const std::string interpreted = folder_ + "/server-" + name + ".gz";
    // The trace read as heaptrack's own launcher reads it, and compressed.
    const FinishedProcess done = runToEnd(
        {"/bin/sh", "-c", "\"$0\" < \"$1\" | gzip -1 -c > \"$2\"", interpreter_, raw, interpreted},
        kHourMs);
    if (done.exit_code != 0) {
      return Status(StatusCode::kIoError, "heaptrack_interpret could not read " + raw + " (exit " +
                                              std::to_string(done.exit_code) + "): " + done.errors);
    }
    std::error_code error;
    fs::remove(raw, error);
  }
  // The live trace has been read into both marks; it may be gigabytes.
  std::error_code error;
  fs::remove(tracePath(), error);
  const FinishedProcess printed =
      runToEnd({printer_, "--file", folder_ + "/server-" + to + ".gz", "--diff",
                folder_ + "/server-" + from + ".gz", "--print-leaks", "1", "--print-peaks", "0",
                "--print-allocators", "0", "--print-temporary", "0", "--peak-limit", "10",
                "--sub-peak-limit", "1"},
               kHourMs);
  if (printed.exit_code != 0) {
    return Status(StatusCode::kIoError, "heaptrack_print failed (exit " +
                                            std::to_string(printed.exit_code) +
                                            "): " + printed.errors);
  }
  HeapGrowth growth = parseHeaptrackGrowth(printed.output);
  growth.account = folder_ + "/server-growth.txt";
  std::ofstream(growth.account) << printed.output;
  return growth;
}

}  // namespace holofuse::deploy

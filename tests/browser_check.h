// Opens a report page in a real browser, headless Chromium (Debian's
// chromium): the page's own check counts the charts whose marks were laid
// out where their values say, and the count is read back from the DOM.
#pragma once

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <regex>
#include <string>
#include <system_error>

namespace holofuse::test {

inline std::string chromium() {
  for (const char* candidate : {"/usr/bin/chromium", "/usr/bin/chromium-browser"}) {
    if (std::filesystem::exists(candidate)) return candidate;
  }
  return "";
}

// The charts the browser rendered, or -1 when the page did not load.
// A browser that stalls is stopped after a minute; each run has a
// profile folder of its own, so tests running side by side do not share one.
inline int chartsRendered(const std::filesystem::path& page) {
  char profile[] = "/tmp/holofuse_chromium_XXXXXX";
  if (mkdtemp(profile) == nullptr) return -1;
  const std::string command =
      // Not under the sanitizer a sanitized test run preloads: the browser is
      // not ours.
      "env -u LD_PRELOAD timeout 60 " + chromium() +
      " --headless --no-sandbox --disable-gpu --no-first-run --disable-background-networking "
      "--user-data-dir=" +
      std::string(profile) + " --dump-dom 'file://" + std::filesystem::absolute(page).string() +
      "' 2>/dev/null";
  std::string dom;
  int status = -1;
  if (FILE* pipe = popen(command.c_str(), "r")) {
    std::array<char, 4096> buffer{};
    while (size_t n = fread(buffer.data(), 1, buffer.size(), pipe)) dom.append(buffer.data(), n);
    status = pclose(pipe);
  }
  std::error_code ignored;
  std::filesystem::remove_all(profile, ignored);
  if (status != 0) return -1;
  std::smatch match;
  if (!std::regex_search(dom, match, std::regex("data-charts-rendered=\"([0-9]+)\""))) return -1;
  return std::stoi(match[1]);
}

}  // namespace holofuse::test

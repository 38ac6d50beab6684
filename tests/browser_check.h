// Opens a report page in a real browser, headless Chromium (Debian's
// chromium): the page's own check counts the charts whose marks were laid
// out where their values say, and the count is read back from the DOM.
#pragma once

#include <array>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <regex>
#include <string>

namespace holofuse::test {

inline std::string chromium() {
  for (const char* candidate : {"/usr/bin/chromium", "/usr/bin/chromium-browser"}) {
    if (std::filesystem::exists(candidate)) return candidate;
  }
  return "";
}

// The charts the browser rendered, or -1 when the page did not load.
inline int chartsRendered(const std::filesystem::path& page) {
  const std::string command = chromium() + " --headless --no-sandbox --disable-gpu --dump-dom 'file://" +
                              std::filesystem::absolute(page).string() + "' 2>/dev/null";
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(command.c_str(), "r"), pclose);
  if (!pipe) return -1;
  std::string dom;
  std::array<char, 4096> buffer{};
  while (size_t n = fread(buffer.data(), 1, buffer.size(), pipe.get())) dom.append(buffer.data(), n);
  std::smatch match;
  if (!std::regex_search(dom, match, std::regex("data-charts-rendered=\"([0-9]+)\""))) return -1;
  return std::stoi(match[1]);
}

}  // namespace holofuse::test

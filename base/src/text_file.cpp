#include "base/text_file.h"

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace holofuse {

Status writeTextFile(const std::string& path, std::string_view text) {
  const std::string partial = path + ".partial";
  auto failed = [&](const char* doing) {
    const std::string why = std::strerror(errno);
    std::remove(partial.c_str());
    return Status(StatusCode::kIoError, path + ": cannot " + doing + ": " + why);
  };
  std::FILE* file = std::fopen(partial.c_str(), "wb");
  if (file == nullptr) return failed("create it");
  const bool written = std::fwrite(text.data(), 1, text.size(), file) == text.size();
  const bool closed = std::fclose(file) == 0;
  if (!written || !closed) return failed("write it");
  if (std::rename(partial.c_str(), path.c_str()) != 0) return failed("rename it into place");
  return Status::ok();
}

}  // namespace holofuse

// Writing a report or table file whole: into a temporary beside it, then
// renamed over it, so a reader never sees half a file and a failed write
// leaves the old one in place.
#pragma once

#include <string>
#include <string_view>

#include "base/status.h"

namespace holofuse {

// An error names the path and what the system said (a full disk, a
// missing folder, no permission).
Status writeTextFile(const std::string& path, std::string_view text);

}  // namespace holofuse

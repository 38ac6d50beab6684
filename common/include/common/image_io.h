// PNG files of Image8 (grey, RGB or RGBA), for outputs people look at and
// tools other than ours read.
#pragma once

#include <string>

#include "base/status.h"
#include "common/image.h"

namespace holofuse {

// Fails with a message naming the path when the file cannot be written.
Status writePng(const std::string& path, const Image8& image);

}  // namespace holofuse

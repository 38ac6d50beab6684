// PNG files of Image8 (grey, RGB or RGBA), for outputs people look at and
// tools other than ours read.
#pragma once

#include <string>

#include "base/status.h"
#include "common/image.h"

namespace holofuse {

// Fails with a message naming the path when the file cannot be written.
Status writePng(const std::string& path, const Image8& image);

// An 8-bit PNG as writePng wrote it (grey, RGB or RGBA, in that order of
// channels); an error names the path and what is wrong with the file.
StatusOr<Image8> readPng(const std::string& path);

}  // namespace holofuse

// Command-line parsing shared by every executable: a wrong flag or value
// prints what is wrong and how to get the usage, and exits 2 (CLI11's own
// exit codes are 100 and up); --help prints the usage and exits 0.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "common/image_codec.h"

#define HOLOFUSE_PARSE_FLAGS(app, argc, argv) \
  try {                                       \
    (app).parse((argc), (argv));              \
  } catch (const CLI::ParseError& e) {        \
    return (app).exit(e) == 0 ? 0 : 2;        \
  }

namespace holofuse {

// The processes of the live loop a launcher flag is passed on to.
enum LoopProcess : unsigned { kToServer = 1, kToPods = 2, kToClient = 4 };

// A flag of a process that the live-loop launcher, eval or the sweep also
// take: its name, help and values, defined once, so that the launcher and
// the sweep's knobs refuse exactly what that process would, and whom the
// launcher passes it to, under the same name (the pods' own name where it
// differs).
struct SharedFlag {
  const char* flag;
  const char* description;
  double min = 0, max = 0;           // a number in [min, max], unless choices are given
  std::vector<std::string> choices;  // or one of these
  unsigned passed_to = 0;            // LoopProcess bits; 0: not a launcher flag
  const char* pods_name = nullptr;   // the pods' name for it, if not flag

  CLI::Validator check() const {
    return choices.empty() ? CLI::Validator(CLI::Range(min, max))
                           : CLI::Validator(CLI::IsMember(choices));
  }
};

inline const std::vector<SharedFlag>& sharedFlags() {
  static const std::vector<SharedFlag> flags = {
      // fusion_server
      {"--voxel", "hull voxel size in metres", 0.0001, 0.5, {}, kToServer},
      {"--hull-error-mm",
       "hull error target in mm of silhouette error: the coarsest voxel from --voxel down that "
       "meets it (the server follows it frame by frame; eval picks it per scene on the first "
       "frame; 0: the voxel "
       "is fixed)",
       0,
       1000,
       {}},
      {"--refine-voxels",
       "photo-consistency refinement: hull voxels the hull's vertices may move inward where the "
       "pods that see them disagree in colour (0: none)",
       0,
       64,
       {},
       kToServer},
      {"--draco-bits", "Draco position quantisation bits", 4, 24, {}, kToServer},
      {"--image-codec", "colour codec of the images sent on", 0, 0, imageCodecNames(),
       kToServer | kToPods, "--codec"},
      // capture_node (and fusion_server for the LZ4 settings)
      {"--codec", "colour codec", 0, 0, imageCodecNames()},
      // (the launcher passes it on itself: to the pods and to the client's truth)
      {"--noise", "synthetic pods' sensor noise, grey levels (default: the scene's)", 0, 64, {}},
      {"--crop-margin",
       "send only the foreground's rectangle grown by this many pixels (-1: whole images)",
       -1,
       4096,
       {},
       kToPods},
      {"--lz4-acceleration",
       "LZ4 acceleration (1 = default; higher: faster, larger)",
       1,
       65537,
       {},
       kToServer | kToPods},
      {"--lz4-hc-level",
       "LZ4HC level: 0 = LZ4's fast mode (at --lz4-acceleration), 1-12 slower and smaller",
       0,
       kMaxLz4HcLevel,
       {},
       kToServer | kToPods},
      // render_client
      {"--alpha",
       "exponent of the normal weight max(0, n . d_i) (normal, holoportation, fragment, "
       "montage4d's fallback)",
       0,
       1000,
       {},
       kToClient},
      {"--lambda", "montage4d: temporal rate per frame at 30 fps (eq. 5)", 0, 1, {}, kToClient},
      {"--dilation",
       "eps: depth discontinuities dilated by this many pixels (-1: paper's 4 px at 2048 wide, "
       "scaled)",
       -1,
       64,
       {},
       kToClient},
      {"--vote-delta",
       "majority vote: Lab distance / 100 under which two views agree (eq. 3; 0: no vote, the "
       "default; paper 000: 0.15)",
       0,
       10,
       {},
       kToClient},
      {"--geodesic-rings",
       "montage4d: k, the geodesic reach in triangle rings",
       1,
       64,
       {},
       kToClient},
      {"--geodesic-passes", "montage4d: K, the geodesic Jacobi passes", 1, 200, {}, kToClient},
      {"--geodesic-radius",
       "montage4d: metres from a seam where gamma reaches 1 (0: k mean edge lengths)",
       0,
       1000,
       {},
       kToClient},
      {"--vertex-precision",
       "vertex positions and normals on the GPU: fp32, or fp16 in half the memory",
       0,
       0,
       {"fp32", "fp16"},
       kToClient},
      {"--beta",
       "exponent of the view weight: (d_k . d_v + 1) in fragment (paper 004 eq. 4), max(0, v . "
       "v_i) in montage4d (paper 000 eq. 4)",
       0,
       1000,
       {},
       kToClient},
      {"--feather-width",
       "pixels over which a pod's weight ramps from its silhouette's edge to 1 (paper 004's "
       "feather weight; 0: none)",
       0,
       1000,
       {},
       kToClient},
      {"--fragment-test",
       "holoportation and montage4d: also test each fragment against every pod's depth map and "
       "mask and feather it (paper 004), on or off",
       0,
       0,
       {"on", "off"},
       kToClient},
  };
  return flags;
}

// An image size "WxH" with each side in 16..max_side: "" and width and
// height set, or what is wrong with the text.
inline std::string parseImageSize(const std::string& text, unsigned& width, unsigned& height,
                                  unsigned max_side = 4096) {
  unsigned w = 0, h = 0;
  char tail = 0;
  if (std::sscanf(text.c_str(), "%ux%u%c", &w, &h, &tail) != 2 || w < 16 || h < 16 ||
      w > max_side || h > max_side) {
    return "'" + text + "' is not WxH with each side in 16.." + std::to_string(max_side);
  }
  width = w;
  height = h;
  return "";
}

// The render client's user camera: "orbit", or "pod:N" to sit at pod N.
inline bool isViewName(const std::string& view) {
  return view == "orbit" || (view.rfind("pod:", 0) == 0 && view.size() > 4 &&
                             view.find_first_not_of("0123456789", 4) == std::string::npos);
}

inline const SharedFlag& sharedFlag(std::string_view flag) {
  for (const SharedFlag& f : sharedFlags()) {
    if (flag == f.flag) return f;
  }
  throw std::logic_error("no shared flag " + std::string(flag));
}

// Adds a shared flag bound to value, with its help and range.
template <typename T>
CLI::Option* addSharedFlag(CLI::App& app, std::string_view flag, T& value) {
  const SharedFlag& f = sharedFlag(flag);
  return app.add_option(f.flag, value, f.description)->check(f.check());
}

}  // namespace holofuse

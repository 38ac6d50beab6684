// The viewer's live panel (render_client --window on, P toggles it): the
// loop's figures over its last frames, drawn over the picture the window
// shows (never over the frames written or judged).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "image/image.h"
#include "report/latency_report.h"

namespace holofuse::render {

struct PanelFigures {
  std::string title;                                // the mode, and the overlay if any
  size_t frames = 0;                                // in the window the figures cover
  double fps = 0;                                   // rendered frames per second over them
  double end_to_end_ms = 0, end_to_end_p50_ms = 0;  // the latest frame's, their median
  double link_mbit_s = 0;  // what the server sent for them (images and mesh), per second
  // The latest frame's end to end by stage (report::timeByStage), in
  // pipeline order with the stages that took no time left out, "waiting"
  // last; slot: the stage's place in the pipeline order (its colour).
  struct Stage {
    std::string name;
    double ms = 0;
    size_t slot = 0;
  };
  std::vector<Stage> stages;
};

// The figures over the last `window` frames of `frames` (recorded in order).
PanelFigures panelFigures(const std::vector<report::FrameRecord>& frames, size_t window,
                          const std::string& title);

// The panel drawn into the picture's top-left corner: a line of figures,
// then the latest frame's stages as one bar with a key of the larger ones
// (3% or more; no key on a picture under 200 rows). Nothing without
// frames.
void drawPanel(Image8& picture, const PanelFigures& figures);

// The window's fade from one mode's picture to the next's (the M key): t
// from 0 (all `from`) to 1 (all `to`), per channel, rounded; `to` where
// the two differ in size.
Image8 crossFade(const Image8& from, const Image8& to, double t);

}  // namespace holofuse::render

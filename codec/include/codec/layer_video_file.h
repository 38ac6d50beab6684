// Texture layers' video as files a player opens (libavformat): each layer's
// stream, as the client received it, muxed without coding it again,
// MPEG-TS for H.264 and HEVC (their Annex B as sent), IVF for AV1 (its
// OBUs). ffprobe and any player read them; `render_client --record-layers`
// writes them.
#pragma once
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "base/status.h"
#include "protocol/messages.h"

namespace holofuse {

class LayerVideoRecorder {
 public:
  // Files go into dir (made if missing): layer<L>_part<N>.ts or .ivf.
  explicit LayerVideoRecorder(std::string dir);
  ~LayerVideoRecorder();
  LayerVideoRecorder(const LayerVideoRecorder&) = delete;
  LayerVideoRecorder& operator=(const LayerVideoRecorder&) = delete;

  // Layer `layer`'s next plane, received at received_ms (the file's clock:
  // a player plays the layers at the pace they came). A file starts at a key
  // frame: planes before the stream's first are not written. A plane of
  // another size or codec than the file's, or one after a gap in the
  // stream, starts the layer's next part at its next key frame.
  Status add(size_t layer, const protocol::Plane& plane, double received_ms);
  // Writes every file's trailer; the files written so far.
  StatusOr<std::vector<std::string>> finish();

 private:
  struct File;
  std::string dir_;
  std::map<size_t, std::unique_ptr<File>> files_;  // the open part per layer
  std::map<size_t, uint32_t> parts_;               // parts begun per layer
  std::vector<std::string> written_;
};

}  // namespace holofuse

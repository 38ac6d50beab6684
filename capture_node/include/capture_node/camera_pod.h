// A pod on a real camera: frames from anything OpenCV's VideoCapture opens
// (a V4L2 device, an RTSP or HTTP stream, a video file paced in real time),
// undistorted with the camera's calibration, segmented against its plate
// with the same background model the import uses, and streamed to the
// fusion server like a synthetic pod's.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "codec/pod_frame_codec.h"
#include "protocol/messages.h"
#include "protocol/socket.h"

namespace holofuse::capture {

struct CameraPodOptions {
  protocol::Endpoint server;
  uint32_t pod_id = 0;
  // "/dev/video0" or a device index ("0"), "rtsp://...", "http://...", or
  // a video file.
  std::string source;
  // The rig's calibration: a capture folder in any format the import
  // reads, and this camera's name in it (empty: the camera numbered
  // pod_id, in natural name order).
  std::string calibration;
  std::string calibration_format = "holofuse";
  std::string camera;
  // The empty room: a picture or a plate video; empty: the camera's
  // background in the calibration, else plate_frames of the source.
  std::string plate;
  // Learn the plate from this many frames of the source (the room empty):
  // at start, or, with plate_on_key, each time a line arrives on standard
  // input (Enter), streaming nothing until the first is learnt.
  int plate_frames = 0;
  bool plate_on_key = false;
  // The rig's frame rate (frame ids on its wall-clock grid); 0: the
  // source's own, else 15.
  double fps = 0;
  bool loop = false;    // a video file starts over at its end
  uint64_t frames = 0;  // stop after this many frames sent; 0: until signalled or the file ends
  PodEncoding encoding;
  std::vector<uint8_t> key;  // authenticates pod pod_id (protocol/auth.h); empty: none
  uint8_t max_minor = protocol::kVersionMinor;
};

// Returns the process exit code: 0 when stopped or the file ended, 2 when
// the calibration, the plate or the source is unusable (named on stderr).
int runCameraPod(const CameraPodOptions& options);

}  // namespace holofuse::capture

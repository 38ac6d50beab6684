#!/usr/bin/env python3
"""An RTSP server on loopback for the camera pod's tests.

Serves a live test picture (GStreamer's videotestsrc, a moving ball) as
Motion-JPEG over RTP at rtsp://127.0.0.1:PORT/NAME, WIDTHxHEIGHT at FPS,
through GStreamer's RTSP server (Debian: gir1.2-gst-rtsp-server-1.0,
gstreamer1.0-plugins-good). Prints "serving URL" once it listens.

    rtsp_server.py PORT NAME WIDTH HEIGHT FPS
"""
import sys

import gi

gi.require_version("Gst", "1.0")
gi.require_version("GstRtspServer", "1.0")
from gi.repository import GLib, Gst, GstRtspServer  # noqa: E402


def main():
    port, name, width, height, fps = sys.argv[1:6]
    Gst.init(None)
    server = GstRtspServer.RTSPServer()
    server.set_address("127.0.0.1")
    server.set_service(port)
    factory = GstRtspServer.RTSPMediaFactory()
    factory.set_launch(
        "( videotestsrc is-live=true pattern=ball ! "
        f"video/x-raw,format=I420,width={width},height={height},framerate={fps}/1 ! "
        "jpegenc quality=90 ! rtpjpegpay name=pay0 pt=26 )")
    factory.set_shared(True)
    server.get_mount_points().add_factory("/" + name, factory)
    if server.attach(None) == 0:
        sys.exit(f"cannot listen on 127.0.0.1:{port}")
    print(f"serving rtsp://127.0.0.1:{port}/{name}", flush=True)
    GLib.MainLoop().run()


if __name__ == "__main__":
    main()

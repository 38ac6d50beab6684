#include "codec/layer_video_file.h"

#include <algorithm>
#include <filesystem>
#include <optional>

#include "codec/layer_video.h"
#include "ffmpeg_codecs.h"

extern "C" {
#include <libavformat/avformat.h>
}

namespace holofuse {
using ffmpeg::avError;

// One part of one layer's stream: a muxer writing one file.
struct LayerVideoRecorder::File {
  std::string path;
  protocol::Codec codec = protocol::Codec::kRaw;
  uint32_t width = 0, height = 0;
  uint32_t last_sequence = 0;
  int64_t last_pts = -1;
  double first_ms = 0;
  AVFormatContext* format = nullptr;
  AVStream* stream = nullptr;
  bool header_written = false;

  ~File() {
    if (format == nullptr) return;
    if (format->pb != nullptr) avio_closep(&format->pb);
    avformat_free_context(format);
  }

  Status open(const std::string& file_path, const protocol::Plane& plane, double received_ms) {
    path = file_path;
    codec = plane.codec;
    width = plane.width;
    height = plane.height;
    first_ms = received_ms;
    const char* muxer = codec == protocol::Codec::kAv1 ? "ivf" : "mpegts";
    int code = avformat_alloc_output_context2(&format, nullptr, muxer, path.c_str());
    if (code < 0 || format == nullptr)
      return Status(StatusCode::kIoError, path + ": no " + muxer + " muxer: " + avError(code));
    stream = avformat_new_stream(format, nullptr);
    if (stream == nullptr) return Status(StatusCode::kIoError, path + ": cannot add its stream");
    stream->codecpar->codec_type = AVMEDIA_TYPE_VIDEO;
    stream->codecpar->codec_id = ffmpeg::infoOf(codec)->id;
    stream->codecpar->width = static_cast<int>(width);
    stream->codecpar->height = static_cast<int>(height);
    stream->time_base = AVRational{1, 1000};
    if ((code = avio_open(&format->pb, path.c_str(), AVIO_FLAG_WRITE)) < 0)
      return Status(StatusCode::kIoError, path + ": " + avError(code));
    if ((code = avformat_write_header(format, nullptr)) < 0)
      return Status(StatusCode::kIoError, path + ": cannot write its header: " + avError(code));
    header_written = true;
    return Status::ok();
  }

  Status write(const LayerVideoPacket& packet, double received_ms) {
    AVPacket* out = av_packet_alloc();
    if (out == nullptr) return Status(StatusCode::kIoError, path + ": out of memory");
    // Milliseconds since the part began, strictly rising.
    const int64_t pts =
        std::max<int64_t>(last_pts + 1, static_cast<int64_t>(received_ms - first_ms));
    last_pts = pts;
    out->data = const_cast<uint8_t*>(packet.bitstream.data());
    out->size = static_cast<int>(packet.bitstream.size());
    out->pts = out->dts = av_rescale_q(pts, AVRational{1, 1000}, stream->time_base);
    out->stream_index = stream->index;
    if (packet.key_frame) out->flags |= AV_PKT_FLAG_KEY;
    const int code = av_write_frame(format, out);
    av_packet_free(&out);
    if (code < 0) return Status(StatusCode::kIoError, path + ": " + avError(code));
    last_sequence = packet.sequence;
    return Status::ok();
  }

  Status finish() {
    if (!header_written) return Status::ok();
    header_written = false;
    const int code = av_write_trailer(format);
    if (code < 0) return Status(StatusCode::kIoError, path + ": " + avError(code));
    return Status::ok();
  }
};

LayerVideoRecorder::LayerVideoRecorder(std::string dir) : dir_(std::move(dir)) {}

LayerVideoRecorder::~LayerVideoRecorder() { (void)finish(); }

Status LayerVideoRecorder::add(size_t layer, const protocol::Plane& plane, double received_ms) {
  HOLOFUSE_ASSIGN_OR_RETURN(const LayerVideoPacket packet, layerVideoPacket(plane));
  auto open = files_.find(layer);
  if (open != files_.end()) {
    const File& file = *open->second;
    const bool same = file.codec == plane.codec && file.width == plane.width &&
                      file.height == plane.height && packet.sequence == file.last_sequence + 1;
    if (same) return open->second->write(packet, received_ms);
    // A new size, codec, or a frame missed: this part ends here.
    const Status ended = open->second->finish();
    files_.erase(open);
    HOLOFUSE_RETURN_IF_ERROR(ended);
  }
  if (!packet.key_frame) return Status::ok();  // the next part starts at a key frame
  std::error_code error;
  std::filesystem::create_directories(dir_, error);
  if (error) return Status(StatusCode::kIoError, dir_ + ": " + error.message());
  const uint32_t part = parts_[layer]++;
  const std::string path = (std::filesystem::path(dir_) /
                            ("layer" + std::to_string(layer) + "_part" + std::to_string(part) +
                             (plane.codec == protocol::Codec::kAv1 ? ".ivf" : ".ts")))
                               .string();
  auto file = std::make_unique<File>();
  HOLOFUSE_RETURN_IF_ERROR(file->open(path, plane, received_ms));
  written_.push_back(path);
  HOLOFUSE_RETURN_IF_ERROR(file->write(packet, received_ms));
  files_[layer] = std::move(file);
  return Status::ok();
}

StatusOr<std::vector<std::string>> LayerVideoRecorder::finish() {
  Status first = Status::ok();
  for (auto& [layer, file] : files_) {
    const Status ended = file->finish();
    if (first.isOk() && !ended.isOk()) first = ended;
  }
  files_.clear();
  if (!first.isOk()) return first;
  return written_;
}

}  // namespace holofuse

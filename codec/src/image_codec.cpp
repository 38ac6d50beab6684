#include "codec/image_codec.h"

#include <lz4.h>
#include <lz4hc.h>
#include <zstd.h>

#include <algorithm>
#include <stdexcept>
#include <string>

namespace holofuse {

using protocol::Codec;
using protocol::PixelFormat;

namespace {

PixelFormat formatFor(uint32_t channels) {
  return channels == 3 ? PixelFormat::kRgb8 : PixelFormat::kGray8;
}

// Interleaved to planar, each row replaced by its horizontal differences.
void planarDelta(const Image8& image, std::vector<uint8_t>& out) {
  out.resize(image.pixels.size());
  const size_t plane = static_cast<size_t>(image.width) * image.height;
  for (uint32_t c = 0; c < image.channels; ++c) {
    uint8_t* dst = out.data() + c * plane;
    for (uint32_t y = 0; y < image.height; ++y) {
      uint8_t prev = 0;
      for (uint32_t x = 0; x < image.width; ++x) {
        const uint8_t v = image.at(x, y)[c];
        *dst++ = static_cast<uint8_t>(v - prev);
        prev = v;
      }
    }
  }
}

void undoPlanarDelta(const std::vector<uint8_t>& in, Image8& image) {
  const size_t plane = static_cast<size_t>(image.width) * image.height;
  for (uint32_t c = 0; c < image.channels; ++c) {
    const uint8_t* src = in.data() + c * plane;
    for (uint32_t y = 0; y < image.height; ++y) {
      uint8_t prev = 0;
      for (uint32_t x = 0; x < image.width; ++x) {
        prev = static_cast<uint8_t>(prev + *src++);
        image.at(x, y)[c] = prev;
      }
    }
  }
}

void lz4Into(const uint8_t* src, size_t size, std::vector<uint8_t>& storage, int acceleration,
             int hc_level) {
  storage.resize(static_cast<size_t>(LZ4_compressBound(static_cast<int>(size))));
  const char* in = reinterpret_cast<const char*>(src);
  char* out = reinterpret_cast<char*>(storage.data());
  const int n = hc_level > 0 ? LZ4_compress_HC(in, out, static_cast<int>(size),
                                               static_cast<int>(storage.size()),
                                               std::min(hc_level, kMaxLz4HcLevel))
                             : LZ4_compress_fast(in, out, static_cast<int>(size),
                                                 static_cast<int>(storage.size()), acceleration);
  storage.resize(static_cast<size_t>(n));
}

}  // namespace

protocol::Plane encodePlane(const Image8& image, protocol::PlaneKind kind, Codec codec,
                            std::vector<uint8_t>& storage, int acceleration, int hc_level) {
  protocol::Plane plane;
  plane.kind = kind;
  plane.codec = codec;
  plane.format = formatFor(image.channels);
  plane.width = image.width;
  plane.height = image.height;
  plane.raw_size = static_cast<uint32_t>(image.pixels.size());
  switch (codec) {
    case Codec::kRaw:
      storage = image.pixels;
      break;
    case Codec::kLz4:
      lz4Into(image.pixels.data(), image.pixels.size(), storage, acceleration, hc_level);
      break;
    case Codec::kLz4PlanarDelta: {
      std::vector<uint8_t> filtered;
      planarDelta(image, filtered);
      lz4Into(filtered.data(), filtered.size(), storage, acceleration, hc_level);
      break;
    }
    case Codec::kZstd: {
      storage.resize(ZSTD_compressBound(image.pixels.size()));
      const size_t n = ZSTD_compress(storage.data(), storage.size(), image.pixels.data(),
                                     image.pixels.size(), kPlaneZstdLevel);
      // Only a bound too small fails, and the bound is Zstandard's own.
      if (ZSTD_isError(n)) throw std::logic_error(ZSTD_getErrorName(n));
      storage.resize(n);
      break;
    }
    case Codec::kH264:
    case Codec::kHevc:
    case Codec::kAv1:
      // A video frame depends on its stream's earlier frames.
      throw std::logic_error("encodePlane: video is coded by a LayerVideoEncoder");
  }
  plane.data = storage;
  return plane;
}

StatusOr<Image8> decodePlane(const protocol::Plane& plane) {
  const std::string which = "plane (kind " + std::to_string(static_cast<int>(plane.kind)) + ", " +
                            std::to_string(plane.width) + "x" + std::to_string(plane.height) + ")";
  uint32_t channels = 0;
  if (plane.format == PixelFormat::kRgb8) channels = 3;
  if (plane.format == PixelFormat::kGray8) channels = 1;
  if (channels == 0) return Status(StatusCode::kMalformed, which + ": unsupported pixel format");
  if (plane.width == 0 || plane.height == 0 || plane.width > protocol::kMaxImageSide ||
      plane.height > protocol::kMaxImageSide) {
    return Status(StatusCode::kMalformed,
                  which + ": size outside 1.." + std::to_string(protocol::kMaxImageSide));
  }
  const uint64_t expected = static_cast<uint64_t>(plane.width) * plane.height * channels;
  if (expected != plane.raw_size || expected > protocol::kMaxPlaneBytes || expected == 0) {
    return Status(StatusCode::kMalformed, which + ": raw size " + std::to_string(plane.raw_size) +
                                              " does not match the image size");
  }
  Image8 image(plane.width, plane.height, channels);
  switch (plane.codec) {
    case Codec::kRaw:
      if (plane.data.size() != expected) {
        return Status(StatusCode::kMalformed,
                      which + ": raw data has " + std::to_string(plane.data.size()) + " bytes");
      }
      std::copy(plane.data.begin(), plane.data.end(), image.pixels.begin());
      return image;
    case Codec::kLz4:
    case Codec::kLz4PlanarDelta: {
      std::vector<uint8_t> scratch;
      uint8_t* dst = image.pixels.data();
      if (plane.codec == Codec::kLz4PlanarDelta) {
        scratch.resize(expected);
        dst = scratch.data();
      }
      const int n = LZ4_decompress_safe(
          reinterpret_cast<const char*>(plane.data.data()), reinterpret_cast<char*>(dst),
          static_cast<int>(plane.data.size()), static_cast<int>(expected));
      if (n != static_cast<int>(expected)) {
        return Status(StatusCode::kMalformed,
                      which + ": LZ4 data is corrupt or decodes to " +
                          (n < 0 ? std::string("an error") : std::to_string(n) + " bytes") +
                          " instead of " + std::to_string(expected));
      }
      if (plane.codec == Codec::kLz4PlanarDelta) undoPlanarDelta(scratch, image);
      return image;
    }
    case Codec::kZstd: {
      // The frame states its size: checked before anything is written.
      const unsigned long long stated =
          ZSTD_getFrameContentSize(plane.data.data(), plane.data.size());
      if (stated != expected) {
        return Status(StatusCode::kMalformed,
                      which + ": its Zstandard frame states " +
                          (stated == ZSTD_CONTENTSIZE_UNKNOWN ? std::string("no size")
                           : stated == ZSTD_CONTENTSIZE_ERROR ? std::string("nothing readable")
                                                              : std::to_string(stated) + " bytes") +
                          " instead of " + std::to_string(expected));
      }
      const size_t n =
          ZSTD_decompress(image.pixels.data(), expected, plane.data.data(), plane.data.size());
      if (ZSTD_isError(n) || n != expected) {
        return Status(StatusCode::kMalformed,
                      which + ": Zstandard data is corrupt (" +
                          (ZSTD_isError(n) ? std::string(ZSTD_getErrorName(n))
                                           : std::to_string(n) + " bytes") +
                          ")");
      }
      return image;
    }
    case Codec::kH264:
    case Codec::kHevc:
    case Codec::kAv1:
      return Status(StatusCode::kMalformed,
                    which + ": a video frame decodes only in its stream (LayerVideoDecoder)");
  }
  return Status(StatusCode::kMalformed, which + ": unknown codec");
}

const std::vector<std::string>& imageCodecNames() {
  static const std::vector<std::string> names = {"raw", "lz4", "lz4-delta"};
  return names;
}

std::string imageCodecName(Codec codec) {
  switch (codec) {
    case Codec::kRaw:
      return "raw";
    case Codec::kLz4:
      return "lz4";
    case Codec::kLz4PlanarDelta:
      return "lz4-delta";
    case Codec::kH264:
      return "h264";
    case Codec::kHevc:
      return "hevc";
    case Codec::kAv1:
      return "av1";
    case Codec::kZstd:
      return "zstd";
  }
  return "unknown codec " + std::to_string(static_cast<int>(codec));
}

std::optional<Codec> imageCodecFromName(const std::string& name) {
  for (Codec codec : {Codec::kRaw, Codec::kLz4, Codec::kLz4PlanarDelta}) {
    if (imageCodecName(codec) == name) return codec;
  }
  return std::nullopt;
}

}  // namespace holofuse

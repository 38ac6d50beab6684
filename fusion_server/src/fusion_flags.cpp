#include "codec/image_codec.h"
#include "codec/layer_video.h"
#include "codec/mesh_codec.h"
#include "fusion_server/fusion_worker.h"

namespace holofuse::fusion {

const std::vector<Setting<FusionSettings>>& fusionFlags() {
  using S = FusionSettings;
  static const std::vector<Setting<S>> flags = [] {
    std::vector<Setting<S>> all = {
        numberSetting<S>("--voxel", "hull voxel size in metres", hull::kMinVoxel, hull::kMaxVoxel,
                         [](S& s) -> double& { return s.hull.voxel_size; }),
        numberSetting<S>(
            "--hull-error-mm",
            "hull error target in mm of silhouette error: the coarsest voxel from --voxel down "
            "that meets it (the server follows it frame by frame; eval picks it per scene on the "
            "first frame; 0: the voxel is fixed)",
            0, 1000, [](S& s) -> double& { return s.hull_error_target; }, 1000.0),
        numberSetting<S>("--fusion-threads",
                         "threads that fuse: groups fused at once, and the threads each group's "
                         "hull spreads over (0: the machine's cores; 1: one group at a time on "
                         "one thread)",
                         0, 256, [](S& s) -> int& { return s.threads; }),
        choiceSetting<S>(
            "--hull-device",
            "where the hull is carved: cpu, or vulkan (compute passes on the first GPU, else "
            "any Vulkan device; the CPU, with a log line, where none opens)",
            {"cpu", "vulkan"}, [](S& s, const std::string& name) { s.hull_device = name; },
            [](const S& s) { return s.hull_device; }),
        numberSetting<S>("--refine-voxels",
                         "photo-consistency refinement: hull voxels the hull's vertices may move "
                         "inward where the pods that see them disagree in colour (0: none)",
                         0, 64, [](S& s) -> double& { return s.refine.depth_voxels; }),
        numberSetting<S>("--draco-bits", "Draco position quantisation bits", 4, 24,
                         [](S& s) -> int& { return s.draco.position_bits; }),
        numberSetting<S>("--draco-speed", "Draco speed 0 (small) .. 10 (fast)", 0, 10,
                         [](S& s) -> int& { return s.draco.speed; }),
        choiceSetting<S>(
            "--mesh-codec",
            "meshes to clients of protocol 1.7: draco, or fp16-lz4 (half floats through LZ4, "
            "the open Holoportation stack's: a third of Draco's time for ten times its bytes); "
            "older clients get draco",
            meshCodecNames(),
            [](S& s, const std::string& name) {
              s.mesh_codec = meshCodecFromName(name).value_or(protocol::MeshCodec::kDraco);
            },
            [](const S& s) { return meshCodecName(s.mesh_codec); }),
        numberSetting<S>("--layers",
                         "texture layers L for the clients that ask for layers (mode layered)", 1,
                         static_cast<double>(protocol::kMaxLayers),
                         [](S& s) -> int& { return s.layers.layers; }),
        numberSetting<S>(
            "--atlas-size",
            "side of the layers' atlas in texels without charts (it doubles up to 4096 "
            "when the mesh needs more)",
            kMinAtlasTexels, 4096, [](S& s) -> uint32_t& { return s.layers.atlas_texels; }),
        numberSetting<S>("--chart-cells",
                         "layers' atlas: a chart per block of this many hull voxels a side and "
                         "facing axis (0: a square per pair of triangles)",
                         0, 16, [](S& s) -> uint32_t& { return s.layers.chart_cells; }),
        numberSetting<S>("--texels-per-voxel",
                         "layers' atlas with charts: texels a hull voxel spans (the layers' "
                         "resolution)",
                         0.25, 16, [](S& s) -> double& { return s.layers.texels_per_cell; }),
        numberSetting<S>("--layer-min-share",
                         "texture layers after the first hold a point only where their camera "
                         "sees it at least this share as squarely as the best camera (0: the L "
                         "best everywhere)",
                         0.0, 1.0, [](S& s) -> double& { return s.layers.min_score_share; }),
        numberSetting<S>("--layer-keep-share",
                         "a texture layer keeps the camera of the texel to its left or above it "
                         "where that camera sees the point at least this share as squarely as "
                         "the one ranked for the layer (fewer seams inside a chart; 1: the "
                         "ranking alone)",
                         0.0, 1.0, [](S& s) -> double& { return s.layers.keep_share; }),
        choiceSetting<S>(
            "--layer-video",
            "the layers' colour as video for the clients that decode it (protocol 1.6): "
            "h264, hevc or av1; off: LZ4 as the images",
            [] {
              std::vector<std::string> names = layerVideoCodecNames();
              names.push_back("off");
              return names;
            }(),
            [](S& s, const std::string& name) {
              s.layers.video.codec = layerVideoCodecFromName(name).value_or(protocol::Codec::kLz4);
            },
            [](const S& s) {
              return isVideoCodec(s.layers.video.codec) ? layerVideoCodecName(s.layers.video.codec)
                                                        : std::string("off");
            }),
        numberSetting<S>("--layer-video-crf",
                         "the layers' video quality: lower is better and larger (H.264 and HEVC "
                         "0-51, AV1 0-63)",
                         0, 63, [](S& s) -> int& { return s.layers.video.crf; }),
        numberSetting<S>("--layer-video-crf-step",
                         "added to --layer-video-crf for each texture layer after the first: "
                         "deeper layers, which the blend weighs less, at lower quality (0: "
                         "every layer alike)",
                         0, 63, [](S& s) -> int& { return s.layers.video_crf_step; }),
        numberSetting<S>("--layer-video-kbps",
                         "the layers' video by a target bitrate instead of --layer-video-crf: "
                         "kilobits a second for all layers together at 30 frames a second, "
                         "split by the texels each holds (0: constant quality)",
                         0, 1000000, [](S& s) -> int& { return s.layers.video.kbps; }),
        numberSetting<S>("--layer-video-key-interval",
                         "frames between the layers' video key frames at most", 1, 600,
                         [](S& s) -> int& { return s.layers.video.key_interval; }),
        onOffSetting<S>(
            "--layer-video-444",
            "the layers' video in 4:4:4 instead of 4:2:0 (colour kept at chart borders)",
            [](S& s) -> bool& { return s.layers.video.full_chroma; })};
    for (Setting<S>& setting :
         imageEncodingSettings<S>("--image-codec", "colour codec of the images sent on",
                                  [](S& s) -> protocol::Codec& { return s.image_codec; }))
      all.push_back(std::move(setting));
    return all;
  }();
  return flags;
}

}  // namespace holofuse::fusion

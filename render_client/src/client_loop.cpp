// The render client's loop: frames off the server link, decoded and checked,
// rendered, written, judged and stamped, then the report.
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <set>

#include "base/eta.h"
#include "base/shutdown.h"
#include "codec/layer_video.h"
#include "codec/layer_video_file.h"
#include "codec/mesh_codec.h"
#include "image/image_io.h"
#include "protocol/clock.h"
#include "protocol/server_link.h"
#include "render_client/client.h"
#include "render_client/frame_judge.h"
#include "render_client/live_panel.h"
#include "render_client/mask_health.h"
#include "render_client/picture_writer.h"
#include "render_client/viewer_window.h"
#include "report/latency_report.h"

namespace holofuse::render {

using protocol::kSourceClient;
using protocol::monotonicNs;
using protocol::Stage;

namespace {

namespace fs = std::filesystem;

struct PendingBundle {
  std::vector<ViewImages> views;
  std::optional<DecodedLayers> layers;  // in place of views, for mode layered
  std::vector<protocol::StageStamp> stamps;
  uint64_t bytes = 0;
  uint64_t feather_bytes = 0;  // of bytes, the feather maps' compressed planes
};

struct FrameStats {
  protocol::Stats stats;
  uint64_t bytes = 0;  // the Stats frame's own size
};

// The fan-out stage ends when the client receives the frame.
void endFanout(std::vector<protocol::StageStamp>& stamps, uint64_t receive_ns) {
  for (auto& stamp : stamps) {
    if (stamp.stage == static_cast<uint16_t>(Stage::kFanout) && stamp.end_ns == 0)
      stamp.end_ns = receive_ns;
  }
}

// --overlap-render: auto overlaps on a GPU only; a CPU device renders on
// the cores the next frame's decode would take.
bool overlapsRender(const ClientOptions& options, const VulkanContext& context) {
  return options.run.overlap_render == "on" ||
         (options.run.overlap_render == "auto" && !context.cpuDevice());
}

// A mesh with its bundle, decoded, checked and on the GPU, ready to render.
struct ReadyMesh {
  protocol::MeshFrame frame;
  std::map<uint64_t, PendingBundle>::iterator bundle;
  std::vector<protocol::StageStamp> stamps;
  Camera user;
  double decode_ms = 0;
  uint64_t wire_bytes = 0;  // the mesh's message
  size_t triangles = 0;
  // upload_start_ns: after the previous frame's render ended (a frame
  // decodes while the one before it renders).
  uint64_t decoded_ns = 0, upload_start_ns = 0, uploaded_ns = 0;
  // Of its bundle, kept past the bundle (dropped once it is on the GPU).
  uint64_t bundle_bytes = 0, feather_bytes = 0;
  uint32_t bundle_cameras = 0;
  uint64_t field_runs = 0;  // the renderer's field passes before this frame
};

class ClientLoop {
 public:
  ClientLoop(const ClientOptions& options, VulkanContext& context, Renderer& renderer,
             std::optional<FrameJudge> judge, const protocol::ClockSync& server_clock)
      : options_(options),
        server_clock_(server_clock),
        out_dir_(options.out_dir),
        context_(context),
        renderer_(renderer),
        judge_(std::move(judge)),
        tty_(isatty(STDOUT_FILENO)),
        overlap_(overlapsRender(options, context)) {
    view_ = options.run.view;
    if (!options.run.record_layers.empty()) layer_files_.emplace(options.run.record_layers);
    mode_ = options.render.blend.mode;
    overlay_ = options.render.blend.overlay;
    overlay_pod_ = options.render.blend.overlay_pod;
    stylisation_ = options.render.blend.stylisation;
    relight_ = options.render.blend.relight;
    // The judge reads each picture as soon as it is written: judged, the
    // pictures are written on the render path.
    if (options_.write_frames && !judge_) writer_.emplace();
    report_.setClockDriftWarnMs(options_.clock_drift_warn_ms);
  }

  // Every picture shown in `window` too (not owned; null: none).
  void setWindow(ViewerWindow* window) { window_ = window; }

  // What the window's user asked for: a view, a mode, a screenshot, a
  // hold on the orbit. Mode layered is in the cycle where the server
  // changes what it sends while the client runs (protocol 1.10:
  // `layers_switchable`); with an older one, a client started layered
  // stays layered, and the others leave it out.
  void takeWindowControls(bool layers_switchable) {
    if (window_ == nullptr) return;
    const ViewerWindow::Controls c = window_->takeControls();
    if (c.view_key >= 0) {
      const std::string view = c.view_key == 0 ? "orbit" : "pod:" + std::to_string(c.view_key - 1);
      if (view == "orbit" || cameras_.count(static_cast<uint32_t>(c.view_key - 1))) {
        view_ = view;
        hold_ = {};
        std::fprintf(stderr, "%s[client] view %s\n", tty_ ? "\n" : "", view_.c_str());
      }
    }
    static const BlendMode kCycle[] = {BlendMode::kNormal, BlendMode::kFragment,
                                       BlendMode::kHoloportation, BlendMode::kMontage4D,
                                       BlendMode::kLayered};
    const size_t modes = std::size(kCycle) - (layers_switchable ? 0 : 1);
    for (int step = 0; step < c.mode_steps; ++step) {
      if (mode_ == BlendMode::kLayered && !layers_switchable) break;
      size_t at = 0;
      while (at < modes && kCycle[at] != mode_) ++at;
      if (mode_ != BlendMode::kLayered) images_mode_ = mode_;
      mode_ = kCycle[(at + 1) % modes];
      // The window fades from the last picture of the mode before.
      fade_from_ = last_shown_;
      fade_start_ns_ = monotonicNs();
      std::fprintf(stderr, "%s[client] mode %s\n", tty_ ? "\n" : "", blendModeName(mode_).c_str());
    }
    screenshot_due_ = screenshot_due_ || c.screenshot;
    for (int step = 0; step < c.stylisation_steps; ++step) {
      const auto next = static_cast<size_t>(stylisation_) + 1;
      stylisation_ = static_cast<Stylisation>(next % stylisationNames().size());
      std::fprintf(stderr, "%s[client] stylisation: %s\n", tty_ ? "\n" : "",
                   stylisationName(stylisation_).c_str());
    }
    if (c.relight_toggles % 2 == 1) {
      if (options_.run.light_probe.empty()) {
        std::fprintf(stderr, "%s[client] no light probe to relight by (--light-probe FILE)\n",
                     tty_ ? "\n" : "");
      } else {
        relight_ = !relight_;
        std::fprintf(stderr, "%s[client] relighting %s\n", tty_ ? "\n" : "",
                     relight_ ? "on" : "off");
      }
    }
    if (c.panel_toggles % 2 == 1) {
      panel_ = !panel_;
      std::fprintf(stderr, "%s[client] live panel %s\n", tty_ ? "\n" : "", panel_ ? "on" : "off");
    }
    if (c.overlay_steps > 0 || c.overlay_pod_steps > 0) {
      overlay_ = static_cast<Overlay>(
          (static_cast<size_t>(overlay_) + static_cast<size_t>(c.overlay_steps)) % kOverlayCount);
      // The pods in turn, by id, among those the client has cameras of.
      for (int step = 0; step < c.overlay_pod_steps && !cameras_.empty(); ++step) {
        auto next = cameras_.upper_bound(overlay_pod_);
        overlay_pod_ = next == cameras_.end() ? cameras_.begin()->first : next->first;
      }
      const bool per_pod = overlay_ != Overlay::kNone && overlay_ != Overlay::kCameraColours;
      std::fprintf(stderr, "%s[client] overlay: %s%s\n", tty_ ? "\n" : "",
                   overlayName(overlay_).c_str(),
                   per_pod ? (" of pod " + std::to_string(overlay_pod_)).c_str() : "");
    }
    if (c.orbit.held && view_ == "orbit") {
      if (!hold_.held) {
        held_from_degrees_ =
            options_.orbit_degrees_per_frame * static_cast<double>(report_.framesRendered());
      }
      hold_ = c.orbit;
    }
  }

  // The frame in flight counts: it will be rendered.
  bool done() const {
    return options_.frames != 0 &&
           report_.framesRendered() + (in_flight_ ? 1 : 0) >= options_.frames;
  }

  // One poll's frames. When frames arrive faster than this client renders,
  // only the newest mesh of a batch is rendered: older ones would only add
  // latency.
  void receive(std::vector<protocol::Frame>& received) {
    size_t newest_mesh = received.size();
    for (size_t k = 0; k < received.size(); ++k) {
      if (typeOf(received[k]) == protocol::MessageType::kMeshFrame) newest_mesh = k;
    }
    for (size_t k = 0; k < received.size() && !done(); ++k) {
      // A render that has ended is taken at once, not after the next
      // frame's decode: its picture and its latency are ready now.
      if (in_flight_ && renderer_.renderDone()) finishFrame();
      const uint64_t receive_ns = now();
      switch (typeOf(received[k])) {
        case protocol::MessageType::kCalibration:
          onCalibration(received[k]);
          break;
        case protocol::MessageType::kStats:
          onStats(received[k]);
          break;
        case protocol::MessageType::kTextureBundle:
          onBundle(received[k], receive_ns);
          break;
        case protocol::MessageType::kMeshFrame:
          if (k != newest_mesh) {
            ++superseded_;
          } else if (auto ready = prepareMesh(received[k], receive_ns)) {
            beginFrame(std::move(*ready));
          }
          break;
        default:
          break;
      }
    }
  }

  void printProgress() {
    const uint64_t now = monotonicNs();
    if (now - last_progress_ns_ <= 1000000000ull || report_.framesRendered() == 0) return;
    last_progress_ns_ = now;
    const auto& last = report_.frames().back();
    // Of a known total (--frames, or a replay's --frames-expected): the
    // count against it and the time left at the pace so far.
    const std::string count =
        Eta::countOf(report_.framesRendered(),
                     options_.frames ? options_.frames : options_.frames_expected, report_.fps());
    std::printf("%sframes %s | %5.1f fps | end-to-end p50 %6.1f ms p95 %6.1f ms | cameras %u/%u%s",
                tty_ ? "\r" : "", count.c_str(), report_.fps(), report_.endToEndPercentile(50),
                report_.endToEndPercentile(95), last.cameras_present, last.cameras_expected,
                tty_ ? "   " : "\n");
    std::fflush(stdout);
  }

  void sayReplayOver() const {
    std::printf("%s[client] the server said goodbye: the replay is over\n", tty_ ? "\n" : "");
  }

  // report.json and report.html, and the summary line.
  void writeReport() {
    finishLayerFiles();
    report_.setSuperseded(superseded_);
    report_.settleEndToEnd(server_clock_);
    // This host's clock minus the server's: the estimate's sign turned.
    report::LatencyReport::HostClock own;
    own.host = "client";
    own.measured = server_clock_.known();
    if (own.measured) {
      own.offset_ms = -static_cast<double>(server_clock_.offsetNs()) / 1e6;
      own.uncertainty_ms = static_cast<double>(server_clock_.uncertaintyNs()) / 1e6;
      own.first_offset_ms = -static_cast<double>(server_clock_.firstOffsetNs()) / 1e6;
      own.first_uncertainty_ms = static_cast<double>(server_clock_.firstUncertaintyNs()) / 1e6;
      own.drifted =
          server_clock_.drifted(static_cast<uint64_t>(options_.clock_drift_warn_ms * 1e6));
    }
    report_.setClientClock(own);
    for (const std::string& warning : report_.clockWarnings())
      std::fprintf(stderr, "[client] warning: %s\n", warning.c_str());
    std::vector<uint32_t> health_ids;
    report_.setMaskHealth(mask_health_.summary(&health_ids), health_ids);
    for (size_t c = 0; c < report_.maskHealth().cameras.size(); ++c) {
      const std::string& concern = report_.maskHealth().cameras[c].concern;
      if (!concern.empty())
        std::fprintf(stderr, "[client] CHECK pod %u's mask: %s\n",
                     c < health_ids.size() ? health_ids[c] : static_cast<uint32_t>(c),
                     concern.c_str());
    }
    if (writer_) {
      writer_->flush();
      report_.setPicturesDropped(writer_->dropped());
    }
    // What the frames were rendered with, so that a report can be matched
    // with the sweep point it was meant to reproduce.
    std::map<std::string, std::string> settings = {
        {"mode", blendModeName(options_.render.blend.mode)},
        {"view", options_.run.view},
        {"size", std::to_string(options_.width) + "x" + std::to_string(options_.height)},
        {"device", context_.deviceName()}};
    // Every rendering setting under its flag's name ("--vote-delta": vote_delta).
    for (const Setting<RenderSettings>& setting : renderFlags()) {
      std::string name = setting.flag.substr(2);
      std::replace(name.begin(), name.end(), '-', '_');
      settings[name] = setting.get(options_.render);
    }
    const fs::path report_path = out_dir_ / "report.json";
    std::ofstream(report_path) << report_.toJson(settings, options_.budget);
    std::ofstream(out_dir_ / "report.html") << report_.toHtml(settings, options_.budget);
    std::string quality;
    for (const auto& q : report_.quality()) {
      char text[96];
      std::snprintf(text, sizeof(text), q.measure == "psnr_db" ? ", PSNR %.2f dB" : ", SSIM %.3f",
                    q.mean);
      quality += text;
    }
    if (!quality.empty()) quality += " against the truth (mean)";
    std::printf(
        "%s[client] %zu frames, %.1f fps, end-to-end p50 %.1f ms p95 %.1f ms p99 %.1f ms%s; "
        "report: %s\n",
        tty_ ? "\n" : "", report_.framesRendered(), report_.fps(), report_.endToEndPercentile(50),
        report_.endToEndPercentile(95), report_.endToEndPercentile(99), quality.c_str(),
        report_path.c_str());
  }

 private:
  // --record-layers: each layer's video plane into its file; a failure is
  // said once and ends the recording, never the client.
  void recordLayers(const protocol::BundleLayers& layers, uint64_t receive_ns) {
    if (!layer_files_) return;
    for (size_t l = 0; l < layers.layers.size(); ++l) {
      for (const protocol::Plane& plane : layers.layers[l]) {
        if (plane.kind != protocol::PlaneKind::kColor || !isVideoCodec(plane.codec)) continue;
        const Status added = layer_files_->add(l, plane, static_cast<double>(receive_ns) / 1e6);
        if (added.isOk()) continue;
        std::fprintf(stderr, "[client] --record-layers stops: %s\n", added.toString().c_str());
        finishLayerFiles();
        return;
      }
    }
  }

  void finishLayerFiles() {
    if (!layer_files_) return;
    const auto written = layer_files_->finish();
    layer_files_.reset();
    if (!written.isOk()) {
      std::fprintf(stderr, "[client] --record-layers: %s\n", written.status().toString().c_str());
      return;
    }
    std::fprintf(stderr, "[client] layers' video: %zu file(s) in %s%s\n", written->size(),
                 options_.run.record_layers.c_str(),
                 written->empty() ? " (no video layers came: --mode layered, and the server's "
                                    "--layer-video h264, hevc or av1)"
                                  : "");
  }

  static protocol::MessageType typeOf(const protocol::Frame& frame) {
    return static_cast<protocol::MessageType>(frame.header.type);
  }

  void skip(uint64_t frame_id, const std::string& why) {
    std::fprintf(stderr, "[client] frame %llu skipped, keeping the previous picture: %s\n",
                 static_cast<unsigned long long>(frame_id), why.c_str());
    report_.noteSkipped("frame " + std::to_string(frame_id) + ": " + why);
  }

  // The caps on a received mesh: the flags' when given, else what the
  // rig can produce. A visual hull has a vertex a voxel, and a voxel
  // smaller than a pixel's footprint adds nothing the cameras saw: its
  // vertices need not exceed the cameras' pixels (at least 2^18). A 200 KB
  // Draco mesh stating two million vertices from four 320x240 pods is then
  // refused before anything of that size exists.
  DracoLimits meshLimits() const {
    DracoLimits limits = options_.mesh_limits;
    if (options_.mesh_limits_given) return limits;
    // Floor: a hull carved finer than its cameras' pixels (a 1 cm voxel
    // over two 96x72 pods gives 117,000 vertices) is wasteful, not hostile.
    constexpr uint64_t kFewestVertices = 1u << 18;
    uint64_t pixels = 0;
    for (const auto& [id, camera] : cameras_) pixels += uint64_t{camera.width} * camera.height;
    const uint64_t vertices = std::max(kFewestVertices, pixels);
    limits.max_vertices = static_cast<uint32_t>(std::min<uint64_t>(limits.max_vertices, vertices));
    limits.max_faces = static_cast<uint32_t>(std::min<uint64_t>(limits.max_faces, 2 * vertices));
    return limits;
  }

  void onCalibration(const protocol::Frame& frame) {
    protocol::Calibration calibration;
    const auto s = protocol::decodeFrame(frame, calibration);
    if (!s.isOk()) {
      std::fprintf(stderr, "[client] bad Calibration ignored: %s\n", s.toString().c_str());
      return;
    }
    cameras_[calibration.camera_id] = fromCalibration(calibration);
  }

  void onStats(const protocol::Frame& frame) {
    protocol::Stats st;
    if (!protocol::decodeFrame(frame, st).isOk()) return;
    if (st.pod_arrivals) report_.setServerArrivals(*st.pod_arrivals);
    const uint64_t id = st.frame_id;
    stats_[id] = FrameStats{std::move(st), frame.bytes.size()};
    while (stats_.size() > 64) stats_.erase(stats_.begin());
  }

  void onBundle(const protocol::Frame& frame, uint64_t receive_ns) {
    protocol::TextureBundle bundle;
    const uint64_t t0 = now();
    auto s = protocol::decodeFrame(frame, bundle);
    if (!s.isOk()) {
      skip(0, "TextureBundle: " + s.toString());
      return;
    }
    PendingBundle pending;
    pending.bytes = frame.bytes.size();
    pending.feather_bytes = featherBytes(bundle);
    pending.stamps = bundle.stamps;
    endFanout(pending.stamps, receive_ns);
    auto views = viewsOfBundle(bundle, cameras_);
    // Mode layered renders from layers only: a bundle of images (the
    // server's layers were refused, or it speaks an older minor) is skipped,
    // unless the user just changed to layered from a mode that blends them
    // (the server had fused it before it heard). A bundle of layers renders
    // layered whatever the mode (the user just left layered).
    std::optional<StatusOr<DecodedLayers>> layers;
    bool before_layers = false;
    if (bundle.layers) {
      recordLayers(*bundle.layers, receive_ns);
      layers.emplace(layersOfBundle(*bundle.layers, cameras_, &layer_streams_));
      layers_began_ = true;
      report_.startUpEnded();
    } else if (mode_ == BlendMode::kLayered && !images_mode_) {
      layers.emplace(
          Status(StatusCode::kMalformed, "mode layered, and the bundle holds no texture layers"));
      before_layers = !layers_began_;
    }
    const Status usable = !views.isOk()                 ? views.status()
                          : layers && !(*layers).isOk() ? (*layers).status()
                                                        : Status::ok();
    if (!usable.isOk()) {
      if (views.isOk() && before_layers) {
        // Fused before the server took this client's request for layers:
        // start-up, not bad input (the report counts it as skipped if no
        // layers ever come).
        std::fprintf(stderr, "[client] frame %llu has no texture layers yet (start-up)\n",
                     static_cast<unsigned long long>(bundle.frame_id));
        report_.noteStartUp("frame " + std::to_string(bundle.frame_id) + ": " + usable.message());
      } else {
        skip(bundle.frame_id, usable.message());
      }
      failed_bundles_.insert(bundle.frame_id);
      while (failed_bundles_.size() > 64) failed_bundles_.erase(failed_bundles_.begin());
      return;
    }
    pending.views = std::move(*views);
    if (layers) pending.layers = std::move(**layers);
    pending.stamps.push_back({static_cast<uint16_t>(Stage::kDecode), kSourceClient, t0, now()});
    bundles_[bundle.frame_id] = std::move(pending);
    while (bundles_.size() > 4) bundles_.erase(bundles_.begin());
  }

  // Decodes a mesh, pairs it with its bundle, checks both (what came off
  // the network, before the renderer takes it: it throws on what these
  // refuse) and uploads them; none, said why, when the frame is skipped.
  std::optional<ReadyMesh> prepareMesh(const protocol::Frame& frame, uint64_t receive_ns) {
    ReadyMesh ready;
    const uint64_t t0 = now();
    auto s = protocol::decodeFrame(frame, ready.frame);
    if (!s.isOk()) {
      skip(0, "MeshFrame: " + s.toString());
      return std::nullopt;
    }
    const uint64_t id = ready.frame.frame_id;
    ready.bundle = bundles_.find(id);
    if (ready.bundle == bundles_.end()) {
      if (failed_bundles_.count(id) == 0) skip(id, "its texture bundle was dropped on the way");
      return std::nullopt;
    }
    const DracoLimits limits = meshLimits();
    auto mesh =
        decodeMesh(ready.frame.codec, ready.frame.mesh.data(), ready.frame.mesh.size(), limits);
    if (!mesh.isOk() && mesh.status().code() == StatusCode::kTooLarge &&
        !options_.mesh_limits_given)
      mesh = Status(StatusCode::kTooLarge,
                    mesh.status().message() +
                        " (what the rig's cameras can produce: a vertex a pixel; "
                        "--max-mesh-vertices to allow more)");
    Status usable = !mesh.isOk() ? mesh.status()
                    : mesh->triangleCount() == 0
                        ? Status(StatusCode::kMalformed, "mesh with no triangles")
                        : Status::ok();
    ready.decoded_ns = now();
    if (mesh.isOk()) ready.triangles = mesh->triangleCount();
    const PendingBundle& bundle = ready.bundle->second;
    // The layers' atlas placed on the mesh as received, from its keys.
    if (usable.isOk() && bundle.layers)
      usable = applyAtlasLayout(*mesh, bundle.layers->layout).status();
    if (usable.isOk()) usable = checkMesh(*mesh, options_.render.half_precision_vertices);
    if (usable.isOk()) usable = checkViews(bundle.views);
    if (usable.isOk()) usable = checkRenderable(mesh->positions.size(), options_.render.blend);
    if (!usable.isOk()) {
      skip(id, usable.message());
      bundles_.erase(ready.bundle);
      return std::nullopt;
    }
    ready.stamps = ready.frame.stamps;
    endFanout(ready.stamps, receive_ns);
    // Decode of this frame: the bundle's and the mesh's together.
    ready.decode_ms = static_cast<double>(ready.decoded_ns - t0) / 1e6 +
                      protocol::stampedMs(bundle.stamps, Stage::kDecode);
    for (const auto& stamp : bundle.stamps) {
      if (stamp.stage == static_cast<uint16_t>(Stage::kImageEncode) ||
          stamp.stage == static_cast<uint16_t>(Stage::kLayers) ||
          stamp.stage == static_cast<uint16_t>(Stage::kLayerVideo))
        ready.stamps.push_back(stamp);
    }
    // This frame is decoded (while the previous one rendered): the
    // previous one's picture is taken before the GPU's inputs change.
    finishFrame();
    ready.upload_start_ns = now();
    renderer_.setMesh(*mesh);
    if (bundle.layers) {
      renderer_.setLayers(bundle.layers->views);
    } else {
      renderer_.setViews(bundle.views);
    }
    report_.addViewsWithoutSubject(renderer_.camerasWithoutSubject());
    if (!bundle.layers) mask_health_.offer(id, now(), *mesh, bundle.views);
    ready.uploaded_ns = now();
    ClientOptions steered = options_;
    steered.run.view = view_;
    OrbitHold hold = hold_;
    hold.yaw += held_from_degrees_;
    auto user = userCamera(steered, cameras_, meshBounds(*mesh), report_.framesRendered(), hold);
    if (!user) {
      skip(id, "view '" + view_ + "' names no calibrated camera");
      bundles_.erase(ready.bundle);
      return std::nullopt;
    }
    ready.user = *user;
    ready.wire_bytes = frame.bytes.size();
    return ready;
  }

  // The blend for the next rendered frame: eq. 5's lambda is rescaled by
  // the real interval between rendered frames (clamped: a stall must not
  // make the field jump); an excluded camera is left out.
  BlendSettings nextBlend(const std::vector<ViewImages>& views, bool layers) {
    BlendSettings blend = options_.render.blend;
    blend.mode = layers                         ? BlendMode::kLayered
                 : mode_ == BlendMode::kLayered ? *images_mode_
                                                : mode_;
    blend.overlay = overlay_;
    blend.overlay_pod = overlay_pod_;
    blend.stylisation = stylisation_;
    blend.relight = relight_;
    const uint64_t now_ns = monotonicNs();
    blend.frame_interval_s =
        last_render_ns_ == 0
            ? 1.0 / 30.0
            : std::clamp(static_cast<double>(now_ns - last_render_ns_) / 1e9, 1e-3, 0.5);
    last_render_ns_ = now_ns;
    if (options_.exclude_camera >= 0) {
      for (const auto& view : views)
        blend.camera_enabled.push_back(static_cast<int>(view.camera.id) != options_.exclude_camera);
    }
    return blend;
  }

  // Written aside and renamed: whoever watches frames/ (a viewer, a test)
  // never reads half a picture. Handed to the writer's thread, or written
  // here when the judge reads it next; whether it was (or will be).
  bool writeFrame(Image8 picture, const std::string& file) {
    if (!options_.write_frames) return false;
    if (writer_) return writer_->submit(std::move(picture), out_dir_ / file);
    return writePictureAtomically(picture, out_dir_ / file);
  }

  // The live judge's verdict on a written frame, outside every stage's
  // time; a judge gone stays gone, and the frames render on unjudged.
  void judgeFrame(const ReadyMesh& ready, report::FrameRecord& record) {
    const uint64_t judge_start = monotonicNs();
    auto answer =
        judge_->judge({(out_dir_ / record.file).string(), ready.frame.frame_id, ready.user});
    const std::string error = answer.isOk() ? answer->error : answer.status().message();
    if (answer.isOk() && error.empty()) record.quality = answer->quality;
    // e.g. a pod view of another size than the picture
    if (!error.empty() && !judge_failed_)
      std::fprintf(stderr, "[client] frames not judged: %s\n", error.c_str());
    judge_failed_ = judge_failed_ || !error.empty();
    report_.addJudgeMs(static_cast<double>(monotonicNs() - judge_start) / 1e6);
  }

 public:
  // Submits the frame's render; the loop goes on receiving and decoding
  // until finishFrame takes the picture.
  void beginFrame(ReadyMesh ready) {
    const PendingBundle& bundle = ready.bundle->second;
    const BlendSettings blend = nextBlend(bundle.views, bundle.layers.has_value());
    ready.bundle_bytes = bundle.bytes;
    ready.feather_bytes = bundle.feather_bytes;
    ready.bundle_cameras = static_cast<uint32_t>(
        bundle.layers ? bundle.layers->views.camera_centers.size() : bundle.views.size());
    ready.field_runs = renderer_.fieldPasses();
    // Where the user changed to or from layered, the frames change from
    // one kind to the other a little later (what the server had fused
    // before it heard): said when they do.
    if (rendered_layers_ && *rendered_layers_ != bundle.layers.has_value())
      std::fprintf(stderr, "%s[client] the frames carry %s: rendering them %s\n", tty_ ? "\n" : "",
                   bundle.layers ? "texture layers" : "camera images",
                   blendModeName(blend.mode).c_str());
    rendered_layers_ = bundle.layers.has_value();
    renderer_.beginRender(ready.user, blend);
    // On the GPU now: this bundle and every older one are done with.
    bundles_.erase(bundles_.begin(), std::next(ready.bundle));
    ready.bundle = bundles_.end();
    in_flight_ = std::move(ready);
    if (!overlap_) finishFrame();
  }

  bool rendering() const { return in_flight_.has_value(); }
  // Texture layers in place of camera images, as the user's mode asks.
  bool wantsLayers() const { return mode_ == BlendMode::kLayered; }

  // The panel's first words: the mode, and the overlay with its pod.
  std::string panelTitle() const {
    std::string title = blendModeName(mode_);
    if (overlay_ == Overlay::kCameraColours) title += " + cameras";
    if (overlay_ != Overlay::kNone && overlay_ != Overlay::kCameraColours)
      title += " + " + overlayName(overlay_) + " of pod " + std::to_string(overlay_pod_);
    return title;
  }

  // The picture of the frame in flight, written and recorded; nothing when
  // none is.
  void finishFrame() {
    if (!in_flight_) return;
    ReadyMesh ready = std::move(*in_flight_);
    in_flight_.reset();
    Image8 picture = renderer_.finishRender();
    // The window shows the picture under the live panel (P hides it); S
    // keeps what the window shows, apart from the frames.
    Image8 shown;
    if (window_ != nullptr) {
      const double fade = static_cast<double>(monotonicNs() - fade_start_ns_) / kFadeNs;
      shown = fade < 1.0 ? crossFade(fade_from_, picture, fade) : picture;
      if (!(fade < 1.0)) fade_from_ = {};
      last_shown_ = shown;
      if (panel_) drawPanel(shown, panelFigures(report_.frames(), kPanelFrames, panelTitle()));
    }
    const Image8& in_window = shown.pixels.empty() ? picture : shown;
    if (window_ != nullptr) window_->show(in_window);
    // The render stage ends with the picture handed to the window, if
    // any: what the window costs shows in it (bench_viewer).
    const uint64_t rendered_ns = now();
    if (screenshot_due_) {
      screenshot_due_ = false;
      char shot[64];
      std::snprintf(shot, sizeof(shot), "screenshot_%03zu.png", ++screenshots_);
      std::error_code ec;
      fs::create_directories(out_dir_ / "screenshots", ec);
      if (writePictureAtomically(in_window, out_dir_ / "screenshots" / shot))
        std::fprintf(stderr, "%s[client] screenshot %s\n", tty_ ? "\n" : "",
                     (out_dir_ / "screenshots" / shot).c_str());
    }
    if (renderer_.fieldPasses() != ready.field_runs) {
      const auto times = renderer_.fieldTimesMs();
      const auto& names = TextureFieldPasses::stageNames();
      for (size_t s = 0; s < times.size() && s < names.size(); ++s) {
        if (times[s] >= 0) report_.addGpuPass(names[s], times[s]);  // -1: not in this mode
      }
    }
    report::FrameRecord record;
    record.frame_id = ready.frame.frame_id;
    char name[64];
    std::snprintf(name, sizeof(name), "frame_%06zu.png", report_.framesRendered());
    record.file = std::string("frames/") + name;
    const bool written = writeFrame(std::move(picture), record.file);
    if (!written) record.file.clear();  // not written, or dropped by a full writer queue
    const uint64_t written_local_ns = monotonicNs();
    const uint64_t written_ns = server_clock_.toPeer(written_local_ns);
    if (judge_ && written) judgeFrame(ready, record);
    auto& stamps = ready.stamps;
    stamps.push_back({static_cast<uint16_t>(Stage::kUpload), kSourceClient, ready.upload_start_ns,
                      ready.uploaded_ns});
    stamps.push_back(
        {static_cast<uint16_t>(Stage::kRender), kSourceClient, ready.uploaded_ns, rendered_ns});
    stamps.push_back(
        {static_cast<uint16_t>(Stage::kWrite), kSourceClient, rendered_ns, written_ns});
    report_.addStamps(stamps);
    record.timeline = report::timelineOf(stamps);
    report_.addStage(static_cast<uint16_t>(Stage::kDecode), ready.decode_ms);
    record.capture_time_ns = ready.frame.capture_time_ns;
    record.written_local_ns = written_local_ns;
    record.end_to_end_ms =
        static_cast<double>(static_cast<int64_t>(written_ns - ready.frame.capture_time_ns)) / 1e6;
    record.client_bytes = ready.wire_bytes + ready.bundle_bytes;
    record.mesh_bytes = ready.wire_bytes;
    record.mesh_triangles = ready.triangles;
    record.feather_bytes = ready.feather_bytes;
    auto st = stats_.find(ready.frame.frame_id);
    if (st != stats_.end()) {
      record.client_bytes += st->second.bytes;
      record.cameras_expected = st->second.stats.cameras_expected;
      const protocol::Stats& stats = st->second.stats;
      record.cameras_present = stats.cameras_present_count.value_or(
          static_cast<uint32_t>(__builtin_popcountll(stats.cameras_present)));
      record.pod_bytes = st->second.stats.pod_bytes;
      record.note = st->second.stats.note;
      stats_.erase(stats_.begin(), std::next(st));
    } else {
      record.cameras_present = ready.bundle_cameras;
      record.cameras_expected = record.cameras_present;
    }
    report_.addFrame(record, written_ns);
  }

 private:
  // This host's clock read on the server's, which every stamp of the frame
  // is on (its own until the server's clock is measured, or from a server
  // before 1.8).
  uint64_t now() const { return server_clock_.toPeer(monotonicNs()); }

  const ClientOptions& options_;
  const protocol::ClockSync& server_clock_;
  const fs::path out_dir_;
  VulkanContext& context_;
  ViewerWindow* window_ = nullptr;
  // The view and the mode, as the flags set them and the window steers
  // them; the orbit's hold, and the automatic orbit's angle when it began.
  std::string view_;
  BlendMode mode_;
  // The last mode that blends camera images, the user's before layered:
  // frames fused before the server heard of a change to layered still
  // carry images, and render so (none: the client started layered).
  std::optional<BlendMode> images_mode_;
  std::optional<bool> rendered_layers_;  // whether the last frame rendered carried layers
  OrbitHold hold_;
  double held_from_degrees_ = 0;
  bool screenshot_due_ = false;
  Overlay overlay_ = Overlay::kNone;
  uint32_t overlay_pod_ = 0;
  Stylisation stylisation_ = Stylisation::kNone;
  bool relight_ = false;
  bool panel_ = true;  // the window's live panel (P)
  static constexpr size_t kPanelFrames = 30;
  // A new mode fades in over kFadeNs from the last picture shown before it
  // (without the panel), so that the difference shows, not a snap.
  static constexpr double kFadeNs = 400e6;
  Image8 last_shown_, fade_from_;
  uint64_t fade_start_ns_ = 0;
  size_t screenshots_ = 0;
  Renderer& renderer_;
  std::optional<FrameJudge> judge_;
  const bool tty_;
  const bool overlap_;  // the next frame decodes while this one renders (--overlap-render)
  std::map<uint32_t, Camera> cameras_;
  LayerStreams layer_streams_;  // the layers' video, kept from bundle to bundle
  std::map<uint64_t, PendingBundle> bundles_;
  std::map<uint64_t, FrameStats> stats_;
  std::set<uint64_t> failed_bundles_;  // ids already reported as skipped
  bool layers_began_ = false;          // a bundle of texture layers came
  report::LatencyReport report_;
  std::optional<LayerVideoRecorder> layer_files_;  // --record-layers
  std::optional<PictureWriter> writer_;            // the pictures, off the render path
  MaskHealthSampler mask_health_;                  // each pod's mask against the hull, off it too
  uint64_t last_progress_ns_ = 0;
  uint64_t superseded_ = 0;             // meshes skipped because a newer one was already there
  bool judge_failed_ = false;           // warned once
  uint64_t last_render_ns_ = 0;         // for the temporal field's real frame interval
  std::optional<ReadyMesh> in_flight_;  // rendering while the loop receives
};

}  // namespace

int runClient(const ClientOptions& options) {
  const fs::path out_dir(options.out_dir);
  std::error_code ec;
  fs::create_directories(out_dir / "frames", ec);
  if (ec) {
    std::fprintf(stderr, "[client] cannot create %s: %s\n", (out_dir / "frames").c_str(),
                 ec.message().c_str());
    return 1;
  }
  std::unique_ptr<VulkanContext> context;
  std::unique_ptr<Renderer> renderer;
  // The window's system first: its extensions go into the instance.
  gpu::ContextOptions context_options;
  context_options.device_selector = options.run.device;
  std::string no_window;
  if (options.run.window)
    context_options.swapchain =
        windowSystemExtensions(&context_options.instance_extensions, &no_window);
  std::unique_ptr<ViewerWindow> window;  // before the context goes
  try {
    context = std::make_unique<VulkanContext>(context_options);
    renderer = std::make_unique<Renderer>(*context, options.width, options.height);
    renderer->setHalfPrecisionVertices(options.render.half_precision_vertices);
    renderer->warmUp(options.render.blend);
    if (context_options.swapchain) {
      window =
          ViewerWindow::open(*context, options.width, options.height,
                             "holofuse client " + std::to_string(options.client_id), &no_window);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "[client] Vulkan start-up failed: %s\n", e.what());
    return 1;
  }
  if (options.run.window) {
    if (window) {
      std::fprintf(stderr, "[client] the pictures show in a window too (Escape or Q closes it)\n");
    } else {
      std::fprintf(stderr, "[client] no window: %s; rendering headless\n", no_window.c_str());
    }
  }
  std::optional<FrameJudge> judge;
  if (!options.judge_command.empty()) {
    auto started = FrameJudge::start(options.judge_command);
    if (!started.isOk()) {
      std::fprintf(stderr, "[client] --judge: %s\n", started.status().message().c_str());
      return 2;
    }
    judge.emplace(std::move(started.value()));
  }
  std::fprintf(
      stderr, "[client] rendering on %s, mode %s, the next frame decoded %s\n",
      context->deviceName().c_str(), blendModeName(options.render.blend.mode).c_str(),
      overlapsRender(options, *context) ? "while this one renders" : "after this one renders");
  if (options.jump_degrees != 0) {
    std::fprintf(stderr, "[client] the view jumps %g degrees at rendered frame %llu\n",
                 options.jump_degrees, static_cast<unsigned long long>(options.jump_at_frame));
  }

  protocol::Hello hello;
  hello.role = protocol::Role::kClient;
  hello.id = options.client_id;
  hello.name = "client-" + std::to_string(options.client_id);
  hello.max_minor = options.max_minor;
  // Mode layered receives texture layers in place of the camera images
  // (their colour as video where the server codes it, since 1.6).
  if (options.render.blend.mode == BlendMode::kLayered)
    hello.capabilities |= protocol::kCapabilityLayers | protocol::kCapabilityLayerVideo;
  protocol::LinkOptions link_options;
  link_options.log_name = "client";
  link_options.key = options.key;
  link_options.limits.max_queued_droppable = 16;
  link_options.frames_ahead = options.run.frames_ahead;
  protocol::ServerLink link(options.server, hello, link_options);

  ClientLoop loop(options, *context, *renderer, std::move(judge), link.clock());
  loop.setWindow(window.get());
  std::vector<protocol::Frame> received;
  bool window_closed = false;
  uint64_t answered_ns = monotonicNs();  // the start, or when the server last answered
  while (!stopRequested() && !loop.done()) {
    if (window && window->closed()) {
      window_closed = true;
      break;
    }
    loop.takeWindowControls(link.changesLayers());
    // Layers as video, as the Hello of a client started layered asks.
    const uint64_t layers =
        loop.wantsLayers() ? protocol::kCapabilityLayers | protocol::kCapabilityLayerVideo : 0;
    if (layers != link.layersTaken()) link.takeLayers(layers);
    // While a frame renders, only what has already arrived is taken (and
    // decoded beside the render); with nothing more, its picture is taken.
    link.poll(loop.rendering() ? 0 : 50, received);
    if (link.fatalError()) {
      std::fprintf(stderr, "[client] giving up: %s\n", link.fatalError()->toString().c_str());
      return 2;
    }
    if (link.ready()) answered_ns = monotonicNs();
    if (options.give_up_after_s > 0 &&
        static_cast<double>(monotonicNs() - answered_ns) / 1e9 > options.give_up_after_s) {
      std::fprintf(
          stderr, "%s[client] giving up: no server answered at %s for %g s (--give-up-after)\n",
          loop.rendering() ? "\n" : "", options.server.toString().c_str(), options.give_up_after_s);
      loop.finishFrame();
      loop.writeReport();
      return 1;
    }
    const bool arrived = !received.empty();
    loop.receive(received);
    received.clear();
    if (!arrived) loop.finishFrame();
    loop.printProgress();
    // Bye follows everything the server sent on the stream: all of it has
    // been rendered by now.
    if (options.exit_when_server_leaves && link.serverSaidBye()) {
      loop.finishFrame();
      loop.sayReplayOver();
      break;
    }
  }
  loop.finishFrame();
  if (window) {
    std::fprintf(stderr, "[client] window: %llu pictures shown, %llu dropped%s\n",
                 static_cast<unsigned long long>(window->shown()),
                 static_cast<unsigned long long>(window->dropped()),
                 window_closed ? " (closed by the user)" : "");
  }
  link.close(window_closed     ? "the client's window was closed"
             : stopRequested() ? "client stopped by signal"
                               : "client rendered its frames");
  loop.writeReport();
  return 0;
}

}  // namespace holofuse::render

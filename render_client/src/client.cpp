#include "render_client/client.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <set>
#include <stdexcept>

#include "common/camera.h"
#include "common/image_codec.h"
#include "common/image_io.h"
#include "common/mesh_codec.h"
#include "common/shutdown.h"
#include "protocol/clock.h"
#include "protocol/server_link.h"
#include "render_client/frame_judge.h"
#include "render_client/latency_report.h"

namespace holofuse::render {

using protocol::kSourceClient;
using protocol::monotonicNs;
using protocol::Stage;

namespace {

struct PendingBundle {
  std::vector<ViewImages> views;
  std::vector<protocol::StageStamp> stamps;
  uint64_t bytes = 0;
  uint64_t feather_bytes = 0;  // of bytes, the feather maps' compressed planes
};

// The axis the pods stand around: the normal of the plane through their
// centres (any order: every pair's cross product is parallel to it), with
// the sign most pods' own up direction agrees with; the pods' mean up
// direction when they do not span a plane (one or two pods, a line).
glm::dvec3 ringAxis(const std::map<uint32_t, Camera>& cameras) {
  glm::dvec3 mean(0.0), up_sum(0.0);
  for (const auto& [id, cam] : cameras) {
    mean += cam.center();
    up_sum += -(glm::transpose(cam.rotation) * glm::dvec3(0, 1, 0));  // image up in the world
  }
  mean /= static_cast<double>(cameras.size());
  glm::dvec3 axis(0.0), reference(0.0);
  double scale = 0;
  for (auto a = cameras.begin(); a != cameras.end(); ++a) {
    scale = std::max(scale, glm::length(a->second.center() - mean));
    for (auto b = std::next(a); b != cameras.end(); ++b) {
      glm::dvec3 n = glm::cross(a->second.center() - mean, b->second.center() - mean);
      if (glm::length(reference) == 0 && glm::length(n) > 0) reference = n;
      axis += glm::dot(n, reference) < 0 ? -n : n;
    }
  }
  if (!(glm::length(axis) > 1e-9 * scale * scale)) {
    return glm::length(up_sum) > 1e-9 ? glm::normalize(up_sum) : glm::dvec3(0, 1, 0);
  }
  axis = glm::normalize(axis);
  // Pods may be rotated 180 degrees in their image plane; the majority
  // decides which way is up.
  int agree = 0;
  for (const auto& [id, cam] : cameras) {
    agree += glm::dot(axis, -(glm::transpose(cam.rotation) * glm::dvec3(0, 1, 0))) >= 0 ? 1 : -1;
  }
  return agree >= 0 ? axis : -axis;
}

// v turned by degrees around the unit axis (Rodrigues).
glm::dvec3 turned(const glm::dvec3& v, const glm::dvec3& axis, double degrees) {
  const double a = degrees * std::numbers::pi / 180.0;
  return v * std::cos(a) + glm::cross(axis, v) * std::sin(a) +
         axis * glm::dot(axis, v) * (1.0 - std::cos(a));
}

}  // namespace

// The orbit runs at the pods' mean distance and height with their mean
// field of view. A pod view turned by the jump keeps the pod's intrinsics
// and turns its pose around the ring axis through the subject.
std::optional<Camera> userCamera(const ClientOptions& options,
                                 const std::map<uint32_t, Camera>& cameras, const Bounds& bounds,
                                 size_t frame_index) {
  if (cameras.empty()) return std::nullopt;
  const glm::dvec3 target = 0.5 * (glm::dvec3(bounds.min) + glm::dvec3(bounds.max));
  const glm::dvec3 up = ringAxis(cameras);
  const double jump = options.jump_degrees != 0 && frame_index >= options.jump_at_frame
                          ? options.jump_degrees
                          : 0.0;
  auto fovX = [](const Camera& cam) {
    return 2.0 * std::atan(0.5 * cam.width / cam.fx) * 180.0 / std::numbers::pi;
  };
  if (options.view.rfind("pod:", 0) == 0) {
    const uint32_t id = static_cast<uint32_t>(std::stoul(options.view.substr(4)));
    auto it = cameras.find(id);
    if (it == cameras.end()) return std::nullopt;
    Camera pod = it->second;
    if (jump == 0) return pod;
    // The pod's whole pose turned, its intrinsics kept: the camera-to-world
    // rotation becomes Q R^T, so world-to-camera R Q^T.
    const glm::dmat3 q(turned({1, 0, 0}, up, jump), turned({0, 1, 0}, up, jump),
                       turned({0, 0, 1}, up, jump));
    const glm::dvec3 eye = target + turned(pod.center() - target, up, jump);
    pod.rotation = pod.rotation * glm::transpose(q);
    pod.translation = -(pod.rotation * eye);
    return pod;
  }
  // In-plane basis: the world's z (else x) projected onto the ring plane.
  glm::dvec3 e1 = glm::dvec3(0, 0, 1) - up * up.z;
  if (glm::length(e1) < 0.1) e1 = glm::dvec3(1, 0, 0) - up * up.x;
  e1 = glm::normalize(e1);
  const glm::dvec3 e2 = glm::cross(up, e1);
  double radius = 0, height = 0, fov_x = 0;
  for (const auto& [id, cam] : cameras) {
    const glm::dvec3 offset = cam.center() - target;
    height += glm::dot(offset, up);
    radius += glm::length(offset - up * glm::dot(offset, up));
    fov_x += fovX(cam);
  }
  const double n = static_cast<double>(cameras.size());
  radius /= n;
  height /= n;
  fov_x /= n;
  const double degrees = options.orbit_degrees_per_frame * static_cast<double>(frame_index) + jump;
  const double angle = degrees * std::numbers::pi / 180.0;
  const glm::dvec3 eye =
      target + up * height + radius * (std::cos(angle) * e1 + std::sin(angle) * e2);
  return lookAtCamera(kOrbitCameraId, eye, target, up, options.width, options.height, fov_x);
}

uint64_t featherBytes(const protocol::TextureBundle& bundle) {
  uint64_t bytes = 0;
  for (const auto& image : bundle.images) {
    for (const auto& plane : image.planes)
      bytes += plane.kind == protocol::PlaneKind::kFeather ? plane.data.size() : 0;
  }
  return bytes;
}

StatusOr<std::vector<ViewImages>> viewsOfBundle(const protocol::TextureBundle& bundle,
                                                const std::map<uint32_t, Camera>& cameras) {
  std::vector<ViewImages> views;
  for (const auto& image : bundle.images) {
    auto malformed = [&](const std::string& what) {
      return Status(StatusCode::kMalformed, "camera " + std::to_string(image.camera_id) + what);
    };
    auto cam = cameras.find(image.camera_id);
    if (cam == cameras.end()) return malformed(" has no calibration");
    ViewImages view;
    view.camera = cam->second;
    for (const auto& plane : image.planes) {
      auto decoded = decodePlane(plane);
      if (!decoded.isOk()) return malformed(": " + decoded.status().message());
      if (plane.kind == protocol::PlaneKind::kColor) view.color = std::move(*decoded);
      if (plane.kind == protocol::PlaneKind::kMask) view.mask = std::move(*decoded);
      if (plane.kind == protocol::PlaneKind::kFeather) view.feather = std::move(*decoded);
    }
    // A feather map is optional (a 1.1 server sends none), but one that is
    // sent covers the colour's rectangle, as one grey plane (SPEC.md 1.2).
    if (!view.feather.pixels.empty() &&
        (view.feather.width != view.color.width || view.feather.height != view.color.height ||
         view.feather.channels != 1)) {
      return malformed(" feather map is " + std::to_string(view.feather.width) + "x" +
                       std::to_string(view.feather.height) + " with " +
                       std::to_string(view.feather.channels) +
                       " channel(s), not one grey plane of the colour's " +
                       std::to_string(view.color.width) + "x" + std::to_string(view.color.height));
    }
    // A rectangle of the image (the pods send their foreground's): back
    // into a whole frame, background black with mask 0.
    const bool whole = image.offset_x == 0 && image.offset_y == 0 &&
                       view.color.width == view.camera.width &&
                       view.color.height == view.camera.height;
    if (!whole && view.color.width == view.mask.width && view.color.height == view.mask.height &&
        cropFits(image.offset_x, image.offset_y, view.color.width, view.color.height,
                 view.camera.width, view.camera.height)) {
      // (The feather map is the colour's rectangle too, checked above.)
      if (!view.feather.pixels.empty()) {
        view.feather = placeInFrame(view.feather, image.offset_x, image.offset_y, view.camera.width,
                                    view.camera.height);
      }
      view.color = placeInFrame(view.color, image.offset_x, image.offset_y, view.camera.width,
                                view.camera.height);
      view.mask = placeInFrame(view.mask, image.offset_x, image.offset_y, view.camera.width,
                               view.camera.height);
    }
    if (view.color.width != view.camera.width || view.color.height != view.camera.height ||
        view.mask.width != view.camera.width || view.mask.height != view.camera.height ||
        view.color.channels != 3 || view.mask.channels != 1) {
      return malformed(" images are not " + std::to_string(view.camera.width) + "x" +
                       std::to_string(view.camera.height) + " RGB + mask");
    }
    views.push_back(std::move(view));
  }
  return views;
}

int runClient(const ClientOptions& options) {
  namespace fs = std::filesystem;
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
  try {
    context = std::make_unique<VulkanContext>(options.device);
    renderer = std::make_unique<Renderer>(*context, options.width, options.height);
    renderer->setHalfPrecisionVertices(options.render.half_precision_vertices);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "[client] Vulkan start-up failed: %s\n", e.what());
    return 1;
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
  std::fprintf(stderr, "[client] rendering on %s, mode %s\n", context->deviceName().c_str(),
               blendModeName(options.render.blend.mode).c_str());
  if (options.jump_degrees != 0) {
    std::fprintf(stderr, "[client] the view jumps %g degrees at rendered frame %llu\n",
                 options.jump_degrees, static_cast<unsigned long long>(options.jump_at_frame));
  }

  protocol::Hello hello;
  hello.role = protocol::Role::kClient;
  hello.id = options.client_id;
  hello.nonce = protocol::realtimeNs();
  hello.name = "client-" + std::to_string(options.client_id);
  protocol::LinkOptions link_options;
  link_options.log_name = "client";
  link_options.limits.max_queued_droppable = 16;
  protocol::ServerLink link(options.server, hello, link_options);

  std::map<uint32_t, Camera> cameras;
  std::map<uint64_t, PendingBundle> bundles;
  struct FrameStats {
    protocol::Stats stats;
    uint64_t bytes = 0;  // the Stats frame's own size
  };
  std::map<uint64_t, FrameStats> stats;
  std::set<uint64_t> failed_bundles;  // ids already reported as skipped
  LatencyReport report;
  const bool tty = isatty(STDOUT_FILENO);
  uint64_t last_progress_ns = 0;
  uint64_t frames_superseded = 0;  // meshes skipped because a newer one was already there
  bool judge_failed = false;       // warned once
  uint64_t last_render_ns = 0;     // for the temporal field's real frame interval
  std::vector<protocol::Frame> received;

  auto skip = [&](uint64_t frame_id, const std::string& why) {
    std::fprintf(stderr, "[client] frame %llu skipped, keeping the previous picture: %s\n",
                 static_cast<unsigned long long>(frame_id), why.c_str());
    report.noteSkipped("frame " + std::to_string(frame_id) + ": " + why);
  };

  while (!stopRequested() && (options.frames == 0 || report.framesRendered() < options.frames)) {
    link.poll(50, received);
    if (link.fatalError()) {
      std::fprintf(stderr, "[client] giving up: %s\n", link.fatalError()->toString().c_str());
      return 2;
    }
    // When frames arrive faster than this client renders, only the newest
    // mesh of a batch is rendered: older ones would only add latency.
    size_t newest_mesh = received.size();
    for (size_t k = 0; k < received.size(); ++k) {
      if (received[k].header.type == static_cast<uint16_t>(protocol::MessageType::kMeshFrame))
        newest_mesh = k;
    }
    for (size_t k = 0; k < received.size(); ++k) {
      auto& frame = received[k];
      if (options.frames != 0 && report.framesRendered() >= options.frames) break;
      const uint64_t receive_ns = monotonicNs();
      if (frame.header.type == static_cast<uint16_t>(protocol::MessageType::kMeshFrame) &&
          k != newest_mesh) {
        ++frames_superseded;
        continue;
      }
      const auto type = static_cast<protocol::MessageType>(frame.header.type);
      if (type == protocol::MessageType::kCalibration) {
        protocol::Calibration calibration;
        const auto s = protocol::decodeFrame(frame, calibration);
        if (!s.isOk()) {
          std::fprintf(stderr, "[client] bad Calibration ignored: %s\n", s.toString().c_str());
          continue;
        }
        cameras[calibration.camera_id] = fromCalibration(calibration);
      } else if (type == protocol::MessageType::kStats) {
        protocol::Stats st;
        if (protocol::decodeFrame(frame, st).isOk()) {
          if (st.pod_arrivals) report.setServerArrivals(*st.pod_arrivals);
          const uint64_t id = st.frame_id;
          stats[id] = FrameStats{std::move(st), frame.bytes.size()};
          while (stats.size() > 64) stats.erase(stats.begin());
        }
      } else if (type == protocol::MessageType::kTextureBundle) {
        protocol::TextureBundle bundle;
        const uint64_t t0 = monotonicNs();
        auto s = protocol::decodeFrame(frame, bundle);
        if (!s.isOk()) {
          skip(0, "TextureBundle: " + s.toString());
          continue;
        }
        PendingBundle pending;
        pending.bytes = frame.bytes.size();
        pending.feather_bytes = featherBytes(bundle);
        pending.stamps = bundle.stamps;
        for (auto& stamp : pending.stamps) {
          if (stamp.stage == static_cast<uint16_t>(Stage::kFanout) && stamp.end_ns == 0)
            stamp.end_ns = receive_ns;
        }
        auto views = viewsOfBundle(bundle, cameras);
        if (views.isOk()) pending.views = std::move(*views);
        if (!views.isOk()) {
          skip(bundle.frame_id, views.status().message());
          failed_bundles.insert(bundle.frame_id);
          while (failed_bundles.size() > 64) failed_bundles.erase(failed_bundles.begin());
          continue;
        }
        pending.stamps.push_back(
            {static_cast<uint16_t>(Stage::kDecode), kSourceClient, t0, monotonicNs()});
        bundles[bundle.frame_id] = std::move(pending);
        while (bundles.size() > 4) bundles.erase(bundles.begin());
      } else if (type == protocol::MessageType::kMeshFrame) {
        protocol::MeshFrame mesh_frame;
        const uint64_t t0 = monotonicNs();
        auto s = protocol::decodeFrame(frame, mesh_frame);
        if (!s.isOk()) {
          skip(0, "MeshFrame: " + s.toString());
          continue;
        }
        auto bundle = bundles.find(mesh_frame.frame_id);
        if (bundle == bundles.end()) {
          if (failed_bundles.count(mesh_frame.frame_id) == 0) {
            skip(mesh_frame.frame_id, "its texture bundle was dropped on the way");
          }
          continue;
        }
        auto mesh = decodeDraco(mesh_frame.mesh.data(), mesh_frame.mesh.size());
        if (!mesh.isOk() || mesh->triangleCount() == 0) {
          skip(mesh_frame.frame_id,
               mesh.isOk() ? "mesh with no triangles" : mesh.status().message());
          bundles.erase(bundle);
          continue;
        }
        const uint64_t t1 = monotonicNs();
        std::vector<protocol::StageStamp> stamps = mesh_frame.stamps;
        for (auto& stamp : stamps) {
          if (stamp.stage == static_cast<uint16_t>(Stage::kFanout) && stamp.end_ns == 0)
            stamp.end_ns = receive_ns;
        }
        // Decode of this frame: the bundle's and the mesh's together.
        const double decode_ms = static_cast<double>(t1 - t0) / 1e6 +
                                 protocol::stampedMs(bundle->second.stamps, Stage::kDecode);
        for (const auto& stamp : bundle->second.stamps) {
          if (stamp.stage == static_cast<uint16_t>(Stage::kImageEncode)) stamps.push_back(stamp);
        }
        // What came off the network, checked before the renderer takes it
        // (it throws on what these refuse).
        Status usable = checkMesh(*mesh, options.render.half_precision_vertices);
        if (usable.isOk()) usable = checkViews(bundle->second.views);
        if (usable.isOk()) usable = checkRenderable(mesh->positions.size(), options.render.blend);
        if (!usable.isOk()) {
          skip(mesh_frame.frame_id, usable.message());
          bundles.erase(bundle);
          continue;
        }
        renderer->setMesh(*mesh);
        renderer->setViews(bundle->second.views);
        report.addViewsWithoutSubject(renderer->camerasWithoutSubject());
        const uint64_t t2 = monotonicNs();
        auto user = userCamera(options, cameras, meshBounds(*mesh), report.framesRendered());
        if (!user) {
          skip(mesh_frame.frame_id, "view '" + options.view + "' names no calibrated camera");
          bundles.erase(bundle);
          continue;
        }
        BlendSettings blend = options.render.blend;
        // Eq. 5's lambda is rescaled by the real interval between rendered
        // frames (clamped: a stall must not make the field jump).
        const uint64_t now_ns = monotonicNs();
        blend.frame_interval_s =
            last_render_ns == 0
                ? 1.0 / 30.0
                : std::clamp(static_cast<double>(now_ns - last_render_ns) / 1e9, 1e-3, 0.5);
        last_render_ns = now_ns;
        if (options.exclude_camera >= 0) {
          for (const auto& view : bundle->second.views) {
            blend.camera_enabled.push_back(static_cast<int>(view.camera.id) !=
                                           options.exclude_camera);
          }
        }
        const uint64_t field_runs = renderer->fieldPasses();
        const Image8 picture = renderer->render(*user, blend);
        const uint64_t t3 = monotonicNs();
        if (renderer->fieldPasses() != field_runs) {
          const auto times = renderer->fieldTimesMs();
          const auto& names = TextureFieldPasses::stageNames();
          for (size_t s = 0; s < times.size() && s < names.size(); ++s) {
            if (times[s] >= 0)
              report.addGpuPass(names[s], times[s]);  // -1: a pass this mode does not have
          }
        }
        FrameRecord record;
        record.frame_id = mesh_frame.frame_id;
        char name[64];
        std::snprintf(name, sizeof(name), "frame_%06zu.png", report.framesRendered());
        record.file = std::string("frames/") + name;
        bool frame_written = false;
        if (options.write_frames) {
          // Written aside and renamed: whoever watches frames/ (a viewer,
          // a test) never reads half a picture.
          const fs::path path = out_dir / record.file;
          const fs::path partial =
              path.parent_path() / (path.stem().string() + ".partial.png");  // PNG by its name
          const Status written = writePng(partial.string(), picture);
          std::error_code renamed;
          if (written.isOk()) fs::rename(partial, path, renamed);
          frame_written = written.isOk() && !renamed;
          if (!written.isOk()) std::fprintf(stderr, "[client] %s\n", written.message().c_str());
          if (renamed)
            std::fprintf(stderr, "[client] %s: %s\n", path.c_str(), renamed.message().c_str());
        }
        const uint64_t t4 = monotonicNs();
        if (judge && frame_written) {
          const uint64_t judge_start = monotonicNs();
          auto answer =
              judge->judge({(out_dir / record.file).string(), mesh_frame.frame_id, *user});
          const std::string error = answer.isOk() ? answer->error : answer.status().message();
          if (answer.isOk() && error.empty()) record.quality = answer->quality;
          // e.g. a pod view of another size than the picture; a judge gone
          // stays gone, and the frames render on unjudged.
          if (!error.empty() && !judge_failed)
            std::fprintf(stderr, "[client] frames not judged: %s\n", error.c_str());
          judge_failed = judge_failed || !error.empty();
          report.addJudgeMs(static_cast<double>(monotonicNs() - judge_start) / 1e6);
        }
        stamps.push_back({static_cast<uint16_t>(Stage::kUpload), kSourceClient, t1, t2});
        stamps.push_back({static_cast<uint16_t>(Stage::kRender), kSourceClient, t2, t3});
        stamps.push_back({static_cast<uint16_t>(Stage::kWrite), kSourceClient, t3, t4});
        report.addStamps(stamps);
        report.addStage(static_cast<uint16_t>(Stage::kDecode), decode_ms);
        record.end_to_end_ms = static_cast<double>(t4 - mesh_frame.capture_time_ns) / 1e6;
        record.client_bytes = frame.bytes.size() + bundle->second.bytes;
        record.feather_bytes = bundle->second.feather_bytes;
        auto st = stats.find(mesh_frame.frame_id);
        if (st != stats.end()) {
          record.client_bytes += st->second.bytes;
          record.cameras_expected = st->second.stats.cameras_expected;
          record.cameras_present =
              static_cast<uint32_t>(__builtin_popcountll(st->second.stats.cameras_present));
          record.pod_bytes = st->second.stats.pod_bytes;
          record.note = st->second.stats.note;
          stats.erase(stats.begin(), std::next(st));
        } else {
          record.cameras_present = static_cast<uint32_t>(bundle->second.views.size());
          record.cameras_expected = record.cameras_present;
        }
        report.addFrame(record, t4);
        bundles.erase(bundles.begin(), std::next(bundle));
      }
    }
    received.clear();
    const uint64_t now = monotonicNs();
    if (now - last_progress_ns > 1000000000ull && report.framesRendered() > 0) {
      last_progress_ns = now;
      const auto& last = report.frames().back();
      std::printf(
          "%sframes %zu%s | %5.1f fps | end-to-end p50 %6.1f ms p95 %6.1f ms | cameras %u/%u%s",
          tty ? "\r" : "", report.framesRendered(),
          options.frames ? ("/" + std::to_string(options.frames)).c_str() : "", report.fps(),
          report.endToEndPercentile(50), report.endToEndPercentile(95), last.cameras_present,
          last.cameras_expected, tty ? "   " : "\n");
      std::fflush(stdout);
    }
    // Bye follows everything the server sent on the stream: all of it has
    // been rendered by now.
    if (options.exit_when_server_leaves && link.serverSaidBye()) {
      std::printf("%s[client] the server said goodbye: the replay is over\n", tty ? "\n" : "");
      break;
    }
  }
  link.close(stopRequested() ? "client stopped by signal" : "client rendered its frames");
  report.setSuperseded(frames_superseded);
  // What the frames were rendered with, so that a report can be matched
  // with the sweep point it was meant to reproduce.
  std::map<std::string, std::string> settings = {
      {"mode", blendModeName(options.render.blend.mode)},
      {"view", options.view},
      {"size", std::to_string(options.width) + "x" + std::to_string(options.height)},
      {"device", context->deviceName()}};
  // Every rendering setting under its flag's name ("--vote-delta": vote_delta).
  for (const Setting<RenderSettings>& setting : renderFlags()) {
    std::string name = setting.flag.substr(2);
    std::replace(name.begin(), name.end(), '-', '_');
    settings[name] = setting.get(options.render);
  }
  const fs::path report_path = out_dir / "report.json";
  std::ofstream(report_path) << report.toJson(settings, options.budget);
  std::ofstream(out_dir / "report.html") << report.toHtml(settings, options.budget);
  std::string quality;
  for (const auto& q : report.quality()) {
    char text[96];
    std::snprintf(text, sizeof(text), q.measure == "psnr_db" ? ", PSNR %.2f dB" : ", SSIM %.3f",
                  q.mean);
    quality += text;
  }
  if (!quality.empty()) quality += " against the truth (mean)";
  std::printf(
      "%s[client] %zu frames, %.1f fps, end-to-end p50 %.1f ms p95 %.1f ms p99 %.1f ms%s; report: "
      "%s\n",
      tty ? "\n" : "", report.framesRendered(), report.fps(), report.endToEndPercentile(50),
      report.endToEndPercentile(95), report.endToEndPercentile(99), quality.c_str(),
      report_path.c_str());
  return 0;
}

}  // namespace holofuse::render

// render_client: headless Vulkan renderer of the fused stream. See
// its --help for the flags.
#include <cstdio>

#include "base/process.h"
#include "base/shutdown.h"
#include "config/command_line.h"
#include "render_client/client.h"
#include "render_client/light_probe.h"

int main(int argc, char** argv) {
  using namespace holofuse;
  render::ClientOptions options;
  std::string server, size = "320x240";
  bool list_devices = false;
  CLI::App app{"holofuse render_client: renders the fused stream to PNG frames"};
  app.add_option("--server", server, "fusion server HOST:PORT");
  app.add_option("--out", options.out_dir, "output folder (frames/ and report.json)");
  app.add_option("--frames", options.frames,
                 "stop after this many rendered frames (0: until signalled)");
  app.add_option("--frames-expected", options.frames_expected,
                 "with --frames 0: the frames the run should bring (a replay's), for the "
                 "progress line's count and time left; it stops nothing");
  app.add_option("--give-up-after", options.give_up_after_s,
                 "exit (1) when no server has answered for this many seconds, from the start or "
                 "since the connection was lost (default 0: keep trying until signalled)")
      ->check(CLI::Range(0.0, 1e6));
  app.add_flag("--exit-when-server-leaves", options.exit_when_server_leaves,
               "finish when the server says goodbye (the end of a replay)");
  app.add_option("--clock-drift-warn-ms", options.clock_drift_warn_ms,
                 "the report warns when a host's clock moves this far against the server's "
                 "from its first estimate, beyond the estimates' uncertainty")
      ->check(CLI::Range(0.001, 60000.0));
  app.add_option("--size", size, "output size WxH");
  app.add_option("--orbit-speed", options.orbit_degrees_per_frame,
                 "orbit degrees per rendered frame");
  app.add_option("--jump-degrees", options.jump_degrees,
                 "turn the view this many degrees around the pods' ring at once, at --jump-at")
      ->check(CLI::Range(-360.0, 360.0));
  app.add_option("--jump-at", options.jump_at_frame,
                 "the rendered frame the jump happens at (default: half of --frames, else 30)");
  const SettingFlags<render::ClientRunSettings> run_flags(app, render::clientRunFlags());
  const SettingFlags<render::RenderSettings> render_flags(app, render::renderFlags());
  app.add_option("--exclude-camera", options.exclude_camera,
                 "leave this pod camera out of the blend");
  app.add_option("--client-id", options.client_id, "this client's id");
  app.add_flag("--list-devices", list_devices, "print the Vulkan devices and exit");
  app.add_option("--judge", options.judge_command,
                 "a shell command that starts a live judge (eval's holofuse_judge): each written "
                 "frame is judged against the truth from its view (PSNR, SSIM in report.json and "
                 "report.html); costs client time after each frame");
  app.add_option("--max-mesh-vertices", options.mesh_limits.max_vertices,
                 "a received mesh stating more vertices is skipped before it is decoded "
                 "(default: the rig's cameras' pixels, at least 262144, at most 2097152)");
  app.add_option("--max-mesh-faces", options.mesh_limits.max_faces,
                 "a received mesh stating more faces is skipped before it is decoded (default: "
                 "twice the vertices' cap)");
  PeerKeyFlags key_flags(app, "client");
  const ProtocolFlag protocol_flag(app, "client");
  addRigFlag(app, "render_client", [&](const RigFile& rig) -> StatusOr<std::vector<RigOption>> {
    const auto client = givenId(app, "--client-id", options.client_id);
    if (!client.isOk()) return client.status();
    auto part = rig.clientPart(*client);
    if (!part.isOk() && app.count("--client-id") == 0)
      return Status(part.status().code(), part.status().message() + "; give --client-id");
    return part;
  });
  HOLOFUSE_PARSE_FLAGS(app, argc, argv)
  options.mesh_limits_given = app.count("--max-mesh-vertices") + app.count("--max-mesh-faces") > 0;
  run_flags.apply(options.run);
  render_flags.apply(options.render);
  options.render.blend.mode = options.run.mode;
  options.render.blend.overlay = options.run.overlay;
  options.render.blend.overlay_pod = options.run.overlay_pod;
  options.render.blend.stylisation = options.run.stylisation;
  if (!options.run.light_probe.empty()) {
    auto probe = render::loadLightProbe(options.run.light_probe);
    if (!probe.isOk()) {
      std::fprintf(stderr, "--light-probe: %s\n", probe.status().message().c_str());
      return 2;
    }
    options.render.blend.relight = true;
    options.render.blend.light_probe = probe->coefficients;
  }
  const auto key = key_flags.load(protocol::Role::kClient, options.client_id);
  if (!key) return 2;
  options.key = *key;
  options.max_minor = protocol_flag.maxMinor();
  if (list_devices) {
    try {
      const auto devices = gpu::VulkanContext::listDevices();
      for (size_t i = 0; i < devices.size(); ++i)
        std::printf("%zu: %s\n", i, devices[i].name.c_str());
      return 0;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s\n", e.what());
      return 1;
    }
  }
  if (server.empty()) {
    std::fprintf(stderr, "--server is required\n%s", app.help().c_str());
    return 2;
  }
  unsigned w = 0, h = 0;
  if (const std::string error = parseImageSize(size, w, h, 8192); !error.empty()) {
    std::fprintf(stderr, "--size %s\n", error.c_str());
    return 2;
  }
  auto loaded_budget = protocol::loadBudgetFlag(options.run.budget);
  if (!loaded_budget.isOk()) {
    std::fprintf(stderr, "%s\n", loaded_budget.status().message().c_str());
    return 2;
  }
  options.budget = *loaded_budget;
  auto endpoint = protocol::parseEndpoint(server);
  if (!endpoint.isOk()) {
    std::fprintf(stderr, "--server: %s\n", endpoint.status().message().c_str());
    return 2;
  }
  options.server = *endpoint;
  if (app.count("--jump-at") && options.jump_degrees == 0) {
    std::fprintf(stderr, "--jump-at: there is no jump to time; give --jump-degrees too\n");
    return 2;
  }
  if (!app.count("--jump-at")) options.jump_at_frame = options.frames > 0 ? options.frames / 2 : 30;
  if (options.jump_degrees != 0 && options.frames > 0 && options.jump_at_frame >= options.frames) {
    std::fprintf(stderr,
                 "--jump-at %llu: past the last of --frames %llu, the jump would never show\n",
                 static_cast<unsigned long long>(options.jump_at_frame),
                 static_cast<unsigned long long>(options.frames));
    return 2;
  }
  options.width = w;
  options.height = h;
  installStopSignals();
  const FreeMemoryReturner free_memory;
  return render::runClient(options);
}

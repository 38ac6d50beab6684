#include "eval/sweep.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>

#include "base/eta.h"
#include "base/process.h"
#include "base/text_file.h"
#include "codec/image_codec.h"
#include "config/command_line.h"
#include "dataset/dataset.h"
#include "dataset/inspection.h"
#include "result_json.h"
#include "scene/scene_library.h"
#include "sweep_live.h"

namespace holofuse::eval {
namespace {

namespace fs = std::filesystem;

// A sweep asked for something it cannot do (a knob, a value, a point file
// of another run): the command line's fault, exit status 2.
Status invalid(const std::string& message) { return Status(StatusCode::kMalformed, message); }

fs::path pointPath(const std::string& out_dir, const std::string& knob, const std::string& value) {
  return fs::path(out_dir) / "points" / (knob + "=" + value + ".json");
}

// Every setting a point's numbers depend on (not where files go). A point
// on disk is reused only when it was measured under the same settings: a
// rerun into the same folder with another scene, size or mode must not
// mix its numbers with the old ones.
nlohmann::json runSettings(const EvalOptions& run) {
  std::vector<std::string> modes;
  for (const auto mode : run.modes) modes.push_back(render::blendModeName(mode));
  nlohmann::json settings = {
      {"scenes", run.scenes},
      {"datasets", run.datasets},
      {"modes", modes},
      {"frames", run.frames},
      {"first_frame", run.first_frame},
      {"size", std::to_string(run.width) + "x" + std::to_string(run.height)},
      {"fps", run.fps},
      {"held_out_cameras", run.held_out_cameras},
      {"novel_view_degrees", run.novel_view_degrees},
      {"camera_kept", run.camera_kept},
      {"device", run.device},
      {"geometry", run.geometry},
      {"cameras", camerasOf(run)},  // the scene's own count by number: the same run
      // How bytes and codec times were counted, and the metrics'
      // definitions: points measured before a change differ here.
      {"links", "the loop's own encoding and decoding"},
      {"metrics",
       "SSIM over the mask's pixels per window; p50/p95 interpolated; Chamfer to triangles; "
       "codec stages per pod frame"}};
  // Every setting of the loop's programs, under its flag.
  for (const Setting<LoopSettings>& setting : loopFlags())
    settings["loop"][setting.flag] = setting.get(run.loop);
  // A dataset's own voxel, or the one given.
  if (!run.datasets.empty()) settings["voxel_from_dataset"] = run.voxel_from_dataset;
  return settings;
}

// Where a point of the sweep lives and what it runs.
struct PlannedPoint {
  EvalOptions run;
  bool is_default = false;
  fs::path path;
};

PlannedPoint planPoint(const SweepOptions& options, const Knob& knob, const std::string& value) {
  PlannedPoint plan;
  plan.run = options.base;
  (void)knob.apply(plan.run, value);
  // The default only when every setting is the base's (the knob's printed
  // value may round a value that differs).
  plan.is_default = runSettings(plan.run) == runSettings(options.base);
  // Every knob's default value is the same run: done once, shared.
  plan.path = plan.is_default ? fs::path(options.out_dir) / "points" / "default.json"
                              : pointPath(options.out_dir, knob.name, value);
  return plan;
}

// A finished point's file, refused by name when it was measured under
// other settings than this run's (the file stays as it is).
StatusOr<nlohmann::json> readPoint(const PlannedPoint& plan) {
  std::ifstream in(plan.path);
  const auto json = nlohmann::json::parse(in, nullptr, false);
  if (json.is_discarded() || !json.is_object() || !json.contains("result") ||
      !json.contains("scene") || !json.at("scene").is_string()) {
    return invalid(plan.path.string() +
                   " is not a finished sweep point; remove it to measure it again");
  }
  const nlohmann::json now = runSettings(plan.run);
  const nlohmann::json then = json.value("settings", nlohmann::json::object());
  std::string differences;
  for (const auto& [key, value] : now.items()) {
    if (then.contains(key) && then.at(key) == value) continue;
    differences += (differences.empty() ? "" : ", ") + key + " " +
                   (then.contains(key) ? then.at(key).dump() : std::string("unrecorded")) +
                   " (now " + value.dump() + ")";
  }
  if (!differences.empty()) {
    return invalid(plan.path.string() + " was measured under other settings: " + differences +
                   "; give another --out, or remove the file to measure it again");
  }
  return json;
}

}  // namespace

std::string primaryMode(const EvalOptions& options) {
  return options.modes.empty() ? "montage4d" : render::blendModeName(options.modes.back());
}

double clientBytes(const SceneResult& result, const ModeResult& mode) {
  return mode.client_bytes_per_frame > 0 ? mode.client_bytes_per_frame : result.bytes_per_frame;
}

double pipelineMs(const SceneResult& result, const std::string& mode, bool p95) {
  const auto it = result.modes.find(mode);
  // Mode layered adds the server's layer stage (its median in both).
  const double client = it == result.modes.end() ? 0.0
                        : p95 ? it->second.ms_per_new_mesh_p95 + it->second.layers_ms
                              : it->second.ms_per_new_mesh + it->second.layers_ms;
  return (p95 ? result.hull_ms_p95 + result.refine_ms_p95 + result.codec_ms_p95
              : result.hull_ms + result.refine_ms + result.codec_ms) +
         client;
}

namespace {

// -1: a costs clearly less than b; 1: clearly more; 0: a tie (Cost).
int compareCost(const Cost& a, const Cost& b) {
  const double tie = std::max({a.tie_share * std::max(a.p50, b.p50), a.p95 - a.p50, b.p95 - b.p50});
  return a.p50 < b.p50 - tie ? -1 : a.p50 > b.p50 + tie ? 1 : 0;
}

}  // namespace

bool dominates(const TradePoint& a, const TradePoint& b) {
  // No worse as measured, better beyond noise: a rule that chains (if a
  // beats b and b beats c, a beats c), so the front is never empty, and
  // noise can neither make a point win nor let a noisily slower one win.
  if (a.psnr_db < b.psnr_db) return false;
  bool better = a.psnr_db > b.psnr_db + kPsnrTieDb;
  if (a.ssim >= 0 && b.ssim >= 0) {
    if (a.ssim < b.ssim) return false;
    better = better || a.ssim > b.ssim + kSsimTie;
  }
  for (size_t k = 0; k < a.costs.size() && k < b.costs.size(); ++k) {
    if (a.costs[k].p50 > b.costs[k].p50) return false;
    better = better || compareCost(a.costs[k], b.costs[k]) < 0;
  }
  return better;
}

std::vector<size_t> paretoFront(const std::vector<TradePoint>& points) {
  std::vector<size_t> front;
  for (size_t i = 0; i < points.size(); ++i) {
    bool dominated = false;
    for (size_t j = 0; j < points.size() && !dominated; ++j)
      dominated = j != i && dominates(points[j], points[i]);
    if (!dominated) front.push_back(i);
  }
  return front;
}

namespace {

// Runs a program with its output into log: its exit status, or -1 when it
// could not start (said why on stderr).
int runLogged(const std::vector<std::string>& command, const fs::path& log) {
  SpawnOptions options;
  options.log_path = log.string();
  const auto pid = spawnProcess(command, options);
  if (!pid.isOk()) {
    std::fprintf(stderr, "[sweep] %s\n", pid.status().message().c_str());
    return -1;
  }
  return waitProcess(*pid, -1).value_or(-1);
}

// The numbers a live run's report.json gives (nlohmann throws on a field
// it lacks).
void readLiveReport(const nlohmann::json& report, LiveMeasure& live) {
  const auto& e2e = report.at("latency_ms").at("end_to_end");
  live.end_to_end_ms_p50 = e2e.at("p50").get<double>();
  live.end_to_end_ms_p95 = e2e.at("p95").get<double>();
  live.fps = report.value("fps", 0.0);
  live.stage_ms_p95["end_to_end"] = live.end_to_end_ms_p95;
  for (const auto& [stage, numbers] : report.at("latency_ms").at("stages").items()) {
    if (numbers.value("samples", 0) > 0) live.stage_ms_p95[stage] = numbers.at("p95").get<double>();
  }
  live.jitter_ms = report.value("jitter_ms", std::map<std::string, double>{});
}

// The point's live run, as the loop's report gives it; an error names the
// log when the loop fails or renders fewer frames than asked.
StatusOr<LiveMeasure> runLive(const SweepOptions& options, const std::string& knob,
                              const std::string& value, bool is_default) {
  const fs::path dir =
      fs::path(options.out_dir) / "live" / (is_default ? "default" : knob + "=" + value);
  std::error_code ec;
  fs::remove_all(dir, ec);
  fs::create_directories(dir, ec);
  if (ec) return Status(StatusCode::kIoError, dir.string() + ": " + ec.message());
  std::vector<std::string> command = {options.loop_program};
  for (auto& argument : liveArguments(options, knob, value)) command.push_back(std::move(argument));
  command.insert(command.end(),
                 {"--frames", std::to_string(options.live_frames), "--out", dir.string()});
  const fs::path log = dir / "loop.log";
  const int status = runLogged(command, log);
  const fs::path report_path = dir / "report.json";
  std::ifstream in(report_path);
  const auto report = nlohmann::json::parse(in, nullptr, false);
  const std::string run = "the live run of " + knob + "=" + value;
  if (status != 0 || report.is_discarded() || !report.contains("latency_ms")) {
    return Status(StatusCode::kIoError, run + " failed (exit status " + std::to_string(status) +
                                            "); see " + log.string());
  }
  LiveMeasure live;
  live.frames = report.value("frames_rendered", 0);
  if (live.frames != options.live_frames) {
    return Status(StatusCode::kIoError, run + " rendered " + std::to_string(live.frames) + " of " +
                                            std::to_string(options.live_frames) + " frames; see " +
                                            log.string());
  }
  // (The loop's own report: a field it lacks is a report of another
  // version, named as such.)
  try {
    readLiveReport(report, live);
  } catch (const nlohmann::json::exception& e) {
    return Status(StatusCode::kIoError,
                  report_path.string() + " is not a report this sweep reads: " + e.what());
  }
  live.report = report_path.string();
  return live;
}

// A point is on disk whole or not at all: a write that fails (a full
// disk) leaves the point as it was and stops the sweep, naming the file.
Status writePoint(const fs::path& path, const nlohmann::json& file) {
  const Status written = writeTextFile(path.string(), file.dump(2));
  if (written.isOk()) return written;
  return Status(written.code(), written.message() + "; the points before it are kept");
}

StatusOr<std::vector<SweepPoint>> sweepPoints(
    const SweepOptions& options, const std::function<void(const std::string&)>& progress) {
  // Points already on disk must match this run before any work starts.
  for (const auto& [name, values] : options.knobs) {
    for (const auto& value : values) {
      const PlannedPoint plan = planPoint(options, *findKnob(name), value);
      if (fs::exists(plan.path)) HOLOFUSE_RETURN_IF_ERROR(readPoint(plan).status());
    }
  }
  std::error_code ec;
  fs::create_directories(fs::path(options.out_dir) / "points", ec);
  if (ec) return Status(StatusCode::kIoError, options.out_dir + ": " + ec.message());
  std::vector<SweepPoint> points;
  size_t done = 0, total = 0;
  for (const auto& [name, values] : options.knobs) total += values.size();
  Eta eta;
  for (const auto& [name, values] : options.knobs) {
    const Knob& knob = *findKnob(name);
    for (const auto& value : values) {
      SweepPoint point;
      point.knob = name;
      point.value = value;
      const PlannedPoint plan = planPoint(options, knob, value);
      point.is_default = plan.is_default;
      bool eta_step = false;  // measured here, not read back
      nlohmann::json file;
      if (fs::exists(plan.path)) {
        HOLOFUSE_ASSIGN_OR_RETURN(file, readPoint(plan));
        try {
          point.result =
              sceneResultFromJson(file.at("scene").get<std::string>(), file.at("result"));
        } catch (const nlohmann::json::exception& e) {
          return invalid(plan.path.string() + " holds no result this sweep reads (" + e.what() +
                         "); remove it to measure it again");
        }
        point.resumed = true;
      } else {
        eta_step = true;
        HOLOFUSE_ASSIGN_OR_RETURN(std::vector<SceneResult> results, runLeaveOneOut(plan.run));
        point.result = std::move(results.at(0));
        file = {{"knob", name},
                {"value", value},
                {"scene", point.result.name},
                {"settings", runSettings(plan.run)},
                {"result", sceneResultJson(point.result)}};
        // Written before the live run, which an interruption or a failed
        // loop must not take the leave-one-out result down with.
        HOLOFUSE_RETURN_IF_ERROR(writePoint(plan.path, file));
      }
      // A live run is kept with its point, and reused when it rendered the
      // frames this run asks for.
      if (options.live_frames > 0) {
        const auto kept = file.find("live");
        // (A live run kept before its stages and jitter were is run again.)
        if (kept != file.end() && kept->value("frames_asked", 0) == options.live_frames &&
            kept->contains("stage_ms_p95")) {
          point.live = liveFromJson(*kept);
        }
        if (!point.live) {
          if (progress) {
            progress("running " + name + "=" + value + " live for " +
                     std::to_string(options.live_frames) + " frames");
          }
          HOLOFUSE_ASSIGN_OR_RETURN(point.live, runLive(options, name, value, plan.is_default));
          eta_step = true;
          file["live"] = liveJson(*point.live, options.live_frames);
          HOLOFUSE_RETURN_IF_ERROR(writePoint(plan.path, file));
        }
      }
      ++done;
      if (eta_step) eta.stepDone();
      if (progress) {
        const auto& m = point.result.modes.at(primaryMode(options.base));
        char line[240];
        std::snprintf(line, sizeof(line),
                      "[%zu/%zu] %s=%s%s: PSNR %.2f dB, SSIM %.4f, client %.0f ms, %.0f KB/frame",
                      done, total, name.c_str(), value.c_str(),
                      point.resumed ? " (already on disk)" : "", m.psnr_db, m.ssim,
                      m.ms_per_new_mesh, clientBytes(point.result, m) / 1000.0);
        std::string text = line;
        if (point.live) {
          std::snprintf(line, sizeof(line), "; live end-to-end p50 %.0f ms, p95 %.0f ms, %.1f fps",
                        point.live->end_to_end_ms_p50, point.live->end_to_end_ms_p95,
                        point.live->fps);
          text += line;
        }
        if (done < total && !eta.text(total - done).empty()) text += "; " + eta.text(total - done);
        progress(text);
      }
      points.push_back(std::move(point));
    }
  }
  return points;
}

}  // namespace

StatusOr<std::vector<SweepPoint>> runSweep(
    const SweepOptions& options, const std::function<void(const std::string&)>& progress) {
  if (options.knobs.empty()) return invalid("no --knob given; knobs: " + knobNames());
  if (options.base.scenes.size() + options.base.datasets.size() != 1) {
    return invalid("a sweep runs on exactly one scene or one dataset");
  }
  // Every knob and value is checked before the first (long) point runs.
  std::set<std::string> named;
  for (const auto& [name, values] : options.knobs) {
    const Knob* knob = findKnob(name);
    if (knob == nullptr) return invalid("unknown knob '" + name + "'; knobs: " + knobNames());
    if (!named.insert(name).second) {
      return invalid("knob '" + name + "' is given twice; list all its values in one --knob " +
                     name + "=v1,v2,...");
    }
    if (values.empty()) return invalid("knob '" + name + "' has no values");
    if (knob->synthetic_only && !options.base.datasets.empty()) {
      return invalid("knob '" + name +
                     "' needs a synthetic scene: a dataset's cameras and image size "
                     "are the recorded ones");
    }
    for (const auto& value : values) {
      EvalOptions probe = options.base;
      const std::string error = knob->apply(probe, value);
      if (!error.empty()) return invalid("knob " + name + ": " + error);
    }
  }
  // The report places the default against the other values: a knob swept
  // without it gets it too (one run shared by every knob, points/default.json).
  SweepOptions swept = options;
  if (!swept.base.datasets.empty() && swept.base.voxel_from_dataset) {
    // The dataset's own voxel is the default point's, by number.
    auto dataset = dataset::Dataset::open(swept.base.datasets.front());
    if (!dataset.isOk()) return invalid(dataset.status().message());
    swept.base.loop.fusion.hull.voxel_size =
        dataset::hullOptionsFor(*dataset, swept.base.loop.fusion.hull.voxel_size).voxel_size;
    swept.base.voxel_from_dataset = false;
  }
  for (auto& [name, values] : swept.knobs) {
    const Knob& knob = *findKnob(name);
    bool has_default = false;
    for (const auto& value : values)
      has_default = has_default || planPoint(swept, knob, value).is_default;
    if (!has_default) values.push_back(knob.current(swept.base));
  }
  return sweepPoints(swept, progress);
}

PointBudget checkPointBudget(const protocol::Budget& budget, const SweepPoint& point,
                             const std::string& mode) {
  PointBudget out;
  out.checks = checkBudget(budget, point.result, {mode});
  const std::vector<std::string> timed = budgetedStages();
  for (const auto& [stage, ms] : budget) {
    if (std::find(timed.begin(), timed.end(), stage) != timed.end()) continue;
    if (point.live) {
      if (const auto live = point.live->stage_ms_p95.find(stage);
          live != point.live->stage_ms_p95.end()) {
        out.checks.push_back({"live", stage, live->second, ms});
        continue;
      }
    }
    out.unchecked.push_back(stage);
  }
  return out;
}

NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(LiveMeasure, frames, end_to_end_ms_p50,
                                                end_to_end_ms_p95, fps, stage_ms_p95, jitter_ms,
                                                report)

nlohmann::json liveJson(const LiveMeasure& live, int frames_asked) {
  nlohmann::json j = live;
  j["frames_asked"] = frames_asked;
  return j;
}

std::optional<LiveMeasure> liveFromJson(const nlohmann::json& j) {
  // (nlohmann throws on a field of the wrong type: a damaged file.)
  try {
    return j.get<LiveMeasure>();
  } catch (const nlohmann::json::exception&) {
    return std::nullopt;
  }
}

// The worst pod's jitter of a live run, or -1 without one.
double worstJitterMs(const std::optional<LiveMeasure>& live) {
  double worst = -1;
  if (live) {
    for (const auto& [pod, ms] : live->jitter_ms) worst = std::max(worst, ms);
  }
  return worst;
}

// The live loop's flags for a point: the scene, the mode, every knob the
// base moved from its default, and the point's own.
std::vector<std::string> liveArguments(const SweepOptions& options, const std::string& knob,
                                       const std::string& value) {
  EvalOptions defaults;
  defaults.scenes = options.base.scenes;
  defaults.datasets = options.base.datasets;
  // A dataset replays through the same network path, over and over until
  // the frames asked for are rendered.
  std::vector<std::string> arguments =
      options.base.datasets.empty()
          ? std::vector<std::string>{"--scene", options.base.scenes.at(0), "--mode",
                                     primaryMode(options.base)}
          : std::vector<std::string>{"--replay", options.base.datasets.at(0), "--loop", "--mode",
                                     primaryMode(options.base)};
  for (const Knob& other : sweepKnobs()) {
    if (other.name != knob && other.current(options.base) != other.current(defaults)) {
      arguments.insert(arguments.end(), {other.loop_flag, other.current(options.base)});
    }
  }
  arguments.insert(arguments.end(), {findKnob(knob)->loop_flag, value});
  return arguments;
}

}  // namespace holofuse::eval

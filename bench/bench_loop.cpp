// ./holofuse bench loop: the live loop end to end, as a user runs it. For
// each mode, the launcher (holofuse_loop: pods, server and a client as
// real processes on loopback) runs N frames, several times; each run's
// report.json gives fps, end-to-end latency and every stage's p50 and p95,
// and the medians over the runs are printed as a table, and written as
// bench_loop.json, bench_loop.md and bench_loop.html (charts) with the
// settings. --baseline DIR sets an earlier run's numbers beside them.
//   bench_loop [--modes M,N] [--frames F] [--repeats R] [--out DIR]
//              [--baseline DIR] [-- flags of holofuse_loop ...]
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "base/process.h"
#include "base/text_file.h"
#include "bench_timing.h"
#include "loop_run.h"
#include "report/html.h"

namespace fs = std::filesystem;
using nlohmann::ordered_json;
using namespace holofuse;

namespace {

// The targets of a live loop that feels live on this machine: ITU-T
// G.114's 150 ms one way, and interactive rates.
constexpr double kMontage4dFps = 10, kMontage4dP95Ms = 150, kNormalFps = 15;
// A stage whose p95 is past twice its p50 is uneven; under a millisecond
// the scheduler's slice on two shared cores is all the spread there is.
constexpr double kSpreadRatio = 2, kSpreadFloorMs = 1;

struct Numbers {
  double p50 = 0, p95 = 0;
};

struct Run {
  double fps = 0;
  Numbers end_to_end;
  std::vector<std::pair<std::string, Numbers>> stages;  // the report's order, sampled ones
};

struct ModeSummary {
  std::string mode;
  std::vector<Run> runs;
  double fps = 0;
  Numbers end_to_end;
  std::vector<std::pair<std::string, Numbers>> stages;  // medians over the runs
};

std::optional<Run> readRun(const ordered_json& report, const fs::path& report_path,
                           std::string* error) {
  Run run;
  try {
    run.fps = report.at("fps").get<double>();
    const auto& latency = report.at("latency_ms");
    run.end_to_end = {latency.at("end_to_end").at("p50").get<double>(),
                      latency.at("end_to_end").at("p95").get<double>()};
    for (const auto& [stage, numbers] : latency.at("stages").items()) {
      if (numbers.value("samples", 0) == 0) continue;
      run.stages.push_back(
          {stage, {numbers.at("p50").get<double>(), numbers.at("p95").get<double>()}});
    }
  } catch (const nlohmann::json::exception& e) {
    *error = report_path.string() + " is not a report bench_loop reads: " + e.what();
    return std::nullopt;
  }
  return run;
}

void summarise(ModeSummary& mode) {
  std::vector<double> fps, p50, p95;
  for (const Run& run : mode.runs) {
    fps.push_back(run.fps);
    p50.push_back(run.end_to_end.p50);
    p95.push_back(run.end_to_end.p95);
  }
  mode.fps = bench::median(fps);
  mode.end_to_end = {bench::median(p50), bench::median(p95)};
  mode.stages.clear();
  for (const auto& [stage, unused] : mode.runs.front().stages) {
    std::vector<double> a, b;
    for (const Run& run : mode.runs) {
      for (const auto& [name, numbers] : run.stages) {
        if (name != stage) continue;
        a.push_back(numbers.p50);
        b.push_back(numbers.p95);
      }
    }
    mode.stages.push_back({stage, {bench::median(a), bench::median(b)}});
  }
}

ordered_json toJson(const ModeSummary& mode) {
  ordered_json j;
  j["fps"] = mode.fps;
  j["end_to_end"] = {{"p50", mode.end_to_end.p50}, {"p95", mode.end_to_end.p95}};
  for (const auto& [stage, n] : mode.stages) j["stages"][stage] = {{"p50", n.p50}, {"p95", n.p95}};
  for (const Run& run : mode.runs) {
    j["runs"].push_back(
        {{"fps", run.fps},
         {"end_to_end", {{"p50", run.end_to_end.p50}, {"p95", run.end_to_end.p95}}}});
  }
  return j;
}

ModeSummary fromJson(const std::string& name, const ordered_json& j) {
  ModeSummary mode;
  mode.mode = name;
  mode.fps = j.at("fps").get<double>();
  mode.end_to_end = {j.at("end_to_end").at("p50").get<double>(),
                     j.at("end_to_end").at("p95").get<double>()};
  for (const auto& [stage, n] : j.at("stages").items())
    mode.stages.push_back({stage, {n.at("p50").get<double>(), n.at("p95").get<double>()}});
  return mode;
}

// "now" or "before -> now" when a baseline has the value.
std::string beside(std::optional<double> before, double now, const char* format = "%.1f") {
  return before ? html::number(format, *before) + " -> " + html::number(format, now)
                : html::number(format, now);
}

std::optional<Numbers> stageOf(const ModeSummary* mode, const std::string& stage) {
  if (mode == nullptr) return std::nullopt;
  for (const auto& [name, n] : mode->stages)
    if (name == stage) return n;
  return std::nullopt;
}

// An earlier run's medians per mode (--baseline's bench_loop.json); false,
// said why, when it has none.
bool readBaseline(const std::string& baseline, std::map<std::string, ModeSummary>& before) {
  std::ifstream in(fs::path(baseline) / "bench_loop.json");
  const auto j = ordered_json::parse(in, nullptr, false);
  if (j.is_discarded() || !j.contains("modes")) {
    std::fprintf(stderr, "--baseline %s: no bench_loop.json there\n", baseline.c_str());
    return false;
  }
  try {
    for (const auto& [name, mode] : j.at("modes").items()) before[name] = fromJson(name, mode);
  } catch (const nlohmann::json::exception& e) {
    std::fprintf(stderr, "--baseline %s: bench_loop.json unreadable: %s\n", baseline.c_str(),
                 e.what());
    return false;
  }
  return true;
}

// The page: fps and end to end per mode, and where each mode's time goes
// (stage p50s), beside the baseline's when given; then the tables.
std::string chartsPage(const std::string& intro, const std::vector<ModeSummary>& results,
                       const std::map<std::string, ModeSummary>& before,
                       const std::vector<std::string>& stages, const html::Table& summary_table,
                       const html::Table& stage_table, const std::string& verdicts) {
  std::vector<std::string> mode_names;
  html::Series fps_now{"now", {}}, fps_before{"baseline", {}};
  html::Series p50_now{"p50", {}}, p95_now{"p95", {}};
  std::vector<html::StackRow> stacks;
  for (const ModeSummary& m : results) {
    mode_names.push_back(m.mode);
    fps_now.values.push_back(m.fps);
    fps_before.values.push_back(before.count(m.mode) ? before.at(m.mode).fps : std::nan(""));
    p50_now.values.push_back(m.end_to_end.p50);
    p95_now.values.push_back(m.end_to_end.p95);
    const ModeSummary* earlier = before.count(m.mode) ? &before.at(m.mode) : nullptr;
    for (const ModeSummary* s : {&m, earlier}) {
      if (s == nullptr) continue;
      html::StackRow row{m.mode + (s == &m ? "" : " (baseline)"), {}, std::nullopt, ""};
      for (const std::string& stage : stages)
        row.segments.push_back(stageOf(s, stage) ? stageOf(s, stage)->p50 : 0.0);
      stacks.push_back(row);
    }
  }
  std::vector<html::Series> fps_series = {fps_now};
  if (!before.empty()) fps_series.push_back(fps_before);
  return "<p>" + html::escape(intro) + "</p>\n" +
         html::barChart("Frames per second", mode_names, fps_series, "fps") +
         html::barChart("End-to-end latency", mode_names, {p50_now, p95_now}, "ms") +
         html::stackedBars("Where the time goes (stage p50)", stages, stacks, "ms") +
         html::table(summary_table) + html::table(stage_table) + "<pre>" + html::escape(verdicts) +
         "</pre>\n";
}

// The targets, said plainly: each mode's fps and end to end against its
// target, and the stages whose p95 is far above their p50.
std::string targetVerdicts(const std::vector<ModeSummary>& results,
                           const std::vector<std::string>& uneven) {
  std::string verdicts;
  for (const ModeSummary& m : results) {
    if (m.mode == "montage4d") {
      verdicts +=
          "- montage4d: " + html::number("%.1f", m.fps) +
          " fps (target >= " + html::number("%.0f", kMontage4dFps) + "), end-to-end p95 " +
          html::number("%.0f", m.end_to_end.p95) +
          " ms (target <= " + html::number("%.0f", kMontage4dP95Ms) + "): " +
          (m.fps >= kMontage4dFps && m.end_to_end.p95 <= kMontage4dP95Ms ? "met" : "missed") + "\n";
    }
    if (m.mode == "normal") {
      verdicts += "- normal: " + html::number("%.1f", m.fps) +
                  " fps (target >= " + html::number("%.0f", kNormalFps) +
                  "): " + (m.fps >= kNormalFps ? "met" : "missed") + "\n";
    }
  }
  std::string spread_text;
  for (const auto& u : uneven) spread_text += (spread_text.empty() ? "" : ", ") + u;
  verdicts += "- stages with p95 over " + html::number("%.0f", kSpreadRatio) +
              "x their p50 (p95 of " + html::number("%.0f", kSpreadFloorMs) +
              " ms or more): " + (uneven.empty() ? std::string("none") : spread_text) + "\n";
  return verdicts;
}

}  // namespace

int main(int argc, char** argv) {
  // Everything after "--" goes to holofuse_loop as it is.
  std::vector<std::string> loop_flags;
  int own_argc = argc;
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) != "--") continue;
    loop_flags.assign(argv + i + 1, argv + argc);
    own_argc = i;
    break;
  }
  std::string modes_text = "normal,holoportation,montage4d", out = "out/bench-loop", baseline;
  int frames = 60, repeats = 3;
  CLI::App app{"bench_loop: the live loop per mode, end to end and stage by stage"};
  app.add_option("--modes", modes_text, "modes to run, comma separated");
  app.add_option("--frames", frames, "frames each run renders")->check(CLI::Range(4, 100000));
  app.add_option("--repeats", repeats, "runs per mode (medians are reported)")
      ->check(CLI::Range(1, 50));
  app.add_option("--out", out, "where the runs and bench_loop.{json,md,html} go");
  app.add_option("--baseline", baseline, "an earlier bench_loop --out folder to compare with");
  try {
    app.parse(own_argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  std::vector<std::string> modes;
  for (size_t start = 0; start <= modes_text.size();) {
    const size_t comma = std::min(modes_text.find(',', start), modes_text.size());
    if (comma > start) modes.push_back(modes_text.substr(start, comma - start));
    start = comma + 1;
  }
  std::map<std::string, ModeSummary> before;
  if (!baseline.empty() && !readBaseline(baseline, before)) return 2;

  std::vector<ModeSummary> results;
  const int total = static_cast<int>(modes.size()) * repeats;
  int done = 0;
  for (const std::string& mode : modes) {
    ModeSummary summary;
    summary.mode = mode;
    for (int r = 0; r < repeats; ++r) {
      const fs::path dir = fs::path(out) / "runs" / (mode + "-" + std::to_string(r + 1));
      std::vector<std::string> command = {"--mode", mode, "--frames", std::to_string(frames)};
      command.insert(command.end(), loop_flags.begin(), loop_flags.end());
      std::fprintf(stderr, "\r[bench loop] %d/%d: %s, run %d of %d   ", done + 1, total,
                   mode.c_str(), r + 1, repeats);
      std::string error;
      const auto report = bench::runLoop(command, dir, &error);
      const auto run = report ? readRun(*report, dir / "report.json", &error) : std::nullopt;
      if (!run) {
        std::fprintf(stderr, "\n[bench loop] %s run %d failed: %s\n", mode.c_str(), r + 1,
                     error.c_str());
        return 1;
      }
      summary.runs.push_back(*run);
      ++done;
    }
    summarise(summary);
    results.push_back(std::move(summary));
  }
  std::fprintf(stderr, "\n");

  // The table: per mode, fps and end to end, then each stage.
  std::string flags_text;
  for (const auto& flag : loop_flags) flags_text += " " + flag;
  const std::string intro =
      "`bench_loop --modes " + modes_text + " --frames " + std::to_string(frames) + " --repeats " +
      std::to_string(repeats) + (flags_text.empty() ? "" : " --" + flags_text) +
      "`: each mode's loop (the demo's settings" +
      (flags_text.empty() ? std::string() : ", with" + flags_text) + ") run " +
      std::to_string(repeats) + " times; medians over the runs, ms" +
      (baseline.empty() ? "" : "; `before -> now` against " + baseline) + ".";
  std::string md = "# The live loop, end to end\n\n" + intro + "\n\n";
  html::Table summary_table{{"mode", "fps", "end-to-end p50", "end-to-end p95"}, {}, "lrrr"};
  for (const ModeSummary& m : results) {
    const ModeSummary* b = before.count(m.mode) ? &before.at(m.mode) : nullptr;
    summary_table.rows.push_back(
        {m.mode, beside(b ? std::optional(b->fps) : std::nullopt, m.fps),
         beside(b ? std::optional(b->end_to_end.p50) : std::nullopt, m.end_to_end.p50),
         beside(b ? std::optional(b->end_to_end.p95) : std::nullopt, m.end_to_end.p95)});
  }
  md += html::markdownTable(summary_table) + "\n";
  // A row per stage any mode sampled, in the report's order.
  std::vector<std::string> stages;
  for (const ModeSummary& m : results)
    for (const auto& [stage, unused] : m.stages)
      if (std::find(stages.begin(), stages.end(), stage) == stages.end()) stages.push_back(stage);
  html::Table stage_table{{"stage"}, {}, "l"};
  for (const ModeSummary& m : results) {
    stage_table.header.push_back(m.mode + " p50");
    stage_table.header.push_back(m.mode + " p95");
  }
  std::vector<std::string> uneven;
  for (const std::string& stage : stages) {
    std::vector<std::string> row = {stage};
    for (const ModeSummary& m : results) {
      const auto now = stageOf(&m, stage);
      const auto was = stageOf(before.count(m.mode) ? &before.at(m.mode) : nullptr, stage);
      if (!now) {
        row.insert(row.end(), {"-", "-"});
        continue;
      }
      row.push_back(beside(was ? std::optional(was->p50) : std::nullopt, now->p50));
      row.push_back(beside(was ? std::optional(was->p95) : std::nullopt, now->p95));
      if (now->p95 > kSpreadRatio * now->p50 && now->p95 >= kSpreadFloorMs)
        uneven.push_back(m.mode + " " + stage + " (" + html::number("%.1f", now->p95 / now->p50) +
                         "x)");
    }
    stage_table.rows.push_back(row);
  }
  md += html::markdownTable(stage_table) + "\n";
  const std::string verdicts = targetVerdicts(results, uneven);
  md += "## Targets\n\n" + verdicts;
  std::fputs(md.c_str(), stdout);

  const std::string body =
      chartsPage(intro, results, before, stages, summary_table, stage_table, verdicts);
  ordered_json json;
  json["command"] = {
      {"modes", modes}, {"frames", frames}, {"repeats", repeats}, {"loop_flags", loop_flags}};
  for (const ModeSummary& m : results) json["modes"][m.mode] = toJson(m);
  json["uneven_stages"] = uneven;
  for (const auto& [name, text] : std::vector<std::pair<std::string, std::string>>{
           {"bench_loop.json", json.dump(2)},
           {"bench_loop.md", md},
           {"bench_loop.html", html::page("holofuse bench loop", body)}}) {
    const Status written = writeTextFile((fs::path(out) / name).string(), text);
    if (!written.isOk()) {
      std::fprintf(stderr, "%s\n", written.toString().c_str());
      return 1;
    }
  }
  std::fprintf(stderr, "[bench loop] wrote %s/bench_loop.{json,md,html}\n", out.c_str());
  return 0;
}

// sweep.json, sweep.md and sweep.html: every point's quality and costs,
// the Pareto front, the default's place on it, and the charts.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>

#include "base/text_file.h"
#include "common/html_report.h"
#include "eval/sweep.h"
#include "result_json.h"
#include "sweep_live.h"

namespace holofuse::eval {
namespace {

namespace fs = std::filesystem;

// The live loop with one knob set as a sweep point had it, and the rest as
// the sweep's base has them (the defaults, or what --set moved).
std::string liveCommand(const SweepOptions& options, const std::string& knob,
                        const std::string& value) {
  std::string command = "./holofuse demo";
  for (const auto& argument : liveArguments(options, knob, value)) command += " " + argument;
  return command;
}

}  // namespace

std::string sweptSubject(const SweepOptions& options) {
  return options.base.datasets.empty() ? options.base.scenes.at(0) : options.base.datasets.at(0);
}

Status writeSweepReports(const SweepOptions& options, const std::vector<SweepPoint>& points) {
  const std::string mode = primaryMode(options.base);
  nlohmann::json json;
  json[options.base.datasets.empty() ? "scene" : "dataset"] = sweptSubject(options);
  json["quality_mode"] = mode;
  json["pipeline_ms"] =
      "hull + codecs + client ms per new mesh: the per-frame work the knobs move (transport not "
      "included)";
  std::string md =
      "# Sweep\n\n" + std::string(options.base.datasets.empty() ? "Scene" : "Dataset") + " `" +
      sweptSubject(options) + "`, quality of `" + mode +
      "` (leave-one-camera-out), one knob at a time around the defaults. Pipeline ms: the hull, "
      "the "
      "codecs (" +
      std::string(kCodecsMeaning) +
      ") and the client's render per new mesh. Front: no "
      "other value of the knob is at least as good in PSNR, client ms, pipeline ms and bytes per "
      "frame on "
      "both links at once and better in one beyond noise (points are measured one after another): "
      "times by more than 10% and more than either point's p50-to-p95 spread, PSNR by more than "
      "0.01 dB, bytes by more than 0.5%. Flicker and Chamfer are shown, not judged. Live "
      "end-to-end ms "
      "(with --live-frames): the live loop run with the point's settings, capture to written "
      "frame, "
      "network and queues included; judged too where every value of the knob ran live. Live "
      "jitter: the worst "
      "pod's RFC 3550 arrival jitter at the server in that run; the leave-one-out runs have no "
      "network, "
      "so a point not run live has none.\n\n";
  std::string body;
  // The other modes asked for, at the default point: what the swept
  // mode's quality and bytes are to be read against (mode layered's
  // targets are the camera images' picture and bytes, in mode normal).
  const auto default_point =
      std::find_if(points.begin(), points.end(), [](const SweepPoint& p) { return p.is_default; });
  if (default_point != points.end() && default_point->result.modes.size() > 1) {
    std::string beside;
    for (const auto& [other, m] : default_point->result.modes) {
      if (other == mode) continue;
      char text[160];
      std::snprintf(text, sizeof(text), "%s`%s` %.2f dB PSNR, SSIM %.4f, %.0f KB/frame to client",
                    beside.empty() ? "" : "; ", other.c_str(), m.psnr_db, m.ssim,
                    clientBytes(default_point->result, m) / 1000.0);
      beside += text;
      json["other_modes_at_default"][other] = {
          {"psnr_db", m.psnr_db},
          {"ssim", m.ssim},
          {"bytes_per_frame", clientBytes(default_point->result, m)}};
    }
    md += "Beside it, at the default point: " + beside + ".\n\n";
    body += "<p>Beside it, at the default point: " + html::escape(beside) + ".</p>\n";
  }
  std::set<std::string> unchecked;  // budgeted stages some point could not hold against its budget
  std::vector<std::vector<std::string>> rows;
  for (const auto& [name, values] : options.knobs) {
    std::vector<const SweepPoint*> mine;
    for (const auto& p : points) {
      if (p.knob == name) mine.push_back(&p);
    }
    // Each point's quality against its costs: client ms, pipeline ms and
    // bytes on each link, alone (the plots) and together (the front).
    // Run live (--live-frames), the loop's end-to-end time is one more cost.
    const bool all_live = std::all_of(mine.begin(), mine.end(),
                                      [](const SweepPoint* p) { return p->live.has_value(); });
    std::vector<TradePoint> by_client, by_pipeline, by_bytes, by_pod_bytes, by_live, by_all;
    for (const SweepPoint* p : mine) {
      const ModeResult& m = p->result.modes.at(mode);
      const Cost client = timeCost(m.ms_per_new_mesh, m.ms_per_new_mesh_p95);
      const Cost pipeline =
          timeCost(pipelineMs(p->result, mode), pipelineMs(p->result, mode, true));
      const Cost bytes = bytesCost(clientBytes(p->result, m));
      const Cost pod_bytes = bytesCost(p->result.pod_link_bytes_per_frame);
      by_client.push_back({m.psnr_db, {client}});
      by_pipeline.push_back({m.psnr_db, {pipeline}});
      by_bytes.push_back({m.psnr_db, {bytes}});
      by_pod_bytes.push_back({m.psnr_db, {pod_bytes}});
      by_all.push_back({m.psnr_db, {client, pipeline, bytes, pod_bytes}});
      if (all_live) {
        const Cost end_to_end = timeCost(p->live->end_to_end_ms_p50, p->live->end_to_end_ms_p95);
        by_live.push_back({m.psnr_db, {end_to_end}});
        by_all.back().costs.push_back(end_to_end);
      }
    }
    auto dominator = [&](size_t i) {
      for (size_t j = 0; j < mine.size(); ++j) {
        if (j != i && dominates(by_all[j], by_all[i])) return static_cast<int>(j);
      }
      return -1;
    };
    auto onFront = [&](size_t i) { return dominator(i) < 0; };
    // Where the default stands: on the front, or dominated by which point.
    std::string verdict = "the default is not among the values swept";
    for (size_t i = 0; i < mine.size(); ++i) {
      if (!mine[i]->is_default) continue;
      const int j = dominator(i);
      verdict = "the default (" + name + "=" + mine[i]->value + ") is " +
                (j < 0 ? std::string("on the Pareto front")
                       : "dominated by " + name + "=" + mine[static_cast<size_t>(j)]->value);
    }
    nlohmann::json& k = json["knobs"][name];
    k["default_verdict"] = verdict;
    html::Table knob_table{{"value", "PSNR dB", "SSIM", "flicker", "Chamfer mm", "client ms",
                            "pipeline ms", "live end-to-end ms", "live jitter ms (worst pod)",
                            "KB/frame to client", "pods KB/frame", "front", "over budget"},
                           {},
                           "lrrrrrrrrrrll"};
    for (size_t i = 0; i < mine.size(); ++i) {
      const SweepPoint& p = *mine[i];
      const ModeResult& m = p.result.modes.at(mode);
      // The stages over the budget (--budget) at this point's p95: the
      // leave-one-out run's, then the live run's for the rest.
      std::string over;
      nlohmann::json violations = nlohmann::json::array();
      const PointBudget point_budget = checkPointBudget(options.base.budget, p, mode);
      for (const BudgetCheck& check : point_budget.checks) {
        if (!check.over()) continue;
        char text[112];
        std::snprintf(text, sizeof(text), "%s%s %.1f > %.1f ms",
                      check.mode == "live" ? "live " : "", check.stage.c_str(), check.p95_ms,
                      check.budget_ms);
        over += (over.empty() ? "" : ", ") + std::string(text);
        violations.push_back({{"stage", check.stage},
                              {"measured", check.mode == "live" ? "live loop" : "leave-one-out"},
                              {"p95_ms", check.p95_ms},
                              {"budget_ms", check.budget_ms}});
      }
      for (const auto& stage : point_budget.unchecked) unchecked.insert(stage);
      k["points"].push_back(
          {{"value", p.value},
           {"is_default", p.is_default},
           {"psnr_db", m.psnr_db},
           {"ssim", m.ssim},
           {"flicker", measuredJson(m.flicker)},
           {"chamfer_mm", measuredJson(p.result.chamfer_mm)},
           {"client_ms", m.ms_per_new_mesh},
           {"client_ms_p95", m.ms_per_new_mesh_p95},
           {"pipeline_ms", pipelineMs(p.result, mode)},
           {"pipeline_ms_p95", pipelineMs(p.result, mode, true)},
           {"bytes_per_frame", clientBytes(p.result, m)},
           {"pod_link_bytes_per_frame", p.result.pod_link_bytes_per_frame},
           {"on_front", onFront(i)},
           {"budget_violations", violations},
           {"budget_unchecked", point_budget.unchecked},
           {"live_worst_pod_jitter_ms", measuredJson(worstJitterMs(p.live))},
           {"live_command", liveCommand(options, name, p.value)},
           {"live", p.live ? liveJson(*p.live, options.live_frames) : nlohmann::json()},
           {"result", sceneResultJson(p.result)}});
      char cells[6][32];
      std::snprintf(cells[0], sizeof(cells[0]), "%.2f", m.psnr_db);
      std::snprintf(cells[1], sizeof(cells[1]), "%.4f", m.ssim);
      std::snprintf(cells[2], sizeof(cells[2]), "%.1f", m.ms_per_new_mesh);
      std::snprintf(cells[3], sizeof(cells[3]), "%.1f", pipelineMs(p.result, mode));
      std::snprintf(cells[4], sizeof(cells[4]), "%.0f", clientBytes(p.result, m) / 1000.0);
      std::snprintf(cells[5], sizeof(cells[5]), "%.0f", p.result.pod_link_bytes_per_frame / 1000.0);
      char live_cell[48] = "not run";
      if (p.live) {
        std::snprintf(live_cell, sizeof(live_cell), "%.0f (p95 %.0f)", p.live->end_to_end_ms_p50,
                      p.live->end_to_end_ms_p95);
      }
      const std::string jitter_cell =
          p.live ? measuredText(worstJitterMs(p.live), "%.2f") : "not run";
      const std::vector<std::string> row = {p.value + (p.is_default ? " (default)" : ""),
                                            cells[0],
                                            cells[1],
                                            measuredText(m.flicker, "%.2f"),
                                            measuredText(p.result.chamfer_mm, "%.1f"),
                                            cells[2],
                                            cells[3],
                                            live_cell,
                                            jitter_cell,
                                            cells[4],
                                            cells[5],
                                            onFront(i) ? "yes" : "",
                                            over};
      knob_table.rows.push_back(row);
      rows.push_back(row);
      rows.back().insert(rows.back().begin(), (over.empty() ? "" : "!") + name);  // "!": flagged
    }
    md += "## " + name + "\n\n" + html::markdownTable(knob_table);
    const std::string live = liveCommand(options, name, "VALUE");
    md += "\n" + verdict + ". A value in the live loop: `" + live + "`.\n\n";
    auto plot = [&](const std::vector<TradePoint>& trade, const std::string& title,
                    const std::string& x) {
      const auto f = paretoFront(trade);
      std::vector<html::Point> marks;
      for (size_t i = 0; i < mine.size(); ++i) {
        marks.push_back({name + "=" + mine[i]->value, trade[i].costs.at(0).p50, trade[i].psnr_db,
                         std::find(f.begin(), f.end(), i) != f.end(), mine[i]->is_default});
      }
      return html::scatterChart(title, x, "PSNR dB", marks);
    };
    body += "<h2>" + html::escape(name) + "</h2>\n<p>" + html::escape(findKnob(name)->meaning) +
            ". " + html::escape(verdict) +
            ". Filled: the Pareto front of each plot's pair; red ring: the default. A value in " +
            "the live loop: <code>" + html::escape(live) + "</code>.</p>\n";
    body += plot(by_client, "PSNR against client ms (" + name + ")", "client ms per new mesh");
    body +=
        plot(by_pipeline, "PSNR against pipeline ms (" + name + ")", "hull + codecs + client ms");
    body += plot(by_bytes, "PSNR against bytes per frame (" + name + ")",
                 "bytes per frame, server to client");
    body += plot(by_pod_bytes, "PSNR against pod bytes per frame (" + name + ")",
                 "bytes per frame, pods to server");
    if (all_live) {
      body += plot(by_live, "PSNR against live end-to-end ms (" + name + ")",
                   "end-to-end ms, capture to written frame, live loop");
    }
    // Where each value's pipeline time goes, p50 and p95 over its renders.
    std::vector<html::StackRow> stack;
    for (const SweepPoint* p : mine) {
      const ModeResult& m = p->result.modes.at(mode);
      stack.push_back({p->value + " p50", latencyParts(p->result, m, false)});
      stack.push_back({p->value + " p95", latencyParts(p->result, m, true)});
    }
    body += html::stackedBars("Latency of a new mesh by value (" + name + ")", latencyStages(),
                              stack, "ms");
  }
  if (!options.base.budget.empty()) {
    // Where each budgeted stage is measured, and which no point measured.
    std::string unchecked_text;
    for (const auto& stage : unchecked)
      unchecked_text += (unchecked_text.empty() ? "" : ", ") + stage;
    const std::string budget_text =
        "Budget: each point's p95 of " + budgetedStagesText() +
        " from its leave-one-out run, and of the other stages (end_to_end, upload, ...) from its "
        "live run (\"live\" "
        "in the table; --live-frames)." +
        (unchecked_text.empty()
             ? std::string()
             : " Not checked at some points (no live run, or no sample in it): " + unchecked_text +
                   ".");
    json["budget_ms"] = options.base.budget;
    json["budget_unchecked"] = unchecked;
    md += budget_text + "\n";
    body += "<p>" + html::escape(budget_text) + "</p>\n";
  }
  body += "<h2>All points</h2>\n" +
          html::table({"knob", "value", "PSNR dB", "SSIM", "flicker", "Chamfer mm", "client ms",
                       "pipeline ms", "live end-to-end ms", "live jitter ms (worst pod)",
                       "KB/frame to client", "pods KB/frame", "front", "over budget"},
                      rows);
  const fs::path out(options.out_dir);
  HOLOFUSE_RETURN_IF_ERROR(writeTextFile((out / "sweep.json").string(), json.dump(2) + "\n"));
  HOLOFUSE_RETURN_IF_ERROR(writeTextFile((out / "sweep.md").string(), md));
  return writeTextFile(
      (out / "sweep.html").string(),
      html::page("holofuse sweep: " + sweptSubject(options) + ", quality of " + mode, body));
}

}  // namespace holofuse::eval

// sweep.json, sweep.md and sweep.html: every point's quality and costs,
// the Pareto front, the default's place on it, and the charts.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>
#include <utility>

#include "base/text_file.h"
#include "eval/sweep.h"
#include "report/html.h"
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

namespace {

// The three documents as they are built, knob by knob.
struct SweepDocuments {
  nlohmann::json json;
  std::string md, body;
  std::vector<std::vector<std::string>> rows;  // every point, its knob first
  std::set<std::string> unchecked;  // budgeted stages some point could not hold against its budget
};

std::string sweepIntro(const SweepOptions& options, const std::string& mode) {
  return "# Sweep\n\n" + std::string(options.base.datasets.empty() ? "Scene" : "Dataset") + " `" +
         sweptSubject(options) + "`, quality of `" + mode +
         "` (leave-one-camera-out), one knob at a time around the defaults. Pipeline ms: the "
         "hull, the "
         "codecs (" +
         std::string(kCodecsMeaning) +
         ") and the client's render per new mesh. Front: no "
         "other value of the knob is at least as good in PSNR, SSIM, client ms, pipeline ms and "
         "bytes per frame on both links at once and better in one beyond noise (points are "
         "measured one after another): times by more than 10% and more than either point's "
         "p50-to-p95 spread, PSNR by more than 0.01 dB, SSIM by more than 0.001, bytes by more "
         "than 0.5%. Flicker and Chamfer are shown, not judged. Live "
         "end-to-end ms "
         "(with --live-frames): the live loop run with the point's settings, capture to written "
         "frame, "
         "network and queues included; judged too where every value of the knob ran live. Live "
         "jitter: the worst "
         "pod's RFC 3550 arrival jitter at the server in that run; the leave-one-out runs have no "
         "network, "
         "so a point not run live has none.\n\n";
}

// The other modes asked for, at the default point: what the swept mode's
// quality and bytes are to be read against (mode layered's targets are
// the camera images' picture and bytes, in mode normal).
void addOtherModes(const std::vector<SweepPoint>& points, const std::string& mode,
                   SweepDocuments& d) {
  const auto default_point =
      std::find_if(points.begin(), points.end(), [](const SweepPoint& p) { return p.is_default; });
  if (default_point == points.end() || default_point->result.modes.size() <= 1) return;
  std::string beside;
  for (const auto& [other, m] : default_point->result.modes) {
    if (other == mode) continue;
    char text[160];
    std::snprintf(text, sizeof(text), "%s`%s` %.2f dB PSNR, SSIM %.4f, %.0f KB/frame to client",
                  beside.empty() ? "" : "; ", other.c_str(), m.psnr_db, m.ssim,
                  clientBytes(default_point->result, m) / 1000.0);
    beside += text;
    d.json["other_modes_at_default"][other] = {
        {"psnr_db", m.psnr_db},
        {"ssim", m.ssim},
        {"bytes_per_frame", clientBytes(default_point->result, m)}};
  }
  d.md += "Beside it, at the default point: " + beside + ".\n\n";
  d.body += "<p>Beside it, at the default point: " + html::escape(beside) + ".</p>\n";
}

// One knob's points, each point's quality against its costs: client ms,
// pipeline ms and bytes on each link, alone (the plots) and together (the
// front). Run live (--live-frames), the loop's end-to-end time is one
// more cost.
struct KnobTrades {
  std::vector<const SweepPoint*> points;
  bool all_live = false;
  std::vector<TradePoint> by_client, by_pipeline, by_bytes, by_pod_bytes, by_live, by_all;

  KnobTrades(const std::vector<SweepPoint>& all, const std::string& knob, const std::string& mode) {
    for (const auto& p : all) {
      if (p.knob == knob) points.push_back(&p);
    }
    all_live = std::all_of(points.begin(), points.end(),
                           [](const SweepPoint* p) { return p->live.has_value(); });
    for (const SweepPoint* p : points) {
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
      by_all.push_back({m.psnr_db, {client, pipeline, bytes, pod_bytes}, m.ssim});
      if (all_live) {
        const Cost end_to_end = timeCost(p->live->end_to_end_ms_p50, p->live->end_to_end_ms_p95);
        by_live.push_back({m.psnr_db, {end_to_end}});
        by_all.back().costs.push_back(end_to_end);
      }
    }
  }
  // The point that dominates point i on every cost at once; -1: none.
  int dominator(size_t i) const {
    for (size_t j = 0; j < points.size(); ++j) {
      if (j != i && dominates(by_all[j], by_all[i])) return static_cast<int>(j);
    }
    return -1;
  }
  bool onFront(size_t i) const { return dominator(i) < 0; }
  // Where the default stands: on the front, or dominated by which point.
  std::string verdict(const std::string& knob) const {
    std::string text = "the default is not among the values swept";
    for (size_t i = 0; i < points.size(); ++i) {
      if (!points[i]->is_default) continue;
      const int j = dominator(i);
      text = "the default (" + knob + "=" + points[i]->value + ") is " +
             (j < 0 ? std::string("on the Pareto front")
                    : "dominated by " + knob + "=" + points[static_cast<size_t>(j)]->value);
    }
    return text;
  }
};

// The stages over the budget (--budget) at a point's p95: the
// leave-one-out run's, then the live run's for the rest, as the table's
// cell and as JSON.
std::pair<std::string, nlohmann::json> overBudget(const PointBudget& budget) {
  std::string over;
  nlohmann::json violations = nlohmann::json::array();
  for (const BudgetCheck& check : budget.checks) {
    if (!check.over()) continue;
    char text[112];
    std::snprintf(text, sizeof(text), "%s%s %.1f > %.1f ms", check.mode == "live" ? "live " : "",
                  check.stage.c_str(), check.p95_ms, check.budget_ms);
    over += (over.empty() ? "" : ", ") + std::string(text);
    violations.push_back({{"stage", check.stage},
                          {"measured", check.mode == "live" ? "live loop" : "leave-one-out"},
                          {"p95_ms", check.p95_ms},
                          {"budget_ms", check.budget_ms}});
  }
  return {over, violations};
}

// One knob: its table and verdict in Markdown, its points in JSON, its
// plots on the page, and its rows in the table of all points.
void addKnob(const SweepOptions& options, const std::vector<SweepPoint>& points,
             const std::string& name, const std::string& mode, SweepDocuments& d) {
  const KnobTrades trades(points, name, mode);
  const std::vector<const SweepPoint*>& mine = trades.points;
  const std::string verdict = trades.verdict(name);
  nlohmann::json& k = d.json["knobs"][name];
  k["default_verdict"] = verdict;
  html::Table knob_table{{"value", "PSNR dB", "SSIM", "flicker", "Chamfer mm", "client ms",
                          "pipeline ms", "live end-to-end ms", "live jitter ms (worst pod)",
                          "KB/frame to client", "pods KB/frame", "front", "over budget"},
                         {},
                         "lrrrrrrrrrrll"};
  for (size_t i = 0; i < mine.size(); ++i) {
    const SweepPoint& p = *mine[i];
    const ModeResult& m = p.result.modes.at(mode);
    const PointBudget point_budget = checkPointBudget(options.base.budget, p, mode);
    const auto [over, violations] = overBudget(point_budget);
    for (const auto& stage : point_budget.unchecked) d.unchecked.insert(stage);
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
         {"on_front", trades.onFront(i)},
         {"budget_violations", violations},
         {"budget_unchecked", point_budget.unchecked},
         {"live_worst_pod_jitter_ms", measuredJson(worstJitterMs(p.live))},
         {"live_command", liveCommand(options, name, p.value)},
         {"live", p.live ? liveJson(*p.live, options.live_frames) : nlohmann::json()},
         {"result", sceneResultJson(p.result)}});
    const std::string live_cell = p.live
                                      ? html::number("%.0f", p.live->end_to_end_ms_p50) +
                                            html::number(" (p95 %.0f)", p.live->end_to_end_ms_p95)
                                      : "not run";
    const std::vector<std::string> row = {
        p.value + (p.is_default ? " (default)" : ""),
        html::number("%.2f", m.psnr_db),
        html::number("%.4f", m.ssim),
        measuredText(m.flicker, "%.2f"),
        measuredText(p.result.chamfer_mm, "%.1f"),
        html::number("%.1f", m.ms_per_new_mesh),
        html::number("%.1f", pipelineMs(p.result, mode)),
        live_cell,
        p.live ? measuredText(worstJitterMs(p.live), "%.2f") : "not run",
        html::number("%.0f", clientBytes(p.result, m) / 1000.0),
        html::number("%.0f", p.result.pod_link_bytes_per_frame / 1000.0),
        trades.onFront(i) ? "yes" : "",
        over};
    knob_table.rows.push_back(row);
    d.rows.push_back(row);
    d.rows.back().insert(d.rows.back().begin(), (over.empty() ? "" : "!") + name);  // flagged
  }
  d.md += "## " + name + "\n\n" + html::markdownTable(knob_table);
  const std::string live = liveCommand(options, name, "VALUE");
  d.md += "\n" + verdict + ". A value in the live loop: `" + live + "`.\n\n";
  d.body += "<h2>" + html::escape(name) + "</h2>\n<p>" + html::escape(findKnob(name)->meaning) +
            ". " + html::escape(verdict) +
            ". Filled: the Pareto front of each plot's pair; red ring: the default. A value in " +
            "the live loop: <code>" + html::escape(live) + "</code>.</p>\n";
}

// One knob's plots: PSNR against each cost, and where each value's
// pipeline time goes, p50 and p95 over its renders.
std::string knobCharts(const std::vector<SweepPoint>& points, const std::string& name,
                       const std::string& mode) {
  const KnobTrades trades(points, name, mode);
  const std::vector<const SweepPoint*>& mine = trades.points;
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
  std::string body =
      plot(trades.by_client, "PSNR against client ms (" + name + ")", "client ms per new mesh");
  body += plot(trades.by_pipeline, "PSNR against pipeline ms (" + name + ")",
               "hull + codecs + client ms");
  body += plot(trades.by_bytes, "PSNR against bytes per frame (" + name + ")",
               "bytes per frame, server to client");
  body += plot(trades.by_pod_bytes, "PSNR against pod bytes per frame (" + name + ")",
               "bytes per frame, pods to server");
  if (trades.all_live) {
    body += plot(trades.by_live, "PSNR against live end-to-end ms (" + name + ")",
                 "end-to-end ms, capture to written frame, live loop");
  }
  std::vector<html::StackRow> stack;
  for (const SweepPoint* p : mine) {
    const ModeResult& m = p->result.modes.at(mode);
    stack.push_back({p->value, latencyParts(p->result, m, false), std::nullopt, ""});
  }
  return body + html::stackedBars("Latency of a new mesh by value (" + name + "; each stage's p50)",
                                  latencyStages(), stack, "ms");
}

// Where each budgeted stage is measured, and which no point measured.
void addBudget(const SweepOptions& options, SweepDocuments& d) {
  if (options.base.budget.empty()) return;
  std::string unchecked_text;
  for (const auto& stage : d.unchecked)
    unchecked_text += (unchecked_text.empty() ? "" : ", ") + stage;
  const std::string budget_text =
      "Budget: each point's p95 of " + budgetedStagesText() +
      " from its leave-one-out run, and of the other stages (end_to_end, upload, ...) from its "
      "live run (\"live\" "
      "in the table; --live-frames)." +
      (unchecked_text.empty() ? std::string()
                              : " Not checked at some points (no live run, or no sample in it): " +
                                    unchecked_text + ".");
  d.json["budget_ms"] = options.base.budget;
  d.json["budget_unchecked"] = d.unchecked;
  d.md += budget_text + "\n";
  d.body += "<p>" + html::escape(budget_text) + "</p>\n";
}

}  // namespace

Status writeSweepReports(const SweepOptions& options, const std::vector<SweepPoint>& points) {
  const std::string mode = primaryMode(options.base);
  SweepDocuments d;
  d.json[options.base.datasets.empty() ? "scene" : "dataset"] = sweptSubject(options);
  d.json["quality_mode"] = mode;
  d.json["pipeline_ms"] =
      "hull + codecs + client ms per new mesh: the per-frame work the knobs move (transport not "
      "included)";
  d.md = sweepIntro(options, mode);
  addOtherModes(points, mode, d);
  for (const auto& [name, values] : options.knobs) {
    addKnob(options, points, name, mode, d);
    d.body += knobCharts(points, name, mode);
  }
  addBudget(options, d);
  d.body += "<h2>All points</h2>\n" +
            html::table({"knob", "value", "PSNR dB", "SSIM", "flicker", "Chamfer mm", "client ms",
                         "pipeline ms", "live end-to-end ms", "live jitter ms (worst pod)",
                         "KB/frame to client", "pods KB/frame", "front", "over budget"},
                        d.rows);
  const fs::path out(options.out_dir);
  HOLOFUSE_RETURN_IF_ERROR(writeTextFile((out / "sweep.json").string(), d.json.dump(2) + "\n"));
  HOLOFUSE_RETURN_IF_ERROR(writeTextFile((out / "sweep.md").string(), d.md));
  return writeTextFile(
      (out / "sweep.html").string(),
      html::page("holofuse sweep: " + sweptSubject(options) + ", quality of " + mode, d.body));
}

}  // namespace holofuse::eval

// Self-contained HTML pages with inline SVG charts for the reports people
// read (demo, eval, sweep): no scripts or styles from elsewhere, so a page
// opens from disk anywhere. Each page carries a small check that, once the
// browser has laid the charts out, counts those whose bars have a real size
// and writes the count to <body data-charts-rendered="N"> (the tests read it
// back from headless Chromium).
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace holofuse::html {

std::string escape(const std::string& text);
// The charts' colour for series i ("#rrggbb"), and as red, green, blue:
// the viewer's panel colours the stages as the reports do.
std::string colour(size_t i);
std::array<unsigned char, 3> colourRgb(size_t i);
// A stage's colour, the same in every chart of every report and in the
// viewer's panel: the colour of its place in the pipeline order
// (protocol::stagesInPipelineOrder), grey for "waiting"; the evaluation's
// "client render" is render's. Another name (a GPU pass) gets the same
// colour wherever it is drawn.
std::string stageColour(const std::string& stage);
// A number as a printf format with one double argument gives it ("%.2f
// dB"), for a cell or a label.
std::string number(const char* format, double value);

struct Series {
  std::string name;
  std::vector<double> values;  // one per category; NaN: not measured (no bar, "n/a")
};

// Grouped vertical bars: a group per category, a bar per series, values
// printed on the bars.
std::string barChart(const std::string& title, const std::vector<std::string>& categories,
                     const std::vector<Series>& series, const std::string& unit);

struct StackRow {
  std::string label;
  std::vector<double> segments;  // one per stage, in the stages' order
  // A figure of the whole drawn as a tick across the row, never stacked:
  // percentiles other than the median do not add up (the end to end's
  // p95 beside the stages' p50s).
  std::optional<double> mark;
  std::string mark_label;
};
// Horizontal stacked bars (the latency budget): a row per label, a segment
// per stage in the stage's colour (stageColour), with a legend.
std::string stackedBars(const std::string& title, const std::vector<std::string>& stages,
                        const std::vector<StackRow>& rows, const std::string& unit);

struct Point {
  std::string label;
  double x = 0, y = 0;
  bool highlighted = false;  // drawn filled and joined (the Pareto front)
  bool marked = false;       // drawn with a ring (the default setting)
};
// Scatter plot of labelled points; highlighted points are joined in x order.
std::string scatterChart(const std::string& title, const std::string& x_label,
                         const std::string& y_label, const std::vector<Point>& points);

struct Line {
  std::string name;
  std::vector<std::pair<double, double>> points;  // (x, y) in order of x
  bool dashed = false;                            // a fitted line, drawn over the samples
};
// Lines against a shared x axis (a soak's quantities against time), each
// in colour(i) of its place, dashed ones thinner, with a legend.
std::string lineChart(const std::string& title, const std::string& x_label,
                      const std::string& y_label, const std::vector<Line>& lines);

// A table of a report, built once and written as HTML (table) or as
// Markdown (markdownTable). Rows whose first cell starts with "!" are
// flagged: shown red in HTML, the "!" dropped in both.
struct Table {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  // Markdown's alignment per column, 'l' or 'r'; columns past its end are
  // right-aligned (numbers), and an empty one left-aligns the first only.
  std::string align;
};

// Cells are escaped.
std::string table(const Table& table);
std::string table(const std::vector<std::string>& header,
                  const std::vector<std::vector<std::string>>& rows);
// A GitHub-flavoured Markdown pipe table (cells as they are).
std::string markdownTable(const Table& table);

std::string page(const std::string& title, const std::string& body);

}  // namespace holofuse::html

#include "report/html.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "protocol/messages.h"

namespace holofuse::html {
namespace {

// Twenty colours apart: every pipeline stage gets one of its own.
const char* const kPalette[] = {"#4e79a7", "#f28e2b", "#59a14f", "#e15759", "#76b7b2",
                                "#edc948", "#b07aa1", "#ff9da7", "#9c755f", "#17becf",
                                "#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e",
                                "#e6ab02", "#5254a3", "#bcbd22", "#aec7e8", "#393b79"};
// Time no stage accounts for.
const char* const kWaiting = "#c7c7c7";

std::string number(double v) {
  char buffer[32];
  const double a = std::abs(v);
  std::snprintf(buffer, sizeof(buffer),
                a >= 100  ? "%.0f"
                : a >= 10 ? "%.1f"
                : a >= 1  ? "%.2f"
                          : "%.3f",
                v);
  return buffer;
}

double finiteOrZero(double v) { return std::isfinite(v) ? v : 0.0; }

// A mark's value in full, for the page's check that the browser drew it in
// proportion (page()'s script).
std::string exact(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.9g", v);
  return buffer;
}

}  // namespace

std::string colour(size_t i) { return kPalette[i % (sizeof(kPalette) / sizeof(kPalette[0]))]; }

std::string stageColour(const std::string& stage) {
  if (stage == "waiting") return kWaiting;
  // The evaluation's name for the client's render stage.
  const std::string name = stage == "client render" ? "render" : stage;
  const std::vector<uint16_t>& order = protocol::stagesInPipelineOrder();
  for (size_t slot = 0; slot < order.size(); ++slot)
    if (protocol::stageName(order[slot]) == name) return colour(slot);
  // Not a stage (a GPU pass): the same colour for the same name in every
  // chart, from its spelling.
  uint32_t hash = 2166136261u;  // FNV-1a
  for (const unsigned char c : stage) hash = (hash ^ c) * 16777619u;
  return colour(hash);
}

std::array<unsigned char, 3> colourRgb(size_t i) {
  const unsigned long rgb = std::stoul(colour(i).substr(1), nullptr, 16);
  return {static_cast<unsigned char>(rgb >> 16), static_cast<unsigned char>(rgb >> 8 & 0xff),
          static_cast<unsigned char>(rgb & 0xff)};
}

std::string number(const char* format, double value) {
  char text[64];
  std::snprintf(text, sizeof(text), format, value);
  return text;
}

std::string escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string barChart(const std::string& title, const std::vector<std::string>& categories,
                     const std::vector<Series>& series, const std::string& unit) {
  size_t longest_label = 0;
  for (const auto& c : categories) longest_label = std::max(longest_label, c.size());
  const double group_width =
      std::max(28.0 * static_cast<double>(std::max<size_t>(series.size(), 1)) + 24.0,
               7.0 * static_cast<double>(longest_label) + 12.0);
  // Wide enough for the groups, the legend and the title.
  const double width =
      std::max({70 + group_width * static_cast<double>(std::max<size_t>(categories.size(), 1)) + 20,
                80 + 130.0 * static_cast<double>(series.size()),
                40 + 8.0 * static_cast<double>(title.size() + unit.size())});
  const double height = 300, top = 40, bottom = 60, plot = height - top - bottom;
  double top_value = 0;
  for (const auto& s : series) {
    for (double v : s.values) top_value = std::max(top_value, finiteOrZero(v));
  }
  if (!(top_value > 0)) top_value = 1;
  std::string svg = "<figure><svg class=\"chart\" xmlns=\"http://www.w3.org/2000/svg\" width=\"" +
                    number(width) + "\" height=\"" + number(height) +
                    "\" role=\"img\" aria-label=\"" + escape(title) + "\">";
  svg +=
      "<text x=\"10\" y=\"20\" class=\"title\">" + escape(title) + " (" + escape(unit) + ")</text>";
  svg += "<line x1=\"60\" y1=\"" + number(top + plot) + "\" x2=\"" + number(width - 10) +
         "\" y2=\"" + number(top + plot) + "\" class=\"axis\"/>";
  for (size_t c = 0; c < categories.size(); ++c) {
    const double gx = 70 + group_width * static_cast<double>(c);
    for (size_t s = 0; s < series.size(); ++s) {
      const double x = gx + 28.0 * static_cast<double>(s);
      if (c < series[s].values.size() && std::isnan(series[s].values[c])) {
        // Not measured: no bar, so that it cannot pass for a small value.
        svg += "<text class=\"value\" x=\"" + number(x + 12) + "\" y=\"" + number(top + plot - 3) +
               "\">n/a</text>";
        continue;
      }
      const double v = c < series[s].values.size() ? finiteOrZero(series[s].values[c]) : 0.0;
      const double h = std::max(0.0, v) / top_value * plot;
      svg += "<rect class=\"bar\" data-encoding=\"height\" data-value=\"" + exact(v) + "\" x=\"" +
             number(x) + "\" y=\"" + number(top + plot - h) + "\" width=\"24\" height=\"" +
             number(std::max(h, 0.5)) + "\" fill=\"" + colour(s) + "\"><title>" +
             escape(series[s].name) + ", " + escape(categories[c]) + ": " + number(v) + " " +
             escape(unit) + "</title></rect>";
      svg += "<text class=\"value\" x=\"" + number(x + 12) + "\" y=\"" +
             number(top + plot - h - 3) + "\">" + number(v) + "</text>";
    }
    svg += "<text class=\"category\" x=\"" + number(gx + group_width / 2 - 12) + "\" y=\"" +
           number(top + plot + 16) + "\">" + escape(categories[c]) + "</text>";
  }
  for (size_t s = 0; s < series.size(); ++s) {
    const double lx = 70 + 130.0 * static_cast<double>(s);
    svg += "<rect x=\"" + number(lx) + "\" y=\"" + number(height - 22) +
           "\" width=\"12\" height=\"12\" fill=\"" + colour(s) + "\"/><text x=\"" +
           number(lx + 16) + "\" y=\"" + number(height - 12) + "\">" + escape(series[s].name) +
           "</text>";
  }
  return svg + "</svg></figure>\n";
}

std::string stackedBars(const std::string& title, const std::vector<std::string>& stages,
                        const std::vector<StackRow>& rows, const std::string& unit) {
  // Room right of the bars for the total, and for a mark's figure beside it.
  const bool marked =
      std::any_of(rows.begin(), rows.end(), [](const StackRow& row) { return row.mark; });
  const double width = 860, row_height = 34, left = 120, right = marked ? 260 : 80;
  const double legend_rows = std::ceil(static_cast<double>(stages.size()) / 5.0);
  const double height = 40 + row_height * static_cast<double>(rows.size()) + 22 * legend_rows + 20;
  double longest = 0;
  for (const auto& row : rows) {
    double total = 0;
    for (double v : row.segments) total += std::max(0.0, finiteOrZero(v));
    longest = std::max(longest, total);
    if (row.mark) longest = std::max(longest, finiteOrZero(*row.mark));
  }
  if (!(longest > 0)) longest = 1;
  const double scale = (width - left - right) / longest;
  std::string svg = "<figure><svg class=\"chart\" xmlns=\"http://www.w3.org/2000/svg\" width=\"" +
                    number(width) + "\" height=\"" + number(height) +
                    "\" role=\"img\" aria-label=\"" + escape(title) + "\">";
  svg +=
      "<text x=\"10\" y=\"20\" class=\"title\">" + escape(title) + " (" + escape(unit) + ")</text>";
  for (size_t r = 0; r < rows.size(); ++r) {
    const double y = 34 + row_height * static_cast<double>(r);
    svg += "<text x=\"10\" y=\"" + number(y + 18) + "\">" + escape(rows[r].label) + "</text>";
    double x = left, total = 0;
    for (size_t s = 0; s < rows[r].segments.size() && s < stages.size(); ++s) {
      const double v = std::max(0.0, finiteOrZero(rows[r].segments[s]));
      total += v;
      const double w = v * scale;
      if (w <= 0) continue;
      svg += "<rect class=\"bar\" data-encoding=\"width\" data-value=\"" + exact(v) + "\" x=\"" +
             number(x) + "\" y=\"" + number(y) + "\" width=\"" + number(w) +
             "\" height=\"24\" fill=\"" + stageColour(stages[s]) + "\"><title>" +
             escape(stages[s]) + ": " + number(v) + " " + escape(unit) + "</title></rect>";
      x += w;
    }
    std::string label = number(total) + " " + escape(unit);
    if (rows[r].mark) {
      // A figure of the whole that is not a sum of the segments (the end
      // to end's p95): a tick across the row, named beside the total.
      const double mx = left + std::max(0.0, finiteOrZero(*rows[r].mark)) * scale;
      svg += "<line class=\"mark\" x1=\"" + number(mx) + "\" y1=\"" + number(y - 4) + "\" x2=\"" +
             number(mx) + "\" y2=\"" + number(y + 28) +
             "\" stroke=\"#222\" stroke-width=\"2\" stroke-dasharray=\"4 2\"><title>" +
             escape(rows[r].mark_label) + ": " + number(*rows[r].mark) + " " + escape(unit) +
             "</title></line>";
      label += "; " + escape(rows[r].mark_label) + " " + number(*rows[r].mark) + " " + escape(unit);
      x = std::max(x, mx);
    }
    svg += "<text x=\"" + number(x + 6) + "\" y=\"" + number(y + 17) + "\">" + label + "</text>";
  }
  for (size_t s = 0; s < stages.size(); ++s) {
    const double lx = 10 + 170.0 * static_cast<double>(s % 5);
    const double ly =
        40 + row_height * static_cast<double>(rows.size()) + 22 * static_cast<double>(s / 5);
    svg += "<rect x=\"" + number(lx) + "\" y=\"" + number(ly) +
           "\" width=\"12\" height=\"12\" fill=\"" + stageColour(stages[s]) + "\"/><text x=\"" +
           number(lx + 16) + "\" y=\"" + number(ly + 10) + "\">" + escape(stages[s]) + "</text>";
  }
  return svg + "</svg></figure>\n";
}

namespace {

// A chart's plotting area: the svg's size, the margins around the axes,
// and the ranges the axes span.
struct PlotArea {
  double width, height, full_height, left, right, top, bottom, x0, x1, y0, y1;
  double x(double v) const { return left + (v - x0) / (x1 - x0) * (width - left - right); }
  double y(double v) const {
    return height - bottom - (v - y0) / (y1 - y0) * (height - top - bottom);
  }
};

// The svg's opening, the title, both axes with five ticks each and their
// labels: what the scatter and line charts share.
std::string axesSvg(const std::string& title, const std::string& x_label,
                    const std::string& y_label, const PlotArea& a) {
  const double width = a.width, height = a.height, left = a.left, right = a.right, top = a.top,
               bottom = a.bottom, x0 = a.x0, x1 = a.x1, y0 = a.y0, y1 = a.y1;
  auto sx = [&](double x) { return a.x(x); };
  auto sy = [&](double y) { return a.y(y); };
  std::string svg = "<figure><svg class=\"chart\" xmlns=\"http://www.w3.org/2000/svg\" width=\"" +
                    number(width) + "\" height=\"" + number(a.full_height) +
                    "\" role=\"img\" aria-label=\"" + escape(title) + "\">";
  svg += "<text x=\"10\" y=\"20\" class=\"title\">" + escape(title) + "</text>";
  svg += "<line class=\"axis\" x1=\"" + number(left) + "\" y1=\"" + number(height - bottom) +
         "\" x2=\"" + number(width - right) + "\" y2=\"" + number(height - bottom) + "\"/>";
  svg += "<line class=\"axis\" x1=\"" + number(left) + "\" y1=\"" + number(top) + "\" x2=\"" +
         number(left) + "\" y2=\"" + number(height - bottom) + "\"/>";
  for (int t = 0; t <= 4; ++t) {
    const double xv = x0 + (x1 - x0) * t / 4, yv = y0 + (y1 - y0) * t / 4;
    svg += "<text class=\"category\" x=\"" + number(sx(xv)) + "\" y=\"" +
           number(height - bottom + 16) + "\">" + number(xv) + "</text>";
    svg += "<text x=\"" + number(left - 6) + "\" y=\"" + number(sy(yv) + 4) +
           "\" style=\"text-anchor:end\">" + number(yv) + "</text>";
  }
  svg += "<text class=\"category\" x=\"" + number((left + width - right) / 2) + "\" y=\"" +
         number(height - 10) + "\">" + escape(x_label) + "</text>";
  svg += "<text x=\"14\" y=\"" + number(top - 8) + "\">" + escape(y_label) + "</text>";
  return svg;
}

}  // namespace

std::string scatterChart(const std::string& title, const std::string& x_label,
                         const std::string& y_label, const std::vector<Point>& points) {
  const double width = 620, height = 380, left = 70, right = 30, top = 40, bottom = 50;
  double x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  bool first = true;
  for (const auto& p : points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
    if (first) {
      x0 = x1 = p.x;
      y0 = y1 = p.y;
      first = false;
    }
    x0 = std::min(x0, p.x);
    x1 = std::max(x1, p.x);
    y0 = std::min(y0, p.y);
    y1 = std::max(y1, p.y);
  }
  const double padx = std::max((x1 - x0) * 0.08, 1e-9 + std::abs(x1) * 0.05);
  const double pady = std::max((y1 - y0) * 0.08, 1e-9 + std::abs(y1) * 0.05);
  x0 -= padx;
  x1 += padx;
  y0 -= pady;
  y1 += pady;
  const PlotArea area{width, height, height, left, right, top, bottom, x0, x1, y0, y1};
  auto sx = [&](double x) { return area.x(x); };
  auto sy = [&](double y) { return area.y(y); };
  std::string svg = axesSvg(title, x_label, y_label, area);
  std::vector<const Point*> front;
  for (const auto& p : points) {
    if (p.highlighted && std::isfinite(p.x) && std::isfinite(p.y)) front.push_back(&p);
  }
  std::sort(front.begin(), front.end(), [](const Point* a, const Point* b) { return a->x < b->x; });
  if (front.size() > 1) {
    std::string path = "<polyline fill=\"none\" stroke=\"#59a14f\" stroke-width=\"1.5\" points=\"";
    for (const Point* p : front) path += number(sx(p->x)) + "," + number(sy(p->y)) + " ";
    svg += path + "\"/>";
  }
  for (const auto& p : points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
    svg += "<circle class=\"bar\" data-encoding=\"position\" data-x=\"" + exact(p.x) +
           "\" data-y=\"" + exact(p.y) + "\" cx=\"" + number(sx(p.x)) + "\" cy=\"" +
           number(sy(p.y)) + "\" r=\"5\" fill=\"" +
           std::string(p.highlighted ? "#59a14f" : "#ffffff") + "\" stroke=\"" +
           std::string(p.marked ? "#e15759" : "#4e79a7") + "\" stroke-width=\"" +
           (p.marked ? "3" : "1.5") + "\"><title>" + escape(p.label) + ": " + number(p.x) + ", " +
           number(p.y) + "</title></circle>";
    svg += "<text x=\"" + number(sx(p.x) + 7) + "\" y=\"" + number(sy(p.y) - 6) + "\">" +
           escape(p.label) + "</text>";
  }
  return svg + "</svg></figure>\n";
}

std::string lineChart(const std::string& title, const std::string& x_label,
                      const std::string& y_label, const std::vector<Line>& lines) {
  const double width = 720, height = 360, left = 70, right = 30, top = 40, bottom = 50;
  const double legend_rows = std::ceil(static_cast<double>(lines.size()) / 4.0);
  double x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  bool first = true;
  for (const Line& line : lines) {
    for (const auto& [x, y] : line.points) {
      if (!std::isfinite(x) || !std::isfinite(y)) continue;
      if (first) {
        x0 = x1 = x;
        y0 = y1 = y;
        first = false;
      }
      x0 = std::min(x0, x);
      x1 = std::max(x1, x);
      y0 = std::min(y0, y);
      y1 = std::max(y1, y);
    }
  }
  const double pady = std::max((y1 - y0) * 0.08, 1e-9 + std::abs(y1) * 0.02);
  y0 -= pady;
  y1 += pady;
  if (x1 <= x0) x1 = x0 + 1;
  const double full = height + 22 * legend_rows;
  const PlotArea area{width, height, full, left, right, top, bottom, x0, x1, y0, y1};
  auto sx = [&](double x) { return area.x(x); };
  auto sy = [&](double y) { return area.y(y); };
  std::string svg = axesSvg(title, x_label, y_label, area);
  for (size_t i = 0; i < lines.size(); ++i) {
    const Line& line = lines[i];
    std::string points;
    for (const auto& [x, y] : line.points) {
      if (std::isfinite(x) && std::isfinite(y)) points += number(sx(x)) + "," + number(sy(y)) + " ";
    }
    svg += "<polyline fill=\"none\" stroke=\"" + colour(i) + "\" stroke-width=\"" +
           (line.dashed ? "2\" stroke-dasharray=\"6 4" : "1.2") + "\" points=\"" + points +
           "\"><title>" + escape(line.name) + "</title></polyline>";
    const double lx = left + 160.0 * static_cast<double>(i % 4),
                 ly = height + 22.0 * static_cast<double>(i / 4) + 4;
    svg += "<line x1=\"" + number(lx) + "\" y1=\"" + number(ly) + "\" x2=\"" + number(lx + 22) +
           "\" y2=\"" + number(ly) + "\" stroke=\"" + colour(i) + "\" stroke-width=\"2\"" +
           (line.dashed ? " stroke-dasharray=\"6 4\"" : "") + "/>";
    svg += "<text x=\"" + number(lx + 28) + "\" y=\"" + number(ly + 4) + "\">" + escape(line.name) +
           "</text>";
  }
  return svg + "</svg></figure>\n";
}

std::string table(const Table& t) { return table(t.header, t.rows); }

std::string markdownTable(const Table& t) {
  auto line = [](const std::vector<std::string>& cells, bool flaggable) {
    std::string out = "|";
    for (size_t c = 0; c < cells.size(); ++c) {
      const bool flagged = flaggable && c == 0 && !cells[c].empty() && cells[c][0] == '!';
      out += " " + (flagged ? cells[c].substr(1) : cells[c]) + " |";
    }
    return out + "\n";
  };
  std::string out = line(t.header, false) + "|";
  for (size_t c = 0; c < t.header.size(); ++c) {
    const char align = c < t.align.size() ? t.align[c] : (c == 0 ? 'l' : 'r');
    out += align == 'l' ? "---|" : "---:|";
  }
  out += "\n";
  for (const auto& row : t.rows) out += line(row, true);
  return out;
}

std::string table(const std::vector<std::string>& header,
                  const std::vector<std::vector<std::string>>& rows) {
  std::string out = "<table><thead><tr>";
  for (const auto& h : header) out += "<th>" + escape(h) + "</th>";
  out += "</tr></thead><tbody>";
  for (const auto& row : rows) {
    const bool flagged = !row.empty() && !row[0].empty() && row[0][0] == '!';
    out += flagged ? "<tr class=\"flagged\">" : "<tr>";
    for (size_t c = 0; c < row.size(); ++c)
      out += "<td>" + escape(c == 0 && flagged ? row[c].substr(1) : row[c]) + "</td>";
    out += "</tr>";
  }
  return out + "</tbody></table>\n";
}

std::string page(const std::string& title, const std::string& body) {
  return "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" +
         escape(title) +
         "</"
         "title>\n<style>body{font-family:sans-serif;margin:24px;color:#222}table{border-collapse:"
         "collapse;margin:12px 0}"
         "td,th{border:1px solid #ccc;padding:4px 8px;text-align:right}th{background:#f4f4f4}"
         "td:first-child,th:first-child{text-align:left}tr.flagged "
         "td{background:#fde0dc;color:#a40000}"
         "svg text{font-size:12px}svg .title{font-size:14px;font-weight:bold}svg "
         ".value{font-size:10px;"
         "text-anchor:middle}svg .category{text-anchor:middle}svg "
         ".axis{stroke:#888}figure{margin:16px 0}</style>"
         "</head>\n<body data-charts-rendered=\"0\">\n<h1>" +
         escape(title) + "</h1>\n" + body +
         "<script>\n"
         "// Counts the charts the browser laid out faithfully: every mark drawn, bar lengths in "
         "proportion to\n"
         "// their values (within a pixel), scatter points in the order of their values along both "
         "axes.\n"
         "function faithful(svg) {\n"
         "  var marks = svg.querySelectorAll('.bar'), lengths = [], points = [], ok = marks.length "
         "> 0;\n"
         "  if (svg.getBoundingClientRect().width <= 0) return false;\n"
         "  marks.forEach(function (mark) {\n"
         "    var box = mark.getBBox(), encoding = mark.getAttribute('data-encoding');\n"
         "    if (!(box.width > 0 && box.height > 0)) ok = false;\n"
         "    if (encoding === 'position') {\n"
         "      points.push({x: +mark.getAttribute('data-x'), y: +mark.getAttribute('data-y'),\n"
         "                   px: box.x + box.width / 2, py: box.y + box.height / 2});\n"
         "    } else {\n"
         "      lengths.push({value: +mark.getAttribute('data-value'),\n"
         "                    size: encoding === 'width' ? box.width : box.height});\n"
         "    }\n"
         "  });\n"
         "  var longest = null;\n"
         "  lengths.forEach(function (l) { if (longest === null || l.value > longest.value) "
         "longest = l; });\n"
         "  if (longest !== null && longest.value > 0) {\n"
         "    var scale = longest.size / longest.value;\n"
         "    lengths.forEach(function (l) {\n"
         "      if (l.value > 0 && Math.abs(l.size - l.value * scale) > 1) ok = false;\n"
         "    });\n"
         "  }\n"
         "  points.forEach(function (a) {\n"
         "    points.forEach(function (b) {\n"
         "      if (a.x < b.x && a.px > b.px + 0.5) ok = false;\n"
         "      if (a.y < b.y && a.py < b.py - 0.5) ok = false;  // a higher value sits higher on "
         "the page\n"
         "    });\n"
         "  });\n"
         "  return ok;\n"
         "}\n"
         "window.addEventListener('load', function () {\n"
         "  var rendered = 0;\n"
         "  document.querySelectorAll('svg.chart').forEach(function (svg) { if (faithful(svg)) "
         "rendered++; });\n"
         "  document.body.setAttribute('data-charts-rendered', String(rendered));\n"
         "});\n</script>\n</body></html>\n";
}

}  // namespace holofuse::html

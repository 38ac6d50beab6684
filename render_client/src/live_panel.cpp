#include "render_client/live_panel.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>

#include "protocol/messages.h"
#include "report/html.h"

namespace holofuse::render {

PanelFigures panelFigures(const std::vector<report::FrameRecord>& frames, size_t window,
                          const std::string& title) {
  PanelFigures figures;
  figures.title = title;
  const size_t n = std::min(frames.size(), std::max<size_t>(window, 1));
  figures.frames = n;
  if (n == 0) return figures;
  const auto first = frames.end() - static_cast<std::ptrdiff_t>(n);
  const report::FrameRecord& latest = frames.back();
  figures.end_to_end_ms = latest.end_to_end_ms;
  std::vector<double> e2e;
  for (auto f = first; f != frames.end(); ++f) e2e.push_back(f->end_to_end_ms);
  std::nth_element(e2e.begin(), e2e.begin() + static_cast<std::ptrdiff_t>(e2e.size() / 2),
                   e2e.end());
  figures.end_to_end_p50_ms = e2e[e2e.size() / 2];
  // Rates over the intervals between the frames' writes: n frames span
  // n - 1 of them, and the bytes of the n - 1 frames after the first.
  if (n >= 2 && latest.written_local_ns > first->written_local_ns) {
    const double seconds =
        static_cast<double>(latest.written_local_ns - first->written_local_ns) / 1e9;
    double bytes = 0;
    for (auto f = first + 1; f != frames.end(); ++f) bytes += static_cast<double>(f->client_bytes);
    figures.fps = static_cast<double>(n - 1) / seconds;
    figures.link_mbit_s = 8 * bytes / seconds / 1e6;
  }
  const std::vector<double> shares = report::timeByStage(latest);
  const std::vector<uint16_t>& order = protocol::stagesInPipelineOrder();
  for (size_t s = 0; s < shares.size(); ++s) {
    if (!(shares[s] > 0)) continue;
    figures.stages.push_back(
        {s < order.size() ? protocol::stageName(order[s]) : "waiting", shares[s], s});
  }
  return figures;
}

void drawPanel(Image8& picture, const PanelFigures& figures) {
  if (figures.frames == 0 || picture.channels != 4 || picture.width < 64 || picture.height < 48)
    return;
  cv::Mat image(static_cast<int>(picture.height), static_cast<int>(picture.width), CV_8UC4,
                picture.pixels.data());
  // Text sized to the picture: legible from 320 pixels wide up.
  const double scale = std::clamp(static_cast<double>(picture.width) / 640.0, 0.45, 1.2);
  const int line = static_cast<int>(std::lround(22 * scale)), pad = std::max(2, line / 4);
  const int font = cv::FONT_HERSHEY_SIMPLEX, thickness = 1;
  // The key names the stages of 3% of the end to end or more, in three
  // columns; the bar shows every stage.
  double total = 0;
  for (const auto& s : figures.stages) total += s.ms;
  // A picture under 200 rows keeps the bar only: the key would hide it.
  std::vector<PanelFigures::Stage> key;
  for (const auto& s : figures.stages) {
    if (s.ms >= 0.03 * total && picture.height >= 200) key.push_back(s);
  }
  const int width = std::min(image.cols, static_cast<int>(std::lround(420 * scale)));
  const int bar_w = width - 2 * pad;
  // As many columns (up to 3) as the longest entry leaves room for.
  int entry_w = 1;
  char buffer[160];
  for (const auto& s : key) {
    std::snprintf(buffer, sizeof(buffer), "%s %.0f", s.name.c_str(), s.ms);
    int baseline = 0;
    entry_w = std::max(
        entry_w, cv::getTextSize(buffer, font, 0.5 * scale, thickness, &baseline).width + line);
  }
  const int columns = std::clamp(bar_w / entry_w, 1, 3);
  const int key_rows = static_cast<int>((key.size() + columns - 1) / columns);
  const int height = std::min(image.rows, pad * 2 + line * (3 + key_rows));
  // A dark, half see-through box keeps the text legible over any picture.
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      cv::Vec4b& p = image.at<cv::Vec4b>(y, x);
      p = cv::Vec4b(static_cast<uint8_t>(p[0] * 35 / 100), static_cast<uint8_t>(p[1] * 35 / 100),
                    static_cast<uint8_t>(p[2] * 35 / 100), 255);
    }
  }
  const cv::Scalar white(255, 255, 255, 255);
  auto text = [&](const std::string& s, int x, int y, const cv::Scalar& colour) {
    cv::putText(image, s, cv::Point(x, y), font, 0.5 * scale, colour, thickness, cv::LINE_AA);
  };
  std::snprintf(buffer, sizeof(buffer), "%s  %.1f fps  %.1f Mbit/s", figures.title.c_str(),
                figures.fps, figures.link_mbit_s);
  text(buffer, pad, pad + line * 3 / 4, white);
  std::snprintf(buffer, sizeof(buffer), "end to end %.0f ms (p50 %.0f over %zu frames)",
                figures.end_to_end_ms, figures.end_to_end_p50_ms, figures.frames);
  text(buffer, pad, pad + line * 7 / 4, white);
  // The latest frame's end to end as one bar, a segment per stage.
  const int bar_y = pad + line * 2 + line / 6, bar_h = line * 2 / 3;
  double at = 0;
  for (const auto& s : figures.stages) {
    const auto rgb = html::colourRgb(s.slot);
    const int x0 = pad + static_cast<int>(std::lround(bar_w * at / total));
    at += s.ms;
    const int x1 = pad + static_cast<int>(std::lround(bar_w * at / total));
    if (x1 > x0)
      cv::rectangle(image, cv::Rect(x0, bar_y, x1 - x0, bar_h),
                    cv::Scalar(rgb[0], rgb[1], rgb[2], 255), cv::FILLED);
  }
  // The key: a swatch, the stage and its ms.
  for (size_t k = 0; k < key.size(); ++k) {
    const auto& s = key[k];
    const int x = pad + static_cast<int>(k) % columns * (bar_w / columns);
    const int y = pad + line * (3 + static_cast<int>(k) / columns);
    const auto rgb = html::colourRgb(s.slot);
    cv::rectangle(image, cv::Rect(x, y + line / 4, line / 2, line / 2),
                  cv::Scalar(rgb[0], rgb[1], rgb[2], 255), cv::FILLED);
    std::snprintf(buffer, sizeof(buffer), "%s %.0f", s.name.c_str(), s.ms);
    text(buffer, x + line * 2 / 3, y + line * 3 / 4, white);
  }
}

Image8 crossFade(const Image8& from, const Image8& to, double t) {
  if (from.width != to.width || from.height != to.height || from.channels != to.channels ||
      !(t < 1.0))
    return to;
  const double w = std::max(t, 0.0);
  Image8 out = to;
  for (size_t i = 0; i < out.pixels.size(); ++i) {
    out.pixels[i] = static_cast<uint8_t>(
        std::lround((1.0 - w) * from.pixels[i] + w * static_cast<double>(to.pixels[i])));
  }
  return out;
}

}  // namespace holofuse::render

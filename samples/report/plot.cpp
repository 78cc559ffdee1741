#include "report/plot.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <map>

namespace shrefract::report {
namespace {

// 5x7 glyphs, one string of 35 characters per glyph, '#' = ink. Lowercase letters use the
// uppercase shapes.
const std::map<char, const char*>& font() {
  static const std::map<char, const char*> glyphs = {
      {'A', " ### #   ##   #######   ##   ##   #"}, {'B', "#### #   ##   ##### #   ##   ##### "},
      {'C', " ### #   ##    #    #    #   # ### "}, {'D', "#### #   ##   ##   ##   ##   ##### "},
      {'E', "######    #    #### #    #    #####"}, {'F', "######    #    #### #    #    #    "},
      {'G', " ### #   ##    # ####   ##   # ####"}, {'H', "#   ##   ##   #######   ##   ##   #"},
      {'I', " ###   #    #    #    #    #   ### "}, {'J', "  ###   #    #    #    # #  #  ##  "},
      {'K', "#   ##  # # #  ##   # #  #  # #   #"}, {'L', "#    #    #    #    #    #    #####"},
      {'M', "#   ### ### # ## # ##   ##   ##   #"}, {'N', "#   ##   ###  ## # ##  ###   ##   #"},
      {'O', " ### #   ##   ##   ##   ##   # ### "}, {'P', "#### #   ##   ##### #    #    #    "},
      {'Q', " ### #   ##   ##   ## # ##  #  ## #"}, {'R', "#### #   ##   ##### # #  #  # #   #"},
      {'S', " #####    #     ###     #    ##### "}, {'T', "#####  #    #    #    #    #    #  "},
      {'U', "#   ##   ##   ##   ##   ##   # ### "}, {'V', "#   ##   ##   ##   ##   # # #   #  "},
      {'W', "#   ##   ##   ## # ## # ## # # # # "}, {'X', "#   ##   # # #   #   # # #   ##   #"},
      {'Y', "#   ##   # # #   #    #    #    #  "}, {'Z', "#####    #   #   #   #   #    #####"},
      {'0', " ### #   ##  ### # ###  ##   # ### "}, {'1', "  #   ##    #    #    #    #   ### "},
      {'2', " ### #   #    #   #   #   #   #####"}, {'3', "#####   #   #     #     ##   # ### "},
      {'4', "   #   ##  # # #  # #####   #    # "}, {'5', "######    ####     #    ##   # ### "},
      {'6', "  ##  #   #    #### #   ##   # ### "}, {'7', "#####    #   #   #   #    #    #   "},
      {'8', " ### #   ##   # ### #   ##   # ### "}, {'9', " ### #   ##   # ####    #   #  ##  "},
      {'.', "                          ##   ##  "}, {'-', "               #####               "},
      {'(', "   #   #   #    #    #     #     # "}, {')', " #     #     #    #    #   #   #   "},
      {'/', "         #   #   #   #   #         "}, {':', "      ##   ##        ##   ##       "},
      {'%', "##   ##  #   #   #   #   #  ##   ##"}, {'+', "       #    #  #####  #    #       "},
      {',', "                     ##    #   #   "}, {'=', "          #####     #####          "},
      {'_', "                              #####"}, {' ', "                                   "},
  };
  return glyphs;
}

void setPixel(bake::Image& img, int x, int y, std::array<float, 3> c) {
  if (x < 0 || y < 0 || x >= static_cast<int>(img.width) || y >= static_cast<int>(img.height)) return;
  float* p = &img.rgba[(size_t(y) * img.width + size_t(x)) * 4];
  p[0] = c[0];
  p[1] = c[1];
  p[2] = c[2];
  p[3] = 1.0f;
}

void drawLine(bake::Image& img, int x0, int y0, int x1, int y1, std::array<float, 3> c) {
  const int dx = std::abs(x1 - x0), dy = -std::abs(y1 - y0);
  const int sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
  int err = dx + dy;
  for (;;) {
    setPixel(img, x0, y0, c);
    if (x0 == x1 && y0 == y1) break;
    const int e2 = 2 * err;
    if (e2 >= dy) {
      err += dy;
      x0 += sx;
    }
    if (e2 <= dx) {
      err += dx;
      y0 += sy;
    }
  }
}

std::string tickText(double v) {
  char buf[32];
  const double a = std::fabs(v);
  if (a != 0.0 && (a >= 1e5 || a < 1e-3)) std::snprintf(buf, sizeof buf, "%.0e", v);
  else if (a >= 100 || v == std::floor(v)) std::snprintf(buf, sizeof buf, "%.0f", v);
  else if (a >= 1) std::snprintf(buf, sizeof buf, "%.1f", v);
  else std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// Round numbers 1, 2, 5 x 10^k spanning [lo, hi].
std::vector<double> niceTicks(double lo, double hi) {
  const double span = hi - lo;
  const double raw = span / 5.0;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * mag >= raw) {
      step = m * mag;
      break;
    }
  std::vector<double> ticks;
  for (double t = std::ceil(lo / step) * step; t <= hi + 1e-9 * span; t += step) ticks.push_back(t);
  return ticks;
}

}  // namespace

void drawText(bake::Image& image, int x, int y, const std::string& text, std::array<float, 3> color, int scale) {
  const auto& glyphs = font();
  int cx = x;
  for (char ch : text) {
    const char up = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
    auto it = glyphs.find(up);
    const char* g = it != glyphs.end() ? it->second : glyphs.at(' ');
    for (int row = 0; row < 7; ++row)
      for (int col = 0; col < 5; ++col)
        if (g[row * 5 + col] == '#')
          for (int sy = 0; sy < scale; ++sy)
            for (int sx = 0; sx < scale; ++sx) setPixel(image, cx + col * scale + sx, y + row * scale + sy, color);
    cx += 6 * scale;
  }
}

namespace {

const std::array<float, 3> kBlack{0.0f, 0.0f, 0.0f}, kGrey{0.85f, 0.85f, 0.85f};

// Where the axes lie in the image (pixels) and the data range they span (x in axis units: log10
// where the axis is logarithmic).
struct PlotFrame {
  int left = 0, right = 0, top = 0, bottom = 0;
  bool logX = false;
  double x0 = 0.0, x1 = 0.0, y0 = 0.0, y1 = 0.0;

  double axisX(double v) const { return logX ? std::log10(std::max(v, 1e-12)) : v; }
  int px(double v) const { return left + static_cast<int>((axisX(v) - x0) / (x1 - x0) * (right - left)); }
  int py(double v) const { return bottom - static_cast<int>((v - y0) / (y1 - y0) * (bottom - top)); }
};

// Non-finite points, and points at x <= 0 on a logarithmic axis, are not drawn.
bool plottable(const Plot& plot, const PlotPoint& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && !(plot.logX && p.x <= 0.0);
}

// The data range of the plottable points, widened where empty or degenerate, then padded.
void fitRange(const Plot& plot, PlotFrame& f) {
  double x0 = 1e300, x1 = -1e300, y0 = plot.yFromZero ? 0.0 : 1e300, y1 = -1e300;
  for (const auto& p : plot.points) {
    if (!plottable(plot, p)) continue;
    x0 = std::min(x0, f.axisX(p.x));
    x1 = std::max(x1, f.axisX(p.x));
    y0 = std::min(y0, p.y);
    y1 = std::max(y1, p.y);
  }
  if (x0 > x1) {
    x0 = 0.0;
    x1 = 1.0;
  }
  if (x1 - x0 < 1e-12) {
    x0 -= 0.5;
    x1 += 0.5;
  }
  if (y0 > y1) {
    y0 = 0.0;
    y1 = 1.0;
  }
  if (y1 <= y0) y1 = y0 + 1.0;
  const double padX = 0.06 * (x1 - x0);
  x0 -= padX;
  x1 += padX;
  if (!plot.yFromZero) y0 -= 0.08 * (y1 - y0);
  y1 += 0.08 * (y1 - y0);
  f.x0 = x0;
  f.x1 = x1;
  f.y0 = y0;
  f.y1 = y1;
}

PlotFrame frameFor(const Plot& plot, uint32_t width, uint32_t height) {
  size_t longestName = 0;
  for (const auto& series : plot.series) longestName = std::max(longestName, series.name.size());
  const int legendWidth = plot.legendOutside ? 6 * static_cast<int>(longestName) + 24 : 0;
  PlotFrame f;
  f.left = 70;
  f.right = static_cast<int>(width) - 20 - legendWidth;
  f.top = 52;
  f.bottom = static_cast<int>(height) - 50;
  f.logX = plot.logX;
  fitRange(plot, f);
  return f;
}

// Grid lines with their tick values, the axis lines, the title and the axis labels.
void drawAxes(bake::Image& img, const Plot& plot, const PlotFrame& f) {
  for (double t : niceTicks(f.y0, f.y1)) {
    const int y = f.py(t);
    drawLine(img, f.left, y, f.right, y, kGrey);
    const std::string s = tickText(t);
    drawText(img, f.left - 6 - 6 * static_cast<int>(s.size()), y - 3, s, kBlack);
  }
  for (double t : niceTicks(f.x0, f.x1)) {
    const int x = f.left + static_cast<int>((t - f.x0) / (f.x1 - f.x0) * (f.right - f.left));
    drawLine(img, x, f.top, x, f.bottom, kGrey);
    const std::string s = tickText(plot.logX ? std::pow(10.0, t) : t);
    drawText(img, x - 3 * static_cast<int>(s.size()), f.bottom + 6, s, kBlack);
  }
  drawLine(img, f.left, f.bottom, f.right, f.bottom, kBlack);
  drawLine(img, f.left, f.top, f.left, f.bottom, kBlack);
  drawText(img, f.left, 10, plot.title, kBlack, 2);
  drawText(img, (f.left + f.right) / 2 - 3 * static_cast<int>(plot.xLabel.size()), f.bottom + 22, plot.xLabel, kBlack);
  drawText(img, 4, f.top - 16, plot.yLabel, kBlack);
}

// Series `s`: its points (dots, labels, and lines between them where it connects) and its legend entry.
void drawSeries(bake::Image& img, const Plot& plot, const PlotFrame& f, size_t s) {
  const PlotSeries& series = plot.series[s];
  int lastX = 0, lastY = 0;
  bool have = false;
  for (const auto& p : plot.points) {
    if (p.series != static_cast<int>(s) || !plottable(plot, p)) continue;
    const int x = f.px(p.x), y = f.py(p.y);
    if (have && series.connect) drawLine(img, lastX, lastY, x, y, series.color);
    for (int dy = -3; dy <= 3; ++dy)
      for (int dx = -3; dx <= 3; ++dx)
        if (dx * dx + dy * dy <= 9) setPixel(img, x + dx, y + dy, series.color);
    drawText(img, x + 5, y - 10, p.label, series.color);
    lastX = x;
    lastY = y;
    have = true;
  }
  // Legend, top right (inside the axes, or in the margin right of them).
  const int ly = f.top + 4 + static_cast<int>(s) * 12;
  const int lx = plot.legendOutside ? f.right + 20 : f.right - 6 * static_cast<int>(series.name.size()) - 16;
  for (int dy = -2; dy <= 2; ++dy)
    for (int dx = -2; dx <= 2; ++dx) setPixel(img, lx - 8 + dx, ly + 3 + dy, series.color);
  drawText(img, lx, ly, series.name, series.color);
}

}  // namespace

bake::Image renderPlot(const Plot& plot, uint32_t width, uint32_t height) {
  bake::Image img;
  img.width = width;
  img.height = height;
  img.rgba.assign(size_t(width) * height * 4, 1.0f);
  const PlotFrame frame = frameFor(plot, width, height);
  drawAxes(img, plot, frame);
  for (size_t s = 0; s < plot.series.size(); ++s) drawSeries(img, plot, frame, s);
  return img;
}

bake::Image sideBySide(const std::vector<const bake::Image*>& images, uint32_t gap) {
  bake::Image out;
  for (const auto* im : images) {
    out.width += im->width;
    out.height = std::max(out.height, im->height);
  }
  if (!images.empty()) out.width += gap * static_cast<uint32_t>(images.size() - 1);
  out.rgba.assign(size_t(out.width) * out.height * 4, 1.0f);
  uint32_t x0 = 0;
  for (const auto* im : images) {
    for (uint32_t y = 0; y < im->height; ++y)
      for (uint32_t x = 0; x < im->width; ++x)
        for (int c = 0; c < 4; ++c)
          out.rgba[(size_t(y) * out.width + x0 + x) * 4 + size_t(c)] = im->rgba[(size_t(y) * im->width + x) * 4 + size_t(c)];
    x0 += im->width + gap;
  }
  return out;
}

}  // namespace shrefract::report

// Scatter plots written as images, with axes, ticks and labels in a built-in 5x7 bitmap font, so
// the report needs no plotting library.
#pragma once

#include <shrefract/assets/image.h>

#include <array>
#include <string>
#include <vector>

namespace shrefract::report {

struct PlotPoint {
  double x = 0.0;
  double y = 0.0;
  std::string label;  // drawn next to the point
  int series = 0;     // index into Plot::series
};

struct PlotSeries {
  std::string name;
  std::array<float, 3> color{0.0f, 0.0f, 0.0f};
  bool connect = true;  // draw lines between the series' points in the order given
};

struct Plot {
  std::string title;
  std::string xLabel;
  std::string yLabel;
  bool logX = false;
  bool yFromZero = true;        // false: the y axis spans the points only (with a margin)
  bool legendOutside = false;   // the legend in a margin right of the axes, not over them
  std::vector<PlotSeries> series;
  std::vector<PlotPoint> points;
};

// Renders the plot into a width x height image (white background). Non-finite points are skipped.
bake::Image renderPlot(const Plot& plot, uint32_t width = 720, uint32_t height = 480);

// Draws `text` with its top-left corner at (x, y), `scale` pixels per font pixel.
void drawText(bake::Image& image, int x, int y, const std::string& text, std::array<float, 3> color, int scale = 1);

// Places images side by side with `gap` white pixels between them; heights may differ.
bake::Image sideBySide(const std::vector<const bake::Image*>& images, uint32_t gap = 8);

}  // namespace shrefract::report

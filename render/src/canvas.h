// Internal: an off-screen OpenGL canvas (OSMesa, legacy fixed-function GL) with FreeType text.
// Coordinates are logical pixels, origin at the top-left, y down; the canvas draws at
// `kSupersample`× and box-filters down, which anti-aliases lines, markers and text alike.
#pragma once

#include <array>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "hexsim/common/status.h"
#include "hexsim/render/image.h"
#include "hexsim/render/plot.h"

namespace hexsim::render::internal {

inline constexpr int kSupersample = 2;
inline constexpr int kMinSize_px = 16;
inline constexpr int kMaxSize_px = 8192;

enum class HAlign { kLeft, kCenter, kRight };
enum class VAlign { kTop, kMiddle, kBottom };

struct TextExtent {
  double width_px = 0.0;
  double height_px = 0.0;  // ascender − descender of the font at this size
};

using Pt = std::array<double, 2>;

class Canvas {
 public:
  // Takes the process-wide renderer lock for the canvas's lifetime.
  static Result<std::unique_ptr<Canvas>> Create(int width, int height);
  ~Canvas();
  Canvas(const Canvas&) = delete;
  Canvas& operator=(const Canvas&) = delete;

  int width() const { return width_; }
  int height() const { return height_; }

  // Restricts drawing to a rectangle (logical px); Unclip() lifts it.
  void Clip(double x0, double y0, double x1, double y1);
  void Unclip();

  void FillRect(double x0, double y0, double x1, double y1, Colour c);
  void FillQuad(const Pt& a, const Pt& b, const Pt& c, const Pt& d, Colour colour);
  void StrokeRect(double x0, double y0, double x1, double y1, Colour c, double width_px);
  void Line(double x0, double y0, double x1, double y1, Colour c, double width_px, bool dashed = false);
  // A polyline; a point with a non-finite coordinate breaks it.
  void Polyline(const std::vector<Pt>& points, Colour c, double width_px, bool dashed = false);
  // Filled discs (markers) of diameter `diameter_px`, skipping non-finite points.
  void Discs(const std::vector<Pt>& centres, Colour c, double diameter_px);

  TextExtent Measure(const std::string& utf8, double size_px);
  // Draws text anchored at (x, y). `vertical`: rotated 90° anticlockwise (reads bottom to top);
  // the alignment then refers to the rotated box.
  void Text(const std::string& utf8, double x, double y, double size_px, Colour c, HAlign h, VAlign v,
            bool vertical = false);

  // Finishes drawing and returns the downsampled image.
  Image Finish();

 private:
  Canvas(int width, int height, std::unique_lock<std::mutex> lock);
  double Dev(double logical) const { return logical * kSupersample; }
  void Rasterise(const std::string& utf8, int size_dev, std::vector<uint8_t>* coverage, int* w, int* h,
                 int* baseline_from_top);

  int width_ = 0, height_ = 0;
  std::unique_lock<std::mutex> lock_;
  std::vector<uint8_t> buffer_;  // device pixels, RGBA, bottom row first
};

}  // namespace hexsim::render::internal

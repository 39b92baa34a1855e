// RGBA8 images and PNG files.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hexsim/common/status.h"

namespace hexsim::render {

// An 8-bit RGBA image, rows stored top to bottom (row 0 is the top of the picture).
struct Rgba8 {
  uint8_t r = 0, g = 0, b = 0, a = 255;
  bool operator==(const Rgba8& o) const { return r == o.r && g == o.g && b == o.b && a == o.a; }
};

struct Image {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> rgba;  // width * height * 4 bytes

  Image() = default;
  Image(int w, int h, Rgba8 fill = {255, 255, 255, 255});
  bool empty() const { return width <= 0 || height <= 0; }
  // Pixel at column x, row y (y = 0 is the top row). Must be inside the image.
  Rgba8 At(int x, int y) const;
  void Set(int x, int y, Rgba8 c);
};

// Encodes as PNG (8-bit RGBA) in memory.
Result<std::string> EncodePng(const Image& image);
// Writes `path` atomically (temporary name, then rename).
Status WritePng(const Image& image, const std::string& path);
// Reads any 8/16-bit PNG into RGBA8.
Result<Image> ReadPng(const std::string& path);

}  // namespace hexsim::render

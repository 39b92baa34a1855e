#include "canvas.h"

#define GL_GLEXT_PROTOTYPES 1
#include <GL/osmesa.h>
#include <GL/gl.h>
#include <ft2build.h>
#include FT_FREETYPE_H

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace hexsim::render::internal {
namespace {

// Font files tried in order (fonts-dejavu-core on Debian/Ubuntu; other common layouts).
constexpr const char* kFontFiles[] = {
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
};

// Process-wide renderer state: one OSMesa context and one FreeType face, made on first use.
struct Renderer {
  std::mutex mutex;
  OSMesaContext context = nullptr;
  FT_Library ft = nullptr;
  FT_Face face = nullptr;
  bool tried = false;
  std::string error;
};

Renderer& GetRenderer() {
  static Renderer* renderer = new Renderer();  // intentionally never destroyed (used until exit)
  return *renderer;
}

void InitLocked(Renderer& r) {
  if (r.tried) return;
  r.tried = true;
  const int attribs[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 0, OSMESA_STENCIL_BITS, 0,
                         OSMESA_ACCUM_BITS, 0, OSMESA_PROFILE, OSMESA_COMPAT_PROFILE, 0};
  r.context = OSMesaCreateContextAttribs(attribs, nullptr);
  if (!r.context) r.context = OSMesaCreateContextExt(OSMESA_RGBA, 0, 0, 0, nullptr);
  if (!r.context) {
    r.error = "render: cannot create an OSMesa context";
    return;
  }
  if (FT_Init_FreeType(&r.ft) != 0) {
    r.error = "render: cannot initialise FreeType";
    return;
  }
  for (const char* file : kFontFiles) {
    if (FT_New_Face(r.ft, file, 0, &r.face) == 0) return;
  }
  r.face = nullptr;
  r.error = std::string("render: font not found: ") + kFontFiles[0] + " (install fonts-dejavu-core)";
}

// Decodes UTF-8; invalid bytes become U+FFFD.
std::vector<char32_t> DecodeUtf8(const std::string& s) {
  std::vector<char32_t> out;
  for (size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    int n = 0;
    char32_t cp = 0;
    if (c < 0x80) { cp = c; n = 1; }
    else if ((c >> 5) == 0x6) { cp = c & 0x1F; n = 2; }
    else if ((c >> 4) == 0xE) { cp = c & 0x0F; n = 3; }
    else if ((c >> 3) == 0x1E) { cp = c & 0x07; n = 4; }
    else { out.push_back(0xFFFD); ++i; continue; }
    if (i + static_cast<size_t>(n) > s.size()) { out.push_back(0xFFFD); break; }
    bool ok = true;
    for (int k = 1; k < n; ++k) {
      const auto cc = static_cast<unsigned char>(s[i + static_cast<size_t>(k)]);
      if ((cc >> 6) != 0x2) ok = false;
      cp = (cp << 6) | (cc & 0x3F);
    }
    out.push_back(ok ? cp : 0xFFFD);
    i += static_cast<size_t>(n);
  }
  return out;
}

void GlColour(Colour c) { glColor4f(c.r, c.g, c.b, c.a); }

}  // namespace

Result<std::unique_ptr<Canvas>> Canvas::Create(int width, int height) {
  if (width < kMinSize_px || height < kMinSize_px || width > kMaxSize_px || height > kMaxSize_px) {
    return Status::BadInput("render: image size " + std::to_string(width) + "x" + std::to_string(height) +
                            " outside " + std::to_string(kMinSize_px) + ".." + std::to_string(kMaxSize_px));
  }
  Renderer& r = GetRenderer();
  std::unique_lock<std::mutex> lock(r.mutex);
  InitLocked(r);
  if (!r.error.empty()) return Status::Numerical(r.error);
  return std::unique_ptr<Canvas>(new Canvas(width, height, std::move(lock)));
}

Canvas::Canvas(int width, int height, std::unique_lock<std::mutex> lock)
    : width_(width), height_(height), lock_(std::move(lock)) {
  const int wd = width_ * kSupersample, hd = height_ * kSupersample;
  buffer_.assign(static_cast<size_t>(wd) * static_cast<size_t>(hd) * 4, 255);
  HEXSIM_CHECK(OSMesaMakeCurrent(GetRenderer().context, buffer_.data(), GL_UNSIGNED_BYTE, wd, hd));
  glViewport(0, 0, wd, hd);
  glMatrixMode(GL_PROJECTION);
  glLoadIdentity();
  glOrtho(0.0, width_, height_, 0.0, -1.0, 1.0);
  glMatrixMode(GL_MODELVIEW);
  glLoadIdentity();
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_SCISSOR_TEST);
  glDisable(GL_LINE_STIPPLE);
  glEnable(GL_BLEND);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glClearColor(1.0f, 1.0f, 1.0f, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT);
}

Canvas::~Canvas() { OSMesaMakeCurrent(nullptr, nullptr, GL_UNSIGNED_BYTE, 0, 0); }

void Canvas::Clip(double x0, double y0, double x1, double y1) {
  const int xd0 = static_cast<int>(std::floor(Dev(std::min(x0, x1))));
  const int xd1 = static_cast<int>(std::ceil(Dev(std::max(x0, x1))));
  const int yd0 = static_cast<int>(std::floor(Dev(std::min(y0, y1))));
  const int yd1 = static_cast<int>(std::ceil(Dev(std::max(y0, y1))));
  glEnable(GL_SCISSOR_TEST);
  glScissor(xd0, height_ * kSupersample - yd1, std::max(0, xd1 - xd0), std::max(0, yd1 - yd0));
}

void Canvas::Unclip() { glDisable(GL_SCISSOR_TEST); }

void Canvas::FillRect(double x0, double y0, double x1, double y1, Colour c) {
  GlColour(c);
  glBegin(GL_QUADS);
  glVertex2d(x0, y0);
  glVertex2d(x1, y0);
  glVertex2d(x1, y1);
  glVertex2d(x0, y1);
  glEnd();
}

void Canvas::FillQuad(const Pt& a, const Pt& b, const Pt& c, const Pt& d, Colour colour) {
  GlColour(colour);
  glBegin(GL_QUADS);
  for (const Pt* p : {&a, &b, &c, &d}) glVertex2d((*p)[0], (*p)[1]);
  glEnd();
}

void Canvas::StrokeRect(double x0, double y0, double x1, double y1, Colour c, double width_px) {
  Polyline({{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}, {x0, y0}}, c, width_px);
}

void Canvas::Line(double x0, double y0, double x1, double y1, Colour c, double width_px, bool dashed) {
  Polyline({{x0, y0}, {x1, y1}}, c, width_px, dashed);
}

void Canvas::Polyline(const std::vector<Pt>& points, Colour c, double width_px, bool dashed) {
  GlColour(c);
  glLineWidth(static_cast<GLfloat>(std::max(1.0, Dev(width_px))));
  if (dashed) {
    glEnable(GL_LINE_STIPPLE);
    glLineStipple(2 * kSupersample, 0x0F0F);  // 4 px on, 4 px off (logical)
  }
  bool open = false;
  for (const Pt& p : points) {
    const bool finite = std::isfinite(p[0]) && std::isfinite(p[1]);
    if (!finite) {
      if (open) glEnd();
      open = false;
      continue;
    }
    if (!open) glBegin(GL_LINE_STRIP);
    open = true;
    glVertex2d(p[0], p[1]);
  }
  if (open) glEnd();
  glDisable(GL_LINE_STIPPLE);
  // Round joints: wide legacy GL lines leave notches at corners; fill them with small discs.
  if (Dev(width_px) >= 3.0 && points.size() > 2 && points.size() < 20000) {
    std::vector<Pt> joints(points.begin() + 1, points.end() - 1);
    if (!dashed) Discs(joints, c, width_px);
  }
}

void Canvas::Discs(const std::vector<Pt>& centres, Colour c, double diameter_px) {
  constexpr int kSegments = 16;
  double cs[kSegments + 1], sn[kSegments + 1];
  for (int i = 0; i <= kSegments; ++i) {
    const double a = 2.0 * 3.14159265358979323846 * i / kSegments;
    cs[i] = std::cos(a) * 0.5 * diameter_px;
    sn[i] = std::sin(a) * 0.5 * diameter_px;
  }
  GlColour(c);
  glBegin(GL_TRIANGLES);
  for (const Pt& p : centres) {
    if (!std::isfinite(p[0]) || !std::isfinite(p[1])) continue;
    for (int i = 0; i < kSegments; ++i) {
      glVertex2d(p[0], p[1]);
      glVertex2d(p[0] + cs[i], p[1] + sn[i]);
      glVertex2d(p[0] + cs[i + 1], p[1] + sn[i + 1]);
    }
  }
  glEnd();
}

void Canvas::Rasterise(const std::string& utf8, int size_dev, std::vector<uint8_t>* coverage, int* w, int* h,
                       int* baseline_from_top) {
  FT_Face face = GetRenderer().face;
  FT_Set_Pixel_Sizes(face, 0, static_cast<FT_UInt>(std::max(1, size_dev)));
  const int ascender = static_cast<int>(face->size->metrics.ascender >> 6);
  const int descender = static_cast<int>(-(face->size->metrics.descender >> 6));
  const std::vector<char32_t> text = DecodeUtf8(utf8);
  // Pass 1: pen positions.
  std::vector<long> pen_x(text.size());
  long pen = 0;
  FT_UInt previous = 0;
  const bool kerning = FT_HAS_KERNING(face);
  for (size_t i = 0; i < text.size(); ++i) {
    const FT_UInt glyph = FT_Get_Char_Index(face, text[i]);
    if (kerning && previous && glyph) {
      FT_Vector delta;
      FT_Get_Kerning(face, previous, glyph, FT_KERNING_DEFAULT, &delta);
      pen += delta.x;
    }
    pen_x[i] = pen;
    if (FT_Load_Glyph(face, glyph, FT_LOAD_DEFAULT) == 0) pen += face->glyph->advance.x;
    previous = glyph;
  }
  *w = static_cast<int>((pen + 63) >> 6) + 2;
  *h = ascender + descender;
  *baseline_from_top = ascender;
  coverage->assign(static_cast<size_t>(*w) * static_cast<size_t>(*h), 0);
  // Pass 2: glyph bitmaps, max-combined.
  for (size_t i = 0; i < text.size(); ++i) {
    const FT_UInt glyph = FT_Get_Char_Index(face, text[i]);
    if (FT_Load_Glyph(face, glyph, FT_LOAD_RENDER) != 0) continue;
    const FT_Bitmap& bm = face->glyph->bitmap;
    const int ox = static_cast<int>(pen_x[i] >> 6) + face->glyph->bitmap_left;
    const int oy = ascender - face->glyph->bitmap_top;
    for (unsigned row = 0; row < bm.rows; ++row) {
      for (unsigned col = 0; col < bm.width; ++col) {
        const int x = ox + static_cast<int>(col), y = oy + static_cast<int>(row);
        if (x < 0 || y < 0 || x >= *w || y >= *h) continue;
        uint8_t& dst = (*coverage)[static_cast<size_t>(y) * static_cast<size_t>(*w) + static_cast<size_t>(x)];
        dst = std::max(dst, bm.buffer[static_cast<long>(row) * bm.pitch + static_cast<long>(col)]);
      }
    }
  }
}

TextExtent Canvas::Measure(const std::string& utf8, double size_px) {
  FT_Face face = GetRenderer().face;
  const int size_dev = static_cast<int>(std::lround(Dev(size_px)));
  FT_Set_Pixel_Sizes(face, 0, static_cast<FT_UInt>(std::max(1, size_dev)));
  const double height = static_cast<double>((face->size->metrics.ascender - face->size->metrics.descender) >> 6);
  long pen = 0;
  FT_UInt previous = 0;
  for (char32_t cp : DecodeUtf8(utf8)) {
    const FT_UInt glyph = FT_Get_Char_Index(face, cp);
    if (FT_HAS_KERNING(face) && previous && glyph) {
      FT_Vector delta;
      FT_Get_Kerning(face, previous, glyph, FT_KERNING_DEFAULT, &delta);
      pen += delta.x;
    }
    if (FT_Load_Glyph(face, glyph, FT_LOAD_DEFAULT) == 0) pen += face->glyph->advance.x;
    previous = glyph;
  }
  return {static_cast<double>(pen) / 64.0 / kSupersample, height / kSupersample};
}

void Canvas::Text(const std::string& utf8, double x, double y, double size_px, Colour c, HAlign h, VAlign v,
                  bool vertical) {
  if (utf8.empty()) return;
  std::vector<uint8_t> cov;
  int tw = 0, th = 0, baseline = 0;
  Rasterise(utf8, static_cast<int>(std::lround(Dev(size_px))), &cov, &tw, &th, &baseline);
  // Box in device pixels (bw × bh), rows top to bottom in `rgba_top`.
  const int bw = vertical ? th : tw, bh = vertical ? tw : th;
  std::vector<uint8_t> rgba(static_cast<size_t>(bw) * static_cast<size_t>(bh) * 4);
  const auto r8 = static_cast<uint8_t>(std::lround(c.r * 255.0f));
  const auto g8 = static_cast<uint8_t>(std::lround(c.g * 255.0f));
  const auto b8 = static_cast<uint8_t>(std::lround(c.b * 255.0f));
  for (int by = 0; by < bh; ++by) {
    for (int bx = 0; bx < bw; ++bx) {
      // Rotated 90° anticlockwise: box (bx, by) shows text pixel (tx, ty) = (bh-1-by, bx).
      const int tx = vertical ? bh - 1 - by : bx, ty = vertical ? bx : by;
      const uint8_t a = cov[static_cast<size_t>(ty) * static_cast<size_t>(tw) + static_cast<size_t>(tx)];
      // glDrawPixels wants the bottom row first.
      const size_t i = (static_cast<size_t>(bh - 1 - by) * static_cast<size_t>(bw) + static_cast<size_t>(bx)) * 4;
      rgba[i] = r8;
      rgba[i + 1] = g8;
      rgba[i + 2] = b8;
      rgba[i + 3] = static_cast<uint8_t>(std::lround(a * c.a));
    }
  }
  double left = Dev(x), top = Dev(y);
  if (h == HAlign::kCenter) left -= bw / 2.0;
  if (h == HAlign::kRight) left -= bw;
  if (v == VAlign::kMiddle) top -= bh / 2.0;
  if (v == VAlign::kBottom) top -= bh;
  const int hd = height_ * kSupersample;
  glWindowPos2i(static_cast<GLint>(std::lround(left)), static_cast<GLint>(std::lround(hd - top - bh)));
  glDrawPixels(bw, bh, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
}

Image Canvas::Finish() {
  glFinish();
  Image out(width_, height_);
  const int s = kSupersample, wd = width_ * s, hd = height_ * s;
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) {
      unsigned sum[3] = {0, 0, 0};
      for (int dy = 0; dy < s; ++dy) {
        const int row = hd - 1 - (y * s + dy);  // buffer is bottom row first
        const uint8_t* p = buffer_.data() + (static_cast<size_t>(row) * static_cast<size_t>(wd) +
                                             static_cast<size_t>(x * s)) * 4;
        for (int dx = 0; dx < s; ++dx, p += 4) {
          sum[0] += p[0];
          sum[1] += p[1];
          sum[2] += p[2];
        }
      }
      const unsigned n = static_cast<unsigned>(s * s);
      uint8_t* o = out.rgba.data() + (static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x)) * 4;
      o[0] = static_cast<uint8_t>((sum[0] + n / 2) / n);
      o[1] = static_cast<uint8_t>((sum[1] + n / 2) / n);
      o[2] = static_cast<uint8_t>((sum[2] + n / 2) / n);
      o[3] = 255;
    }
  }
  return out;
}

}  // namespace hexsim::render::internal

#include "client/preview/contact_sheet.h"

#include <ft2build.h>
#include FT_FREETYPE_H

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include "client/preview/image_io.h"

namespace glint::client {
namespace {

constexpr uint8_t kLabelBackground = 40;  // dark grey strip under each tile
constexpr uint8_t kLabelText = 255;

// FreeType library + face, released in reverse order.
class Font {
 public:
  explicit Font(int pixel_height) {
    const char *env = std::getenv("GLINT_LABEL_FONT");
    path_ = env && *env ? env : kDefaultLabelFont;
    if (FT_Init_FreeType(&library_) != 0) throw std::runtime_error("FreeType: cannot initialise");
    if (FT_New_Face(library_, path_.c_str(), 0, &face_) != 0) {
      FT_Done_FreeType(library_);
      throw std::runtime_error("label font " + path_ +
                               ": cannot load (install fonts-dejavu-core or set GLINT_LABEL_FONT)");
    }
    FT_Set_Pixel_Sizes(face_, 0, static_cast<FT_UInt>(pixel_height));
  }
  ~Font() {
    FT_Done_Face(face_);
    FT_Done_FreeType(library_);
  }
  Font(const Font &) = delete;
  Font &operator=(const Font &) = delete;

  // Advance width of `text` in pixels.
  int Measure(const std::string &text) {
    int width = 0;
    for (unsigned char c : text) {
      if (FT_Load_Char(face_, c, FT_LOAD_DEFAULT) == 0) {
        width += static_cast<int>(face_->glyph->advance.x >> 6);
      }
    }
    return width;
  }

  // Draws `text` (Latin-1 bytes) with its baseline at `baseline`, starting at x0, clipped to
  // [clip_x0, clip_x1) x [clip_y0, clip_y1), blending kLabelText over the background by the
  // glyph coverage.
  void Draw(const std::string &text, int x0, int baseline, std::vector<uint8_t> *rgb, int width,
            int clip_x0, int clip_x1, int clip_y0, int clip_y1) {
    int pen = x0;
    for (unsigned char c : text) {
      if (FT_Load_Char(face_, c, FT_LOAD_RENDER) != 0) continue;
      const FT_GlyphSlot g = face_->glyph;
      const FT_Bitmap &bm = g->bitmap;
      for (unsigned row = 0; row < bm.rows; ++row) {
        const int y = baseline - g->bitmap_top + static_cast<int>(row);
        if (y < clip_y0 || y >= clip_y1) continue;
        for (unsigned col = 0; col < bm.width; ++col) {
          const int x = pen + g->bitmap_left + static_cast<int>(col);
          if (x < clip_x0 || x >= clip_x1) continue;
          const uint8_t a = bm.buffer[row * static_cast<unsigned>(bm.pitch) + col];
          for (int k = 0; k < 3; ++k) {
            uint8_t &dst = (*rgb)[3 * (static_cast<size_t>(y) * width + x) + k];
            dst = static_cast<uint8_t>((dst * (255 - a) + kLabelText * a + 127) / 255);
          }
        }
      }
      pen += static_cast<int>(g->advance.x >> 6);
    }
  }

  int ascender() const { return static_cast<int>(face_->size->metrics.ascender >> 6); }
  int descender() const { return static_cast<int>(face_->size->metrics.descender >> 6); }

 private:
  std::string path_;
  FT_Library library_ = nullptr;
  FT_Face face_ = nullptr;
};

}  // namespace

ContactSheetLayout LayoutContactSheet(int count, int tile_width, int tile_height) {
  ContactSheetLayout l;
  l.columns = std::max(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(count)))));
  l.rows = std::max(1, (count + l.columns - 1) / l.columns);
  l.tile_width = tile_width;
  l.tile_height = tile_height;
  l.label_height = std::clamp(tile_height / 10, 16, 48);
  return l;
}

void WriteContactSheet(const std::string &path, const ContactSheetLayout &layout,
                       const std::vector<std::vector<uint8_t>> &tiles,
                       const std::vector<std::string> &labels) {
  if (tiles.size() != labels.size() ||
      tiles.size() > static_cast<size_t>(layout.columns) * static_cast<size_t>(layout.rows)) {
    throw std::runtime_error("contact sheet " + path + ": " + std::to_string(tiles.size()) +
                             " tiles, " + std::to_string(labels.size()) + " labels for a " +
                             std::to_string(layout.columns) + "x" + std::to_string(layout.rows) +
                             " grid");
  }
  const int w = layout.width(), h = layout.height();
  const size_t tile_bytes =
      size_t{3} * static_cast<size_t>(layout.tile_width) * static_cast<size_t>(layout.tile_height);
  std::vector<uint8_t> sheet(size_t{3} * static_cast<size_t>(w) * static_cast<size_t>(h),
                             kLabelBackground);
  Font font(std::max(8, layout.label_height * 5 / 8));
  for (size_t i = 0; i < tiles.size(); ++i) {
    if (tiles[i].size() != tile_bytes) {
      throw std::runtime_error("contact sheet " + path + ": tile " + std::to_string(i) + " (" +
                               labels[i] + ") is not " + std::to_string(layout.tile_width) + "x" +
                               std::to_string(layout.tile_height) + " RGB");
    }
    const int cx = static_cast<int>(i) % layout.columns;
    const int cy = static_cast<int>(i) / layout.columns;
    const int x0 = cx * layout.tile_width;
    const int y0 = cy * (layout.tile_height + layout.label_height);
    for (int y = 0; y < layout.tile_height; ++y) {
      std::copy_n(&tiles[i][3 * static_cast<size_t>(y) * layout.tile_width],
                  3 * static_cast<size_t>(layout.tile_width),
                  &sheet[3 * (static_cast<size_t>(y0 + y) * w + x0)]);
    }
    // The label, centred in its strip; shortened from the right with "..." if too wide.
    std::string text = labels[i];
    const int margin = 4;
    const int room = layout.tile_width - 2 * margin;
    if (font.Measure(text) > room) {
      while (!text.empty() && font.Measure(text + "...") > room) text.pop_back();
      text += "...";
    }
    const int text_w = font.Measure(text);
    const int strip_y0 = y0 + layout.tile_height;
    const int baseline = strip_y0 + (layout.label_height + font.ascender() + font.descender()) / 2;
    font.Draw(text, x0 + std::max(margin, (layout.tile_width - text_w) / 2), baseline, &sheet, w,
              x0, x0 + layout.tile_width, strip_y0, strip_y0 + layout.label_height);
  }
  WritePngRgb8(path, w, h, sheet);
}

}  // namespace glint::client

// A contact sheet: tone-mapped previews side by side on a grid, each with its label (the
// material's name) drawn below it in DejaVu Sans with FreeType (Debian fonts-dejavu-core,
// libfreetype).
#ifndef GLINT_CLIENT_PREVIEW_CONTACT_SHEET_H
#define GLINT_CLIENT_PREVIEW_CONTACT_SHEET_H

#include <cstdint>
#include <string>
#include <vector>

namespace glint::client {

// The font the labels are drawn with; override with the environment variable GLINT_LABEL_FONT.
inline constexpr const char *kDefaultLabelFont = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

struct ContactSheetLayout {
  int columns = 0, rows = 0;
  int tile_width = 0, tile_height = 0;  // one preview
  int label_height = 0;                 // strip below each preview
  int width() const { return columns * tile_width; }
  int height() const { return rows * (tile_height + label_height); }
};

// columns = ceil(sqrt(count)), rows = ceil(count / columns); the label strip is
// clamp(tile_height / 10, 16, 48) pixels high.
ContactSheetLayout LayoutContactSheet(int count, int tile_width, int tile_height);

// tiles: 8-bit sRGB RGB images (image_io.h ToneMapToSrgb8), all tile_width x tile_height, in
// reading order; labels: one per tile, drawn white on dark grey, shortened with "..." when
// wider than the tile. Writes the sheet as a PNG. Throws std::runtime_error naming the path
// (or the font) on failure.
void WriteContactSheet(const std::string &path, const ContactSheetLayout &layout,
                       const std::vector<std::vector<uint8_t>> &tiles,
                       const std::vector<std::string> &labels);

}  // namespace glint::client

#endif  // GLINT_CLIENT_PREVIEW_CONTACT_SHEET_H

// Named float channels of a single-part OpenEXR file, read and written with OpenEXR's general
// interface (Header + FrameBuffer), for multi-layer files such as a renderer's AOVs
// ("P.X", "N.R", "uv.U", ...). image_io.h covers the plain RGB case on top of the same library.
#ifndef GLINT_CLIENT_PREVIEW_EXR_LAYERS_H
#define GLINT_CLIENT_PREVIEW_EXR_LAYERS_H

#include <string>
#include <vector>

namespace glint::client {

// Pixel rectangles as OpenEXR stores them: inclusive min / max corners.
struct ExrWindow {
  int min_x = 0, min_y = 0, max_x = -1, max_y = -1;
  int width() const { return max_x - min_x + 1; }
  int height() const { return max_y - min_y + 1; }
};

struct ExrChannelInfo {
  std::string name;
  int x_sampling = 1, y_sampling = 1;
};

// The header of a file: its windows and channels (in the file's order, i.e. sorted by name).
// Throws std::runtime_error naming the path when the file cannot be opened.
struct ExrHeaderInfo {
  ExrWindow data_window, display_window;
  std::vector<ExrChannelInfo> channels;
  int parts = 1;
};
ExrHeaderInfo ReadExrHeader(const std::string &path);

// Reads the named channels of part 0 over the data window as float planes (width * height each,
// row-major, top row first; half and uint are converted by the library). Throws
// std::runtime_error naming the path and the channel when one is missing or subsampled.
std::vector<std::vector<float>> ReadExrChannels(const std::string &path,
                                                const std::vector<std::string> &names,
                                                ExrWindow *data_window = nullptr);

// One plane to write: `data` holds data_window.width() * data_window.height() floats.
struct ExrPlane {
  std::string name;
  const float *data = nullptr;
};

// Writes the planes as FLOAT (or HALF) channels, ZIP compression, scanlines. Throws
// std::runtime_error naming the path on failure.
void WriteExrChannels(const std::string &path, const ExrWindow &data_window,
                      const ExrWindow &display_window, const std::vector<ExrPlane> &planes,
                      bool half_float = false);

}  // namespace glint::client

#endif  // GLINT_CLIENT_PREVIEW_EXR_LAYERS_H

#include "client/preview/exr_layers.h"

#include <ImfChannelList.h>
#include <ImfCompression.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfMultiPartInputFile.h>
#include <ImfOutputFile.h>
#include <half.h>

#include <stdexcept>

namespace glint::client {
namespace {

ExrWindow FromBox(const Imath::Box2i &b) {
  return {b.min.x, b.min.y, b.max.x, b.max.y};
}
Imath::Box2i ToBox(const ExrWindow &w) {
  return Imath::Box2i(Imath::V2i(w.min_x, w.min_y), Imath::V2i(w.max_x, w.max_y));
}

}  // namespace

ExrHeaderInfo ReadExrHeader(const std::string &path) {
  try {
    Imf::MultiPartInputFile multi(path.c_str());
    ExrHeaderInfo info;
    info.parts = multi.parts();
    const Imf::Header &header = multi.header(0);
    info.data_window = FromBox(header.dataWindow());
    info.display_window = FromBox(header.displayWindow());
    for (auto it = header.channels().begin(); it != header.channels().end(); ++it) {
      info.channels.push_back({it.name(), it.channel().xSampling, it.channel().ySampling});
    }
    return info;
  } catch (const std::exception &e) {
    throw std::runtime_error(path + ": cannot read as OpenEXR: " + e.what());
  }
}

std::vector<std::vector<float>> ReadExrChannels(const std::string &path,
                                                const std::vector<std::string> &names,
                                                ExrWindow *data_window) {
  try {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i dw = file.header().dataWindow();
    const ExrWindow window = FromBox(dw);
    const size_t w = static_cast<size_t>(window.width());
    const size_t h = static_cast<size_t>(window.height());
    std::vector<std::vector<float>> planes;
    Imf::FrameBuffer frame;
    planes.reserve(names.size());
    for (const std::string &name : names) {
      const Imf::Channel *channel = file.header().channels().findChannel(name);
      if (channel == nullptr) throw std::runtime_error("no channel '" + name + "'");
      if (channel->xSampling != 1 || channel->ySampling != 1) {
        throw std::runtime_error(
            "channel '" + name + "' is subsampled (" + std::to_string(channel->xSampling) + "x" +
            std::to_string(channel->ySampling) + "); every layer must have the image's full size");
      }
      planes.emplace_back(w * h, 0.0f);
      frame.insert(name, Imf::Slice::Make(Imf::FLOAT, planes.back().data(), dw, sizeof(float),
                                          sizeof(float) * w));
    }
    file.setFrameBuffer(frame);
    file.readPixels(dw.min.y, dw.max.y);
    if (data_window) *data_window = window;
    return planes;
  } catch (const std::exception &e) {
    throw std::runtime_error(path + ": " + e.what());
  }
}

void WriteExrChannels(const std::string &path, const ExrWindow &data_window,
                      const ExrWindow &display_window, const std::vector<ExrPlane> &planes,
                      bool half_float) {
  if (data_window.width() <= 0 || data_window.height() <= 0) {
    throw std::runtime_error(path + ": image size must be positive");
  }
  const size_t w = static_cast<size_t>(data_window.width());
  const size_t pixels = w * static_cast<size_t>(data_window.height());
  const Imf::PixelType type = half_float ? Imf::HALF : Imf::FLOAT;
  std::vector<std::vector<Imath::half>> halves;
  try {
    Imf::Header header(ToBox(display_window), ToBox(data_window));
    header.compression() = Imf::ZIP_COMPRESSION;
    Imf::FrameBuffer frame;
    for (const ExrPlane &plane : planes) {
      header.channels().insert(plane.name, Imf::Channel(type));
      char *base = nullptr;
      if (half_float) {
        // Values above 65504 become +Inf in half: the format's limit, not clamped here.
        halves.emplace_back(plane.data, plane.data + pixels);
        base = reinterpret_cast<char *>(halves.back().data());
      } else {
        // The library only reads through the slice pointer; Slice takes char* either way.
        base = reinterpret_cast<char *>(const_cast<float *>(plane.data));
      }
      const size_t component = half_float ? sizeof(Imath::half) : sizeof(float);
      frame.insert(plane.name,
                   Imf::Slice::Make(type, base, ToBox(data_window), component, component * w));
    }
    Imf::OutputFile file(path.c_str(), header);
    file.setFrameBuffer(frame);
    file.writePixels(data_window.height());
  } catch (const std::exception &e) {
    throw std::runtime_error(path + ": cannot write OpenEXR: " + e.what());
  }
}

}  // namespace glint::client

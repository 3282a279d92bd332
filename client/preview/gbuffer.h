// A renderer's G-buffer (multi-layer OpenEXR: world position, shading normal, optional tangent,
// uv, optional view vector and footprint, optional alpha) turned into one glint query per
// covered pixel, so that `glint render` shades a renderer's frame with a glint material.
//
// Layers and channels. A layer is a channel-name prefix; its channels are
//   P, N, T, V (3 components)   <layer>.X .Y .Z  or  <layer>.R .G .B   (upper or lower case)
//   uv (2 components)           <layer>.U .V  or  .X .Y  or  .R .G      (upper or lower case)
//   footprint (optional)        <prefix>dudx, <prefix>dvdx, <prefix>dudy, <prefix>dvdy, all four
//   alpha (optional)            one channel, default "A"
// Default layer names are P, N, T, uv, V and A; GBufferLayers / ParseLayerMapping rename them,
// e.g. for Blender Cycles "P=ViewLayer.Position,N=ViewLayer.Normal,uv=ViewLayer.UV,
// A=ViewLayer.Combined.A".
//
// Per covered pixel (GBufferQueries):
//   - background: alpha == 0 when there is an alpha channel, else a normal of exactly (0, 0, 0);
//     background pixels get no query (and black in the beauty);
//   - position, uv as written; normal (and V, and T) as written when they are unit to float
//     rounding (| |n| - 1 | <= kGBufferUnitSlack), else normalised in double: half-float and
//     filtered AOVs are never exactly unit, and a unit float vector must not be perturbed;
//   - tangent: T made orthogonal to N (Gram-Schmidt) and unit; without a T layer, the direction
//     of dp/du recovered from the screen-space derivatives of P and uv,
//       [dP/dx dP/dy] = [dp/du dp/dv] J,  J = [[du/dx, du/dy], [dv/dx, dv/dy]],
//     so dp/du = (dP/dx dv/dy - dP/dy dv/dx) / det J (the tangent the preview scenes use:
//     increasing u), made orthogonal to N; a world axis when J is singular;
//   - wo: from the V layer, or normalize(camera - P) computed in double from the float P;
//   - footprint (du/dx, dv/dx, du/dy, dv/dy per pixel along +x and +y = one row DOWN, as in
//     preview_scene.h): from the footprint channels when present, else from the uv of the
//     neighbouring pixels along each axis:
//       both neighbours covered: central difference (uv[+1] - uv[-1]) / 2 (second-order
//         accurate), unless the two one-sided differences d- and d+ differ by more than the
//         longer of them (|d+ - d-| > max(|d-|, |d+|): the uv jumps, at a texture seam or
//         where another surface starts), then the shorter one-sided difference;
//       one neighbour covered (image edge, silhouette): that one-sided difference;
//       none: 0 (no filtering along that axis).
//     Differences are taken in double from the float uv and rounded to float once.
#ifndef GLINT_CLIENT_PREVIEW_GBUFFER_H
#define GLINT_CLIENT_PREVIEW_GBUFFER_H

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "client/preview/exr_layers.h"
#include "client/preview/preview_scene.h"

namespace glint::client {

// A unit vector rounded to float has | |n| - 1 | <= 2^-24 (each component's relative error is
// at most 2^-24) and, if orthogonal to another rounded unit vector before rounding, a dot
// product of at most 2 * 2^-24 with it; twice that leaves room for the double arithmetic.
inline constexpr double kGBufferUnitSlack = 0x1p-22;

struct GBufferLayers {
  std::string position = "P";
  std::string normal = "N";
  std::string tangent = "T";  // optional layer
  std::string uv = "uv";
  std::string view = "V";      // optional layer: unit vector from the surface to the eye
  std::string alpha = "A";     // optional channel (a full channel name)
  std::string footprint = "";  // channel-name prefix of dudx, dvdx, dudy, dvdy (optional)
};

// Applies "KEY=NAME[,KEY=NAME...]" with KEY one of P, N, T, uv, V, A, footprint. Returns false
// and sets `error` on an unknown key, a repeated key or a missing '='.
bool ParseLayerMapping(const std::string &text, GBufferLayers *layers, std::string *error);

// Planes are width * height * components floats, row-major, top row first; optional ones are
// empty when the file has no such layer.
struct GBuffer {
  ExrWindow data_window, display_window;
  int width = 0, height = 0;
  std::vector<float> position, normal, uv;  // 3, 3, 2 per pixel
  std::vector<float> tangent, view;         // 3 per pixel, optional
  std::vector<float> footprint;             // 4 per pixel (dudx, dvdx, dudy, dvdy), optional
  std::vector<float> alpha;                 // 1 per pixel, optional
  std::string source;                       // file name for error messages
  // Channel names actually read, per layer, for messages: e.g. "P.X,P.Y,P.Z".
  std::string position_channels, normal_channels, tangent_channels, uv_channels, view_channels,
      footprint_channels, alpha_channel;
};

// Reads a G-buffer. Throws std::runtime_error naming the file and the layer when a required
// layer (P, N, uv) is missing (listing the channels the file has), when an optional layer is
// incomplete (e.g. dudx without dvdy, T.X without T.Z), when a layer is subsampled (not the
// image's size), or when the file is multi-part (only the first part would be read).
GBuffer ReadGBuffer(const std::string &path, const GBufferLayers &layers = {});

// Writes P, N, T, uv, V, dudx..dvdy and A (those present) with the default names.
void WriteGBuffer(const std::string &path, const GBuffer &gbuffer);

bool IsBackground(const GBuffer &gbuffer, size_t pixel);

// One query per covered pixel, in row-major order (see the header comment for the rules).
// `camera` gives wo; without it the G-buffer must have a V layer. Throws std::runtime_error
// naming the file, layer and pixel (x, y in data-window coordinates) for a non-finite value in
// a covered pixel, and naming the file when neither a camera nor a V layer is available.
PreviewQueries GBufferQueries(const GBuffer &gbuffer,
                              const std::optional<std::array<double, 3>> &camera);

// The G-buffer of a preview scene: every query's position, normal, tangent, uv, wo (as V) and
// footprint at its pixel, alpha 1 there and 0 elsewhere. GBufferQueries of it (without a
// camera) reproduces `scene.queries` exactly.
GBuffer PreviewGBuffer(const PreviewQueries &scene);

}  // namespace glint::client

#endif  // GLINT_CLIENT_PREVIEW_GBUFFER_H

// glint preview. One material: one Evaluate (unary or streamed). A batch (--material given
// several times, or --materials DIR, or --contact-sheet): the scene's queries are built once
// and every material is evaluated over ONE EvaluateStream (client/lib/evaluate_series.h); each
// material's EXR and PNG are written by a writer thread while the next material is evaluated.
#include "client/cli/preview_command.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>
#include <set>
#include <stdexcept>
#include <thread>

#include "client/cli/normal_map_commands.h"
#include "client/lib/evaluate_series.h"
#include "client/lib/query_io.h"
#include "client/preview/contact_sheet.h"
#include "client/preview/gbuffer.h"
#include "client/preview/image_io.h"
#include "client/preview/preview_scene.h"

namespace glint::cli {

const char *const kPreviewUsage =
    R"(usage: glint preview --server ADDR --material M.json --lights L.json --out IMG.exr
                     [--scene sphere|plane] [--size WxH] [--exposure STOPS]
                     [--precision fp32|fp64] [--seed N] [--half] [--gbuffer-out G.exr]
                     [--area-method ltc|reference|lecocq|lecocq-pearson|mc|auto] [--samples N]
                     [--max-error E]
       glint preview --server ADDR (--material A.json --material B.json ... | --materials DIR)
                     --lights L.json --out IMG.exr [--contact-sheet SHEET.png] [options above]

Renders the material on a unit sphere or a ground plane seen by a fixed pinhole camera (one
query per covered pixel, with ray-differential footprints) under world-space lights. Writes
IMG.exr (linear radiance) and IMG.png next to it (tone-mapped sRGB) and prints both paths.

Batch: with several --material, with --materials DIR (every *.json in DIR, by name) or with
--contact-sheet, every material is rendered over one connection and one stream (the scene is
set up once), material STEM.json going to IMG_STEM.exr and IMG_STEM.png; --contact-sheet adds
a PNG of all previews on a grid, each labelled with its STEM. Prints the throughput.

  --server ADDR       gRPC target, e.g. 127.0.0.1:50051
  --material M.json   glint.v1.Material in proto3 JSON (repeat for a batch)
  --materials DIR     a batch of every *.json in DIR
  --lights L.json     glint.v1.LightList in proto3 JSON (world space, +z up)
  --out IMG.exr       output EXR; the PNG gets the same name with .png
  --contact-sheet S   batch: write the labelled contact sheet S (.png)
  --gbuffer-out G     also write the scene's G-buffer (P, N, T, uv, V, dudx..dvdy, A) for
                      'glint render'
  --scene S           sphere (default) or plane
  --size WxH          image size in pixels (default 512x512)
  --exposure STOPS    PNG exposure in stops, scale 2^STOPS (default 0)
  --precision P       fp32 (default) or fp64
  --seed N            seed of the stochastic glint models (default 0)
  --area-method M     polygon lights: ltc (default), lecocq, lecocq-pearson (Lecocq et al.
                      peak fits), mc (Monte Carlo, seeded), reference (quadrature) or
                      auto (the cheapest meeting --max-error)
  --samples N         reference: quadrature nodes per dimension per triangle; mc: samples
                      per query and light (default 64)
  --max-error E       --area-method auto: the relative error allowed per query and light
                      (e.g. 0.05); the server picks the cheapest method predicted to meet it
  --half              store half floats in the EXR instead of float32
  --normal-map FILE   NORMAL_MAP materials: use FILE (EXR / PNG) as material.normal_map.digest,
                      uploading it when the server does not hold it
)";

const std::vector<std::string> kPreviewOptions = {
    "server",        "material",    "materials",  "lights",   "out",         "scene",
    "size",          "exposure",    "precision",  "seed",     "area-method", "samples",
    "contact-sheet", "gbuffer-out", "normal-map", "max-error"};

namespace {

namespace fs = std::filesystem;

struct PreviewSetup {
  std::string server, lights_path, out, scene_name;
  glint::client::PreviewShape shape = glint::client::PreviewShape::kSphere;
  int width = 0, height = 0;
  float exposure = 0.0f;
  bool half = false;
};

PreviewSetup ParseSetup(const Options &options) {
  PreviewSetup s;
  s.server = options.Required("server");
  s.lights_path = options.Required("lights");
  s.out = options.Required("out");
  if (glint::client::OutputFormatFromPath(s.out) != glint::client::OutputFormat::kExr) {
    throw UsageError{"--out " + s.out + ": preview writes an .exr (and a .png beside it)"};
  }
  s.scene_name = options.Get("scene", "sphere");
  if (!glint::client::ParsePreviewShape(s.scene_name, &s.shape)) {
    throw UsageError{"--scene: '" + s.scene_name + "' is neither sphere nor plane"};
  }
  const std::string size = options.Get("size", "512x512");
  if (!ParseSize(size, &s.width, &s.height)) {
    throw UsageError{"--size: '" + size + "' is not WIDTHxHEIGHT with positive integers"};
  }
  s.exposure = ParseNumber<float>("exposure", options.Get("exposure", "0"));
  if (!std::isfinite(s.exposure)) throw UsageError{"--exposure must be finite"};
  s.half = options.Has("half");
  return s;
}

// IMG.exr -> IMG.png
std::string PngBeside(const std::string &exr) {
  return exr.substr(0, exr.size() - 4) + ".png";
}

void WriteGBufferIfAsked(const Options &options, const glint::client::PreviewQueries &scene) {
  if (!options.Has("gbuffer-out")) return;
  const std::string path = options.Required("gbuffer-out");
  glint::client::WriteGBuffer(path, glint::client::PreviewGBuffer(scene));
  std::printf("%s\n", path.c_str());
}

int RunSingle(const Options &options) {
  const PreviewSetup s = ParseSetup(options);
  const std::string material_path = options.Required("material");

  glint::v1::EvaluateRequest request;
  FillSettings(options, &request);
  *request.mutable_material() = glint::client::ReadMaterialJson(material_path);
  if (options.Has("normal-map"))
    AttachNormalMap(s.server, ConnectionOptions(options), options.Required("normal-map"),
                    request.mutable_material());
  for (auto &light : glint::client::ReadLightsJson(s.lights_path)) {
    *request.add_lights() = std::move(light);
  }
  glint::client::PreviewQueries scene =
      glint::client::BuildPreviewQueries(s.shape, s.width, s.height);
  *request.mutable_queries() = scene.queries;

  glint::client::GlintClient client(s.server, ConnectionOptions(options));
  std::vector<float> rgb;
  glint::client::EvaluateInfo info;
  double seconds = 0.0;
  if (request.queries().count() > 0) {
    const std::optional<double> t = EvaluateWithProgress(client, request, &rgb, &info, s.server);
    if (!t) return kExitFailure;
    seconds = *t;
  }
  const std::vector<float> image = glint::client::ScatterToImage(scene, rgb);
  glint::client::WriteExrRgb(s.out, s.width, s.height, image, s.half);
  const std::string png = PngBeside(s.out);
  glint::client::WritePngToneMapped(png, s.width, s.height, image, s.exposure);
  std::printf("glint preview: %s %dx%d, %u queries in %.3f s via %s\n", s.scene_name.c_str(),
              s.width, s.height, request.queries().count(), seconds, Transport(info).c_str());
  std::printf("%s\n%s\n", s.out.c_str(), png.c_str());
  WriteGBufferIfAsked(options, scene);
  return kExitOk;
}

// Every --material, then every *.json of --materials DIR sorted by name.
std::vector<std::string> BatchMaterials(const Options &options) {
  std::vector<std::string> paths = options.GetAll("material");
  if (options.Has("materials")) {
    const std::string dir = options.Required("materials");
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) throw UsageError{"--materials " + dir + ": not a directory"};
    std::vector<std::string> found;
    for (const auto &entry : fs::directory_iterator(dir, ec)) {
      if (entry.is_regular_file() && entry.path().extension() == ".json") {
        found.push_back(entry.path().string());
      }
    }
    if (ec) throw UsageError{"--materials " + dir + ": " + ec.message()};
    if (found.empty()) throw UsageError{"--materials " + dir + ": no *.json files"};
    std::sort(found.begin(), found.end());
    paths.insert(paths.end(), found.begin(), found.end());
  }
  if (paths.empty()) throw UsageError{"missing --material or --materials"};
  return paths;
}

// Runs jobs on one background thread in order, so that writing a material's EXR and PNG
// overlaps evaluating the next one (the server waits for us to read each chunk).
class BackgroundWriter {
 public:
  BackgroundWriter() : thread_([this] { Loop(); }) {}
  ~BackgroundWriter() { Finish(); }

  void Post(std::function<void()> job) {
    std::lock_guard<std::mutex> lock(mutex_);
    jobs_.push_back(std::move(job));
    cv_.notify_one();
  }
  // Waits for every job; returns the first error message ("" if none).
  std::string Finish() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done_ = true;
      cv_.notify_one();
    }
    if (thread_.joinable()) thread_.join();
    return error_;
  }

 private:
  void Loop() {
    for (;;) {
      std::function<void()> job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        cv_.wait(lock, [&] { return done_ || !jobs_.empty(); });
        if (jobs_.empty()) return;
        job = std::move(jobs_.front());
        jobs_.pop_front();
      }
      try {
        if (error_.empty()) job();
      } catch (const std::exception &e) {
        error_ = e.what();
      }
    }
  }
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> jobs_;
  bool done_ = false;
  std::string error_;
  std::thread thread_;
};

int RunBatch(const Options &options) {
  const auto start = std::chrono::steady_clock::now();
  const PreviewSetup s = ParseSetup(options);
  const std::vector<std::string> material_paths = BatchMaterials(options);
  const std::string sheet = options.Get("contact-sheet", "");
  if (options.Has("contact-sheet") && sheet.empty()) throw UsageError{"missing --contact-sheet"};

  // Materials first, so that a typo fails before any work; stems name the outputs.
  std::vector<std::string> stems;
  std::set<std::string> seen;
  glint::v1::EvaluateRequest base;
  FillSettings(options, &base);
  for (auto &light : glint::client::ReadLightsJson(s.lights_path)) *base.add_lights() = light;
  std::vector<glint::v1::EvaluateRequest> settings;
  for (const std::string &path : material_paths) {
    const std::string stem = fs::path(path).stem().string();
    if (!seen.insert(stem).second) {
      throw UsageError{"two materials named '" + stem + "' (" + path +
                       "): their outputs would overwrite each other"};
    }
    stems.push_back(stem);
    settings.push_back(base);
    *settings.back().mutable_material() = glint::client::ReadMaterialJson(path);
    // Only the batch's NORMAL_MAP materials take the map; the others would refuse its field.
    if (options.Has("normal-map") && settings.back().material().model() == glint::v1::NORMAL_MAP)
      AttachNormalMap(s.server, ConnectionOptions(options), options.Required("normal-map"),
                      settings.back().mutable_material());
  }
  // The outputs are written while the stream runs: a missing directory must fail up front,
  // not after every material has been evaluated.
  for (const std::string &path : {s.out, sheet}) {
    const fs::path dir = fs::path(path).parent_path();
    std::error_code ec;
    if (!path.empty() && !dir.empty() && !fs::is_directory(dir, ec)) {
      throw std::runtime_error(path + ": directory " + dir.string() + " does not exist");
    }
  }
  const glint::client::PreviewQueries scene =
      glint::client::BuildPreviewQueries(s.shape, s.width, s.height);
  WriteGBufferIfAsked(options, scene);
  const std::string stem_base = s.out.substr(0, s.out.size() - 4);

  glint::client::GlintClient client(s.server, ConnectionOptions(options));
  const glint::client::ContactSheetLayout layout =
      glint::client::LayoutContactSheet(static_cast<int>(stems.size()), s.width, s.height);
  std::vector<std::vector<uint8_t>> tiles(stems.size());
  std::vector<std::string> written;
  BackgroundWriter writer;
  auto deliver = [&](size_t k, std::vector<float> &&rgb) {
    const std::string exr = stem_base + "_" + stems[k] + ".exr";
    written.push_back(exr);
    writer.Post([&, k, exr, rgb = std::move(rgb)] {
      const std::vector<float> image = glint::client::ScatterToImage(scene, rgb);
      glint::client::WriteExrRgb(exr, s.width, s.height, image, s.half);
      tiles[k] = glint::client::ToneMapToSrgb8(s.width, s.height, image, s.exposure);
      glint::client::WritePngRgb8(PngBeside(exr), s.width, s.height, tiles[k]);
    });
  };

  ProgressBar bar;
  const auto eval_start = std::chrono::steady_clock::now();
  glint::client::SeriesInfo info;
  const grpc::Status status = glint::client::EvaluateSeries(
      client, settings, scene.queries, deliver,
      [&](uint64_t done, uint64_t total) { bar.Update(done, total); }, &info);
  const std::chrono::duration<double> eval_seconds = std::chrono::steady_clock::now() - eval_start;
  bar.Finish();
  const std::string write_error = writer.Finish();
  if (!status.ok()) {
    ReportRpcError("evaluation failed after " + std::to_string(written.size()) + " of " +
                       std::to_string(stems.size()) + " materials (at " +
                       material_paths[std::min(written.size(), stems.size() - 1)] + ")",
                   status, s.server);
    return kExitFailure;
  }
  if (!write_error.empty()) {
    std::fprintf(stderr, "glint: %s\n", write_error.c_str());
    return kExitFailure;
  }
  if (!sheet.empty()) glint::client::WriteContactSheet(sheet, layout, tiles, stems);
  const std::chrono::duration<double> total = std::chrono::steady_clock::now() - start;

  const uint64_t queries = uint64_t{scene.queries.count()} * stems.size();
  const double t = total.count();
  std::printf(
      "glint preview: %zu materials, %s %dx%d, %u queries each, one stream of %llu chunks of <= "
      "%u queries\n",
      stems.size(), s.scene_name.c_str(), s.width, s.height, scene.queries.count(),
      static_cast<unsigned long long>(info.chunks), info.chunk_queries);
  std::printf(
      "glint preview: throughput %.2f materials/s, %.0f queries/s (%.3f s in all, %.3f s "
      "evaluating)\n",
      t > 0 ? static_cast<double>(stems.size()) / t : 0.0,
      t > 0 ? static_cast<double>(queries) / t : 0.0, t, eval_seconds.count());
  for (const std::string &exr : written)
    std::printf("%s\n%s\n", exr.c_str(), PngBeside(exr).c_str());
  if (!sheet.empty()) std::printf("%s\n", sheet.c_str());
  return kExitOk;
}

}  // namespace

int RunPreview(const Options &options) {
  const bool batch = options.GetAll("material").size() > 1 || options.Has("materials") ||
                     options.Has("contact-sheet");
  return batch ? RunBatch(options) : RunSingle(options);
}

}  // namespace glint::cli

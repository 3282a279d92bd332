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
a PNG of all rendered previews on a grid, each labelled with its STEM. Prints the throughput.
A material the server refuses (e.g. BINOMIAL under a light without a cone, a request over the
cost limits) or a NORMAL_MAP material without --normal-map is skipped and the others are
rendered; the run ends with a list of the materials not rendered and why, on stderr, and exits
1 if there are any. A failure of the server or the connection stops the batch there.

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

// Why a material of a batch was not rendered, for the summary.
struct NotRendered {
  size_t material;
  std::string why;
};

// Whether `status`, ending a series at one material, is the server's refusal of that material's
// request (INVALID_ARGUMENT: a field of the material or its lights, e.g. BINOMIAL without a
// light cone; NOT_FOUND: its normal map; FAILED_PRECONDITION; RESOURCE_EXHAUSTED naming a
// request cost limit: its work): the batch skips it and goes on. Anything else (the server or
// the connection failed, the server is full, a deadline passed) would meet the next materials
// too: the batch stops there.
bool RefusesTheMaterial(const grpc::Status &status) {
  switch (status.error_code()) {
    case grpc::StatusCode::INVALID_ARGUMENT:
    case grpc::StatusCode::NOT_FOUND:
    case grpc::StatusCode::FAILED_PRECONDITION:
    case grpc::StatusCode::OUT_OF_RANGE:
      return true;
    case grpc::StatusCode::RESOURCE_EXHAUSTED:  // "server busy" may pass later: not the material
      return status.error_message().find("request cost") != std::string::npos;
    default:
      return false;
  }
}

// The server's status without its "chunk N: " prefix (N counts the chunks of one stream, which
// means nothing to the reader of the summary; the material is named instead).
std::string WithoutChunkPrefix(const grpc::Status &status) {
  std::string message = status.error_message();
  if (message.rfind("chunk ", 0) == 0) {
    const size_t colon = message.find(": ");
    if (colon != std::string::npos && message.find_first_not_of("0123456789", 6) == colon)
      message = message.substr(colon + 2);
  }
  return glint::client::FormatStatus(grpc::Status(status.error_code(), message));
}

// A batch (several --material, --materials DIR or --contact-sheet): every material over one
// stream; a material the server refuses (or that needs --normal-map) is skipped and the others
// are still rendered, over a new stream from the next one on (the server ends a stream at its
// first refusal). The run ends with a summary of what was not rendered and why, and exits 1 if
// anything was not (a TD rendering 200 previews overnight gets the other 199).
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
  std::vector<NotRendered> not_rendered;
  std::vector<size_t> pending;  // materials still to render, in order
  for (const std::string &path : material_paths) {
    const std::string stem = fs::path(path).stem().string();
    if (!seen.insert(stem).second) {
      throw UsageError{"two materials named '" + stem + "' (" + path +
                       "): their outputs would overwrite each other"};
    }
    stems.push_back(stem);
    settings.push_back(base);
    *settings.back().mutable_material() = glint::client::ReadMaterialJson(path);
    glint::v1::Material *material = settings.back().mutable_material();
    // Only the batch's NORMAL_MAP materials take the map; the others would refuse its field.
    if (material->model() == glint::v1::NORMAL_MAP) {
      if (options.Has("normal-map")) {
        AttachNormalMap(s.server, ConnectionOptions(options), options.Required("normal-map"),
                        material);
      } else if (material->normal_map().digest().empty()) {
        // The server would refuse it too ("material.normal_map: unset"); the CLI knows the fix.
        not_rendered.push_back({stems.size() - 1,
                                "skipped: a NORMAL_MAP material needs a normal map: pass "
                                "--normal-map FILE (EXR / PNG), or set normal_map.digest to "
                                "what 'glint upload' prints"});
        continue;
      }
    }
    pending.push_back(stems.size() - 1);
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
  std::vector<std::vector<uint8_t>> tiles(stems.size());
  std::vector<size_t> rendered;  // in order
  std::vector<std::string> written;
  BackgroundWriter writer;
  const uint64_t per_material = scene.queries.count();
  const uint64_t all_queries = per_material * pending.size();
  uint64_t done_before = 0;  // queries of the streams before this one
  ProgressBar bar;
  const auto eval_start = std::chrono::steady_clock::now();
  glint::client::SeriesInfo info;  // of the first stream (the chunk size is the same in all)
  uint64_t chunks = 0;
  int streams = 0;
  bool stopped = false;
  while (!pending.empty() && !stopped) {
    std::vector<glint::v1::EvaluateRequest> part;
    for (size_t k : pending) part.push_back(settings[k]);
    auto deliver = [&](size_t local, std::vector<float> &&rgb) {
      const size_t k = pending[local];
      const std::string exr = stem_base + "_" + stems[k] + ".exr";
      written.push_back(exr);
      rendered.push_back(k);
      writer.Post([&, k, exr, rgb = std::move(rgb)] {
        const std::vector<float> image = glint::client::ScatterToImage(scene, rgb);
        glint::client::WriteExrRgb(exr, s.width, s.height, image, s.half);
        tiles[k] = glint::client::ToneMapToSrgb8(s.width, s.height, image, s.exposure);
        glint::client::WritePngRgb8(PngBeside(exr), s.width, s.height, tiles[k]);
      });
    };
    glint::client::SeriesInfo this_stream;
    const grpc::Status status = glint::client::EvaluateSeries(
        client, part, scene.queries, deliver,
        [&](uint64_t done, uint64_t) { bar.Update(done_before + done, all_queries); },
        &this_stream);
    if (streams++ == 0) info = this_stream;
    chunks += this_stream.chunks;
    const size_t delivered = std::min(this_stream.delivered, pending.size());
    if (status.ok() && delivered == pending.size()) break;
    if (status.ok()) {  // cannot happen (EvaluateSeries checks the chunk count); stop honestly
      stopped = true;
      for (size_t i = delivered; i < pending.size(); ++i)
        not_rendered.push_back({pending[i], "not rendered: the stream ended early"});
      break;
    }
    const size_t failed = pending[delivered];
    const std::string why = WithoutChunkPrefix(status);
    if (RefusesTheMaterial(status)) {
      not_rendered.push_back({failed, "skipped: " + why});
    } else {
      stopped = true;
      ReportRpcError("preview of " + material_paths[failed] + " failed", status, s.server);
      for (size_t i = delivered; i < pending.size(); ++i)
        not_rendered.push_back(
            {pending[i], i == delivered ? "failed: " + why
                                        : "not attempted: the batch stopped at " + stems[failed]});
    }
    done_before += per_material * (delivered + 1);
    pending.erase(pending.begin(), pending.begin() + static_cast<std::ptrdiff_t>(delivered) + 1);
  }
  const std::chrono::duration<double> eval_seconds = std::chrono::steady_clock::now() - eval_start;
  bar.Finish();
  const std::string write_error = writer.Finish();
  if (!write_error.empty()) {
    std::fprintf(stderr, "glint: %s\n", write_error.c_str());
    return kExitFailure;
  }
  // The sheet holds the rendered materials, in order; the summary names the others.
  if (!sheet.empty() && !rendered.empty()) {
    std::vector<std::vector<uint8_t>> sheet_tiles;
    std::vector<std::string> labels;
    for (size_t k : rendered) {
      sheet_tiles.push_back(std::move(tiles[k]));
      labels.push_back(stems[k]);
    }
    glint::client::WriteContactSheet(
        sheet,
        glint::client::LayoutContactSheet(static_cast<int>(rendered.size()), s.width, s.height),
        sheet_tiles, labels);
  }
  const std::chrono::duration<double> total = std::chrono::steady_clock::now() - start;

  const uint64_t queries = per_material * rendered.size();
  const double t = total.count();
  std::string count = std::to_string(rendered.size());
  if (rendered.size() != stems.size()) count += " of " + std::to_string(stems.size());
  std::printf(
      "glint preview: %s materials, %s %dx%d, %u queries each, %d stream%s of %llu chunks of <= "
      "%u queries\n",
      count.c_str(), s.scene_name.c_str(), s.width, s.height, scene.queries.count(), streams,
      streams == 1 ? "" : "s", static_cast<unsigned long long>(chunks), info.chunk_queries);
  std::printf(
      "glint preview: throughput %.2f materials/s, %.0f queries/s (%.3f s in all, %.3f s "
      "evaluating)\n",
      t > 0 ? static_cast<double>(rendered.size()) / t : 0.0,
      t > 0 ? static_cast<double>(queries) / t : 0.0, t, eval_seconds.count());
  for (const std::string &exr : written)
    std::printf("%s\n%s\n", exr.c_str(), PngBeside(exr).c_str());
  if (!sheet.empty() && !rendered.empty()) std::printf("%s\n", sheet.c_str());
  if (not_rendered.empty()) return kExitOk;
  std::sort(not_rendered.begin(), not_rendered.end(),
            [](const NotRendered &a, const NotRendered &b) { return a.material < b.material; });
  std::fprintf(stderr, "glint preview: %zu of %zu materials not rendered:\n", not_rendered.size(),
               stems.size());
  for (const NotRendered &n : not_rendered)
    std::fprintf(stderr, "  %s (%s): %s\n", stems[n.material].c_str(),
                 material_paths[n.material].c_str(), n.why.c_str());
  return kExitFailure;
}

}  // namespace

int RunPreview(const Options &options) {
  const bool batch = options.GetAll("material").size() > 1 || options.Has("materials") ||
                     options.Has("contact-sheet");
  return batch ? RunBatch(options) : RunSingle(options);
}

}  // namespace glint::cli

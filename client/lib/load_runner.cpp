#include "client/lib/load_runner.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <memory>
#include <mutex>
#include <numbers>
#include <thread>
#include <vector>

#include "client/lib/percentile.h"
#include "glint/v1/glint.grpc.pb.h"

namespace glint::client {
namespace {

using Clock = std::chrono::steady_clock;

// What one thread saw; merged under no lock once the threads are joined.
struct ThreadTally {
  std::vector<double> latencies_ms;  // successful requests only
  uint64_t refused = 0;
  uint64_t errors = 0;
  std::string first_error;

  void Fail(const grpc::Status &status) {
    if (status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) {
      ++refused;
    } else {
      ++errors;
    }
    if (first_error.empty()) first_error = FormatStatus(status);
  }
};

double MsBetween(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

// Shared by the threads of one level: the time limit and the request budget.
class Budget {
 public:
  Budget(Clock::time_point stop, uint64_t max) : stop_(stop), max_(max) {}
  // True when the caller may send one more request (and takes it from the budget).
  bool Take() { return Clock::now() < stop_ && issued_.fetch_add(1) < max_; }

 private:
  Clock::time_point stop_;
  uint64_t max_;
  std::atomic<uint64_t> issued_{0};
};

void UnaryWorker(GlintClient &client, const LoadConfig &config, Budget &budget,
                 ThreadTally &tally) {
  std::vector<float> radiance;
  while (budget.Take()) {
    const auto t0 = Clock::now();
    const grpc::Status status = client.Evaluate(config.request, &radiance);
    const auto t1 = Clock::now();
    if (status.ok()) {
      tally.latencies_ms.push_back(MsBetween(t0, t1));
    } else {
      tally.Fail(status);
    }
  }
}

void StreamWorker(GlintClient &client, const LoadConfig &config, Budget &budget,
                  ThreadTally &tally) {
  auto stub = glint::v1::GlintService::NewStub(client.channel());
  // Built once: chunk 0 carries the settings, later chunks only the queries.
  glint::v1::EvaluateChunk first;
  *first.mutable_request() = config.request;
  glint::v1::EvaluateChunk later;
  *later.mutable_request()->mutable_queries() = config.request.queries();
  const uint64_t floats = uint64_t{config.request.queries().count()} * 3;

  bool more = budget.Take();
  while (more) {  // one stream per iteration; a new one after the server ended the last
    grpc::ClientContext context;
    client.PrepareContext(&context);
    if (config.timeout.count() > 0) {
      context.set_deadline(
          std::chrono::system_clock::now() +
          std::chrono::duration_cast<std::chrono::system_clock::duration>(config.duration) +
          config.timeout);
    }
    auto stream = stub->EvaluateStream(&context);
    uint64_t index = 0;
    bool broken = false;
    glint::v1::EvaluateChunkResult result;
    for (; more; more = budget.Take()) {
      glint::v1::EvaluateChunk &chunk = index == 0 ? first : later;
      chunk.set_chunk_index(index);
      const auto t0 = Clock::now();
      if (!stream->Write(chunk) || !stream->Read(&result)) {
        broken = true;  // the server ended the stream; Finish says why
        more = budget.Take();
        break;
      }
      const auto t1 = Clock::now();
      if (result.chunk_index() != index ||
          static_cast<uint64_t>(result.result().radiance_size()) != floats) {
        tally.Fail(grpc::Status(grpc::StatusCode::INTERNAL,
                                "stream answered chunk " + std::to_string(result.chunk_index()) +
                                    " with " + std::to_string(result.result().radiance_size()) +
                                    " floats; expected chunk " + std::to_string(index) + " with " +
                                    std::to_string(floats)));
        context.TryCancel();
        broken = true;
        more = budget.Take();
        break;
      }
      tally.latencies_ms.push_back(MsBetween(t0, t1));
      ++index;
    }
    if (!broken) stream->WritesDone();
    while (broken && stream->Read(&result)) {
    }
    const grpc::Status status = stream->Finish();
    if (broken && !status.ok()) {
      tally.Fail(status);
    } else if (broken && index == 0) {
      // Ended OK without answering the chunk it was sent: a protocol failure, not a success.
      tally.Fail(grpc::Status(grpc::StatusCode::DATA_LOSS, "stream ended without an answer"));
    }
  }
}

std::string Number(double v) {
  if (!std::isfinite(v)) return "nan";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

}  // namespace

LoadLevelResult RunLoadLevel(GlintClient &client, const LoadConfig &config, int concurrency) {
  LoadLevelResult r;
  r.concurrency = concurrency;
  if (concurrency < 1) return r;
  const auto start = Clock::now();
  Budget budget(start + std::chrono::duration_cast<Clock::duration>(config.duration),
                config.requests_max);
  std::vector<ThreadTally> tallies(static_cast<size_t>(concurrency));
  std::vector<std::thread> threads;
  threads.reserve(tallies.size());
  for (ThreadTally &tally : tallies) {
    threads.emplace_back([&] {
      if (config.stream) {
        StreamWorker(client, config, budget, tally);
      } else {
        UnaryWorker(client, config, budget, tally);
      }
    });
  }
  for (std::thread &t : threads) t.join();
  r.seconds = std::chrono::duration<double>(Clock::now() - start).count();

  std::vector<double> latencies;
  for (const ThreadTally &t : tallies) {
    latencies.insert(latencies.end(), t.latencies_ms.begin(), t.latencies_ms.end());
    r.refused += t.refused;
    r.errors += t.errors;
    if (r.first_error.empty()) r.first_error = t.first_error;
  }
  r.ok = latencies.size();
  if (r.seconds > 0.0) {
    r.requests_per_s = static_cast<double>(r.ok) / r.seconds;
    r.queries_per_s = r.requests_per_s * static_cast<double>(config.request.queries().count());
  }
  double sum = 0.0;
  for (const double l : latencies) sum += l;
  r.mean_ms = latencies.empty() ? std::nan("") : sum / static_cast<double>(latencies.size());
  const std::vector<double> p = NearestRankPercentiles(std::move(latencies), {50, 90, 95, 99});
  r.p50_ms = p[0];
  r.p90_ms = p[1];
  r.p95_ms = p[2];
  r.p99_ms = p[3];
  return r;
}

glint::v1::QueryBatch MakeLoadQueries(uint32_t n, bool with_wi) {
  glint::v1::QueryBatch q;
  q.set_count(n);
  q.mutable_uv()->Reserve(static_cast<int>(n) * 2);
  q.mutable_footprint()->Resize(static_cast<int>(n) * 4, 0.0f);
  q.mutable_wo()->Reserve(static_cast<int>(n) * 3);
  if (with_wi) q.mutable_wi()->Reserve(static_cast<int>(n) * 3);
  // Golden-angle spiral over cos(theta) in [0.1, 1): evenly spread, never grazing, no RNG.
  constexpr double kGolden = 2.399963229728653;  // pi (3 - sqrt 5)
  auto direction = [&](uint32_t i, double offset, google::protobuf::RepeatedField<float> *out) {
    const double t = (static_cast<double>(i) + offset) / static_cast<double>(n);
    const double cos_theta = 0.1 + 0.9 * (t - std::floor(t));
    const double sin_theta = std::sqrt(1.0 - cos_theta * cos_theta);
    const double phi = kGolden * static_cast<double>(i) + offset * std::numbers::pi;
    out->Add(static_cast<float>(sin_theta * std::cos(phi)));
    out->Add(static_cast<float>(sin_theta * std::sin(phi)));
    out->Add(static_cast<float>(cos_theta));
  };
  for (uint32_t i = 0; i < n; ++i) {
    q.add_uv(static_cast<float>((i % 1024) / 1024.0));
    q.add_uv(static_cast<float>((i / 1024 % 1024) / 1024.0));
    direction(i, 0.25, q.mutable_wo());
    if (with_wi) direction(i, 0.75, q.mutable_wi());
  }
  return q;
}

std::string LoadCsvHeader() {
  return "concurrency,requests_per_s,queries_per_s,p50_ms,p90_ms,p99_ms,ok,refused,errors";
}

std::string LoadCsvRow(const LoadLevelResult &r) {
  return std::to_string(r.concurrency) + "," + Number(r.requests_per_s) + "," +
         Number(r.queries_per_s) + "," + Number(r.p50_ms) + "," + Number(r.p90_ms) + "," +
         Number(r.p99_ms) + "," + std::to_string(r.ok) + "," + std::to_string(r.refused) + "," +
         std::to_string(r.errors);
}

}  // namespace glint::client

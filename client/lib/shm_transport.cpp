#include "client/lib/shm_transport.h"

#include <fcntl.h>
#include <google/protobuf/util/field_mask_util.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <mutex>
#include <random>
#include <stdexcept>

namespace glint::client {
namespace {

using Floats = google::protobuf::RepeatedField<float>;

// The input blocks in SharedMemoryIo order with their floats per query.
struct Block {
  const Floats *array;
  uint32_t per;
};

std::vector<Block> Blocks(const glint::v1::QueryBatch &q) {
  return {{&q.uv(), 2},       {&q.footprint(), 4}, {&q.wo(), 3},     {&q.wi(), 3},
          {&q.position(), 3}, {&q.normal(), 3},    {&q.tangent(), 3}};
}

uint32_t FloatsPerQuery(const glint::v1::QueryBatch &q) {
  uint32_t floats = 0;
  for (const Block &b : Blocks(q))
    if (!b.array->empty()) floats += b.per;
  return floats;
}

// Output after the input, at a 64-byte boundary.
size_t OutputOffset(size_t input_bytes) {
  return (input_bytes + 63) / 64 * 64;
}

std::string UniqueSuffix() {
  static std::atomic<uint64_t> counter{0};
  std::random_device rd;
  return std::to_string(getpid()) + "-" + std::to_string(counter++) + "-" +
         std::to_string(uint64_t(rd()) << 32 | rd());
}

// Every field of `request` but the queries (a copy of those would cost as much as the transfer
// saved).
glint::v1::EvaluateRequest SettingsOf(const glint::v1::EvaluateRequest &request) {
  glint::v1::EvaluateRequest call;
  google::protobuf::FieldMask settings;
  const google::protobuf::Descriptor *d = request.GetDescriptor();
  for (int i = 0; i < d->field_count(); ++i)
    if (d->field(i)->name() != "queries") settings.add_paths(d->field(i)->name());
  google::protobuf::util::FieldMaskUtil::MergeMessageTo(
      request, settings, google::protobuf::util::FieldMaskUtil::MergeOptions(), &call);
  return call;
}

}  // namespace

Transport ParseTransport(const std::string &name) {
  if (name == "auto") return Transport::kAuto;
  if (name == "tcp") return Transport::kTcp;
  if (name == "shm") return Transport::kShm;
  throw std::invalid_argument("--transport " + name + ": expected auto, tcp or shm");
}

bool IsSameHostAddress(const std::string &address) {
  if (address.rfind("unix:", 0) == 0 || address.rfind("unix-abstract:", 0) == 0) return true;
  std::string host = address;
  for (const char *scheme : {"ipv4:", "ipv6:", "dns:///", "dns:"})
    if (host.rfind(scheme, 0) == 0) host = host.substr(std::strlen(scheme));
  if (host.find(',') != std::string::npos) return false;  // several servers
  if (!host.empty() && host.front() == '[') {
    host = host.substr(
        1, host.find(']') == std::string::npos ? std::string::npos : host.find(']') - 1);
  } else if (std::count(host.begin(), host.end(), ':') == 1) {
    host = host.substr(0, host.find(':'));
  }
  return host.rfind("127.", 0) == 0 || host == "::1" || host == "localhost";
}

std::unique_ptr<ShmBuffer> ShmBuffer::Create(size_t bytes, std::string *error) {
  std::unique_ptr<ShmBuffer> b(new ShmBuffer());
  b->key_ = "/glint-" + UniqueSuffix();
  const int fd = shm_open(b->key_.c_str(), O_RDWR | O_CREAT | O_EXCL, 0600);
  if (fd < 0) {
    *error = "shm_open(" + b->key_ + "): " + std::strerror(errno);
    return nullptr;
  }
  void *map = MAP_FAILED;
  if (ftruncate(fd, off_t(bytes)) == 0)
    map = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  if (map == MAP_FAILED) *error = "ftruncate/mmap of " + b->key_ + ": " + std::strerror(errno);
  close(fd);  // the mapping keeps the object
  if (map == MAP_FAILED) {
    shm_unlink(b->key_.c_str());
    return nullptr;
  }
  b->data_ = static_cast<uint8_t *>(map);
  b->size_ = bytes;
  return b;
}

ShmBuffer::~ShmBuffer() {
  if (data_) munmap(data_, size_);
  shm_unlink(key_.c_str());
}

size_t SharedMemoryInputBytes(const glint::v1::QueryBatch &q, uint32_t count) {
  return size_t(count) * FloatsPerQuery(q) * sizeof(float);
}

void PackSharedQueries(const glint::v1::QueryBatch &q, uint32_t begin, uint32_t end, uint8_t *dst,
                       glint::v1::SharedMemoryIo *io) {
  io->set_count(end - begin);
  io->set_uv(!q.uv().empty());
  io->set_footprint(!q.footprint().empty());
  io->set_wi(!q.wi().empty());
  io->set_frame(!q.normal().empty());
  uint8_t *at = dst;
  for (const Block &b : Blocks(q)) {
    if (b.array->empty()) continue;
    const size_t bytes = size_t(end - begin) * b.per * sizeof(float);
    std::memcpy(at, b.array->data() + size_t(begin) * b.per, bytes);
    at += bytes;
  }
  io->set_input_byte_size(uint64_t(at - dst));
}

ShmSession::~ShmSession() {
  Close();
}

void ShmSession::Close() {
  if (!name_.empty()) {
    auto stub = glint::v1::GlintService::NewStub(client_->channel());
    grpc::ClientContext ctx;
    client_->PrepareContext(&ctx);
    ctx.set_deadline(std::chrono::system_clock::now() + client_->options().rpc_timeout);
    glint::v1::UnregisterSharedMemoryRequest r;
    r.set_name(name_);
    glint::v1::UnregisterSharedMemoryResponse out;
    stub->UnregisterSharedMemory(&ctx, r, &out);  // best effort: the server may be gone
    name_.clear();
  }
  buffer_.reset();  // unmaps and unlinks
  piece_ = slots_ = 0;
  slot_bytes_ = 0;
  in_place_.Clear();  // its region is gone
}

grpc::Status ShmSession::FetchLimits() {
  if (max_batch_ != 0) return grpc::Status::OK;  // the server's limits do not change under it
  glint::v1::Capabilities caps;
  if (grpc::Status s = client_->GetCapabilities(&caps); !s.ok()) return s;
  if (caps.max_shared_memory_regions() == 0)
    return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION,
                        "the server offers no shared memory (Capabilities)");
  max_batch_ = std::max<uint32_t>(caps.max_batch(), 1);
  return grpc::Status::OK;
}

grpc::Status ShmSession::Reserve(size_t bytes) {
  if (buffer_ && buffer_->size() >= bytes) return grpc::Status::OK;
  Close();
  std::string error;
  buffer_ = ShmBuffer::Create(bytes, &error);
  if (!buffer_) return grpc::Status(grpc::StatusCode::INTERNAL, error);
  auto stub = glint::v1::GlintService::NewStub(client_->channel());
  grpc::ClientContext ctx;
  client_->PrepareContext(&ctx);
  ctx.set_deadline(std::chrono::system_clock::now() + client_->options().rpc_timeout);
  glint::v1::RegisterSharedMemoryRequest r;
  r.set_name("glint-" + UniqueSuffix());
  r.set_key(buffer_->key());
  r.set_offset(0);
  r.set_byte_size(bytes);
  glint::v1::RegisterSharedMemoryResponse out;
  grpc::Status s = stub->RegisterSharedMemory(&ctx, r, &out);
  if (!s.ok()) {
    buffer_.reset();
    return s;
  }
  name_ = r.name();
  return grpc::Status::OK;
}

grpc::Status ShmSession::Prepare(const glint::v1::QueryBatch &q, uint32_t count) {
  if (grpc::Status s = FetchLimits(); !s.ok()) return s;
  // This request's layout, not the largest so far: the offsets below follow from this
  // request's pieces and arrays, and only these bytes are known to fit.
  const uint32_t piece = std::min({std::max(count, 1u), max_batch_, piece_queries_});
  const uint32_t slots = count > piece ? 2 : 1;
  const size_t slot_bytes = OutputOffset(OutputOffset(SharedMemoryInputBytes(q, piece)) +
                                         size_t(piece) * 3 * sizeof(float));
  if (grpc::Status s = Reserve(slots * slot_bytes); !s.ok()) return s;
  piece_ = piece;
  slots_ = slots;
  slot_bytes_ = slot_bytes;
  return grpc::Status::OK;
}

namespace {

// One call of a pipelined Evaluate: queries [begin, end) in slot `slot`, answered asynchronously.
struct Piece {
  uint32_t begin = 0, end = 0, slot = 0;
  grpc::ClientContext ctx;
  glint::v1::EvaluateRequest call;
  glint::v1::EvaluateResponse response;
  grpc::Status status;
  bool done = false;
};

}  // namespace

grpc::Status ShmSession::Evaluate(const glint::v1::EvaluateRequest &request,
                                  std::vector<float> *radiance, ProgressFn progress,
                                  EvaluateInfo *info) {
  const glint::v1::QueryBatch &q = request.queries();
  const uint32_t n = q.count();
  radiance->resize(size_t(n) * 3);  // every element is written below
  if (n == 0) return grpc::Status::OK;
  if (grpc::Status s = Prepare(q, n); !s.ok()) return s;
  auto stub = glint::v1::GlintService::NewStub(client_->channel());
  // The settings once; each call carries them and a SharedMemoryIo naming its slot.
  const glint::v1::EvaluateRequest settings = SettingsOf(request);
  const size_t out_in_slot = OutputOffset(SharedMemoryInputBytes(q, piece_));
  std::mutex mu;
  std::condition_variable answered;
  std::deque<std::unique_ptr<Piece>> flight;  // oldest first
  uint32_t next = 0;
  uint64_t calls = 0;
  // Packs the next piece into `slot` and sends it; the answer arrives on gRPC's thread.
  auto launch = [&](uint32_t slot) {
    auto p = std::make_unique<Piece>();
    p->begin = next;
    p->end = std::min(n, next + piece_);
    p->slot = slot;
    next = p->end;
    p->call = settings;
    uint8_t *base = buffer_->data() + size_t(slot) * slot_bytes_;
    glint::v1::SharedMemoryIo *io = p->call.mutable_shared_memory();
    PackSharedQueries(q, p->begin, p->end, base, io);
    io->set_input_region(name_);
    io->set_input_offset(uint64_t(slot) * slot_bytes_);
    io->set_output_region(name_);
    io->set_output_offset(uint64_t(slot) * slot_bytes_ + out_in_slot);
    client_->PrepareContext(&p->ctx);
    if (client_->options().evaluate_timeout.count() > 0)
      p->ctx.set_deadline(std::chrono::system_clock::now() + client_->options().evaluate_timeout);
    Piece *raw = p.get();
    flight.push_back(std::move(p));
    stub->async()->Evaluate(&raw->ctx, &raw->call, &raw->response,
                            [raw, &mu, &answered](grpc::Status s) {
                              std::lock_guard<std::mutex> lock(mu);
                              raw->status = std::move(s);
                              raw->done = true;
                              answered.notify_all();
                            });
  };
  auto wait = [&](Piece *p) {
    std::unique_lock<std::mutex> lock(mu);
    answered.wait(lock, [p] { return p->done; });
  };
  for (uint32_t slot = 0; slot < slots_ && next < n; ++slot) launch(slot);
  grpc::Status failure;
  while (!flight.empty()) {
    Piece *p = flight.front().get();
    wait(p);
    if (p->status.ok() && p->response.count() != p->end - p->begin)
      p->status =
          grpc::Status(grpc::StatusCode::INTERNAL,
                       "shared-memory Evaluate answered " + std::to_string(p->response.count()) +
                           " queries; expected " + std::to_string(p->end - p->begin));
    if (!p->status.ok()) {
      // The server counts query indices from the piece's first query: say where it lies.
      failure = n > piece_
                    ? grpc::Status(p->status.error_code(),
                                   "shared-memory call for queries [" + std::to_string(p->begin) +
                                       ", " + std::to_string(p->end) +
                                       ") of the batch: " + p->status.error_message())
                    : p->status;
      // The other piece's call is awaited, not cancelled: its answer comes once glintd has
      // written its radiance, so no write of it can land in the region after we return (a
      // cancelled call answers at once while its slice may still be running).
      for (auto &other : flight) wait(other.get());
      break;
    }
    std::memcpy(radiance->data() + size_t(p->begin) * 3,
                buffer_->data() + size_t(p->slot) * slot_bytes_ + out_in_slot,
                size_t(p->end - p->begin) * 3 * sizeof(float));
    ++calls;
    if (info) info->device = p->response.stats().device();
    if (progress) progress(p->end, n);
    const uint32_t slot = p->slot;
    flight.pop_front();
    if (next < n) launch(slot);  // the slot just read out takes the next piece
  }
  if (!failure.ok()) return failure;
  if (info) {
    info->streamed = false;
    info->chunks = calls;
    info->chunk_queries = piece_;
    info->attempts = 1;
  }
  return grpc::Status::OK;
}

grpc::Status ShmSession::PrepareInPlace(const glint::v1::QueryBatch &shape, uint32_t count,
                                        InPlaceBlocks *blocks) {
  in_place_.Clear();
  if (count == 0)
    return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "count: 0; expected at least 1");
  if (shape.wo().empty())
    return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                        "shape.wo: empty; every query has wo (give shape one value in it)");
  if (grpc::Status s = FetchLimits(); !s.ok()) return s;
  if (count > max_batch_)
    return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                        "count: " + std::to_string(count) + " exceeds the server's max_batch " +
                            std::to_string(max_batch_) + " (one in-place call)");
  // One slot of `count` queries at offset 0 (not Evaluate's pipelined layout).
  const size_t in_bytes = SharedMemoryInputBytes(shape, count);
  if (grpc::Status s = Reserve(OutputOffset(in_bytes) + size_t(count) * 3 * sizeof(float)); !s.ok())
    return s;
  piece_ = slots_ = 0;  // Evaluate lays the region out again (Prepare)
  *blocks = InPlaceBlocks();
  blocks->count = count;
  float *at = reinterpret_cast<float *>(buffer_->data());
  float **fields[] = {&blocks->uv,       &blocks->footprint, &blocks->wo,     &blocks->wi,
                      &blocks->position, &blocks->normal,    &blocks->tangent};
  size_t k = 0;
  for (const Block &b : Blocks(shape)) {  // SharedMemoryIo order, as PackSharedQueries
    if (!b.array->empty()) {
      *fields[k] = at;
      at += size_t(count) * b.per;
    }
    ++k;
  }
  blocks->radiance = reinterpret_cast<const float *>(buffer_->data() + OutputOffset(in_bytes));
  in_place_.set_count(count);
  in_place_.set_uv(!shape.uv().empty());
  in_place_.set_footprint(!shape.footprint().empty());
  in_place_.set_wi(!shape.wi().empty());
  in_place_.set_frame(!shape.normal().empty());
  in_place_.set_input_byte_size(in_bytes);
  in_place_.set_input_region(name_);
  in_place_.set_input_offset(0);
  in_place_.set_output_region(name_);
  in_place_.set_output_offset(OutputOffset(in_bytes));
  return grpc::Status::OK;
}

grpc::Status ShmSession::EvaluateInPlace(const glint::v1::EvaluateRequest &settings,
                                         EvaluateInfo *info) {
  if (in_place_.count() == 0 || name_.empty())
    return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION,
                        "EvaluateInPlace: call PrepareInPlace first");
  glint::v1::EvaluateRequest call = SettingsOf(settings);
  *call.mutable_shared_memory() = in_place_;
  auto stub = glint::v1::GlintService::NewStub(client_->channel());
  grpc::ClientContext ctx;
  client_->PrepareContext(&ctx);
  if (client_->options().evaluate_timeout.count() > 0)
    ctx.set_deadline(std::chrono::system_clock::now() + client_->options().evaluate_timeout);
  glint::v1::EvaluateResponse response;
  grpc::Status s = stub->Evaluate(&ctx, call, &response);
  if (!s.ok()) return s;
  if (response.count() != in_place_.count())
    return grpc::Status(grpc::StatusCode::INTERNAL,
                        "shared-memory Evaluate answered " + std::to_string(response.count()) +
                            " queries; expected " + std::to_string(in_place_.count()));
  if (info) {
    info->device = response.stats().device();
    info->streamed = false;
    info->chunks = 1;
    info->chunk_queries = in_place_.count();
    info->attempts = 1;
  }
  return grpc::Status::OK;
}

grpc::Status EvaluateWithTransport(GlintClient &client, Transport transport,
                                   const glint::v1::EvaluateRequest &request,
                                   std::vector<float> *radiance, ProgressFn progress,
                                   EvaluateInfo *info, std::string *used) {
  if (transport == Transport::kShm ||
      (transport == Transport::kAuto && IsSameHostAddress(client.address()))) {
    ShmSession session(&client);
    grpc::Status s = session.Prepare(request.queries(), std::max(request.queries().count(), 1u));
    if (s.ok()) {
      if (used) *used = "shm";
      return session.Evaluate(request, radiance, progress, info);
    }
    if (transport == Transport::kShm) return s;
    // Unreachable: TCP would fail the same way (after its own retries); say so once.
    if (s.error_code() == grpc::StatusCode::UNAVAILABLE ||
        s.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED ||
        s.error_code() == grpc::StatusCode::UNAUTHENTICATED)
      return s;
    // auto: the server cannot open our objects (another host behind a loopback proxy, shared
    // memory disabled, an older server): the arrays go over the connection instead.
  }
  if (used) *used = "tcp";
  return client.Evaluate(request, radiance, progress, info);
}

}  // namespace glint::client

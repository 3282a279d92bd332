// The windows of a shared-memory Evaluate (server/shm_io.h ResolveSharedMemoryCall), checked
// without a server: the registry maps real POSIX objects of this process.
//  - an output window that shares a byte of the object with the input window is flagged
//    (SharedMemoryCall::windows_overlap), whether both lie in one region or in two regions
//    registered over the same object at different window offsets (the overlap is a property of
//    the object's bytes, not of the region-relative offsets), and such a call is never
//    evaluated in place (EvaluatesInPlace): in place, the kernels read the queries while
//    writing the radiance and evaluated some queries from other queries' radiance: 37,497 of
//    200,000 SMOOTH probes wrong with the output 4 bytes after the input, and ~4,600 of them
//    different from run to run with it 12,000 bytes after (session 9 outside-client probe,
//    Python multiprocessing.shared_memory). Copied first, the call is correct
//    (tests/service/shm_test.cpp OverlappingWindowsGiveTheArrayResults);
//  - windows that touch but do not overlap, and the same offsets in two different objects, are
//    not flagged;
//  - an offset near 2^64 is refused with that offset, not a wrapped range end.
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <utility>

#include "client/lib/shm_transport.h"
#include "server/shm_io.h"
#include "server/shm_regions.h"

namespace {

using glint::Status;
using glint::client::ShmBuffer;
using glint::v1::SharedMemoryIo;

constexpr uint32_t kCount = 1000;
constexpr uint64_t kInBytes = uint64_t(kCount) * 6 * 4;  // wo and wi blocks: 6 floats a query
constexpr uint64_t kOutBytes = uint64_t(kCount) * 3 * 4;

std::unique_ptr<ShmBuffer> Object(size_t bytes) {
  std::string error;
  auto b = ShmBuffer::Create(bytes, &error);
  EXPECT_TRUE(b) << error;
  return b;
}

void Register(glint::ShmRegistry *registry, const std::string &name, const ShmBuffer &object,
              uint64_t offset, uint64_t bytes) {
  glint::v1::RegisterSharedMemoryRequest r;
  r.set_name(name);
  r.set_key(object.key());
  r.set_offset(offset);
  r.set_byte_size(bytes);
  const Status s = registry->Register("", r);
  ASSERT_TRUE(s.ok()) << s.message();
}

// A probe batch (wo, wi) of kCount queries at `in_offset` of `in`, radiance to `out`.
SharedMemoryIo Io(const std::string &in, uint64_t in_offset, const std::string &out,
                  uint64_t out_offset) {
  SharedMemoryIo io;
  io.set_count(kCount);
  io.set_wi(true);
  io.set_input_region(in);
  io.set_input_offset(in_offset);
  io.set_input_byte_size(kInBytes);
  io.set_output_region(out);
  io.set_output_offset(out_offset);
  return io;
}

Status Resolve(const glint::ShmRegistry &registry, const SharedMemoryIo &io,
               bool *overlap = nullptr) {
  glint::SharedMemoryCall call;
  const Status s = glint::ResolveSharedMemoryCall(registry, "", io, &call);
  if (overlap) *overlap = call.windows_overlap;
  return s;
}

// Whether Resolve accepts `io` and flags its windows as overlapping.
bool Overlaps(const glint::ShmRegistry &registry, const SharedMemoryIo &io) {
  bool overlap = false;
  const Status s = Resolve(registry, io, &overlap);
  EXPECT_TRUE(s.ok()) << s.message();
  return overlap;
}

// A SMOOTH probe request: the one shape that is evaluated in place when it may be.
glint::v1::EvaluateRequest SmoothProbes() {
  glint::v1::EvaluateRequest r;
  r.mutable_material()->set_model(glint::v1::SMOOTH);
  return r;
}

bool Mentions(const Status &s, const std::string &text) {
  return s.message().find(text) != std::string::npos;
}

TEST(ShmWindows, OutputOverlappingTheInputInOneRegionIsCopiedNotReadInPlace) {
  auto object = Object(kInBytes + kOutBytes);
  glint::ShmRegistry registry;
  Register(&registry, "io", *object, 0, kInBytes + kOutBytes);
  // Every shift of the output by 997 floats across the input overlaps, up to the first offset
  // past the input; the last float of the input too.
  for (uint64_t out = 0; out < kInBytes; out += 4 * 997)
    EXPECT_TRUE(Overlaps(registry, Io("io", 0, "io", out))) << "output at " << out;
  EXPECT_TRUE(Overlaps(registry, Io("io", 0, "io", kInBytes - 4)));
  // Output just before or just after the input: touching is not overlapping.
  EXPECT_FALSE(Overlaps(registry, Io("io", 0, "io", kInBytes)));
  EXPECT_FALSE(Overlaps(registry, Io("io", kOutBytes, "io", 0)));
  // In place only when the windows are disjoint (the device path of a SMOOTH probe batch).
  for (const auto &[out, in_place] : {std::pair<uint64_t, bool>{4, false}, {kInBytes, true}}) {
    glint::SharedMemoryCall call;
    ASSERT_TRUE(glint::ResolveSharedMemoryCall(registry, "", Io("io", 0, "io", out), &call).ok());
    EXPECT_EQ(glint::EvaluatesInPlace(call, SmoothProbes(), /*on_device=*/true), in_place)
        << "output at " << out;
  }
}

TEST(ShmWindows, OverlapIsJudgedOnTheObjectsBytesAcrossRegions) {
  // Regions "a" = object bytes [0, size) and "b" = [4096, size): b's offset 0 is a's 4096.
  const uint64_t size = 4096 + kInBytes + kOutBytes;
  auto object = Object(size);
  glint::ShmRegistry registry;
  Register(&registry, "a", *object, 0, size);
  Register(&registry, "b", *object, 4096, size - 4096);
  // Input in a at 4096 (object [4096, 4096 + kInBytes)), output at b's 0 (object 4096): overlap.
  EXPECT_TRUE(Overlaps(registry, Io("a", 4096, "b", 0)));
  // Input in a at 0, output at b's kInBytes - 4096 (object kInBytes): disjoint, though the
  // region-relative ranges [0, kInBytes) and [kInBytes - 4096, ...) overlap as numbers.
  EXPECT_FALSE(Overlaps(registry, Io("a", 0, "b", kInBytes - 4096)));
}

TEST(ShmWindows, SameOffsetsInTwoObjectsDoNotOverlap) {
  auto in = Object(kInBytes);
  auto out = Object(kOutBytes);
  glint::ShmRegistry registry;
  Register(&registry, "in", *in, 0, kInBytes);
  Register(&registry, "out", *out, 0, kOutBytes);
  EXPECT_FALSE(Overlaps(registry, Io("in", 0, "out", 0)));
}

TEST(ShmWindows, AnOffsetNear2To64IsNamedNotWrapped) {
  auto object = Object(kInBytes + kOutBytes);
  glint::ShmRegistry registry;
  Register(&registry, "io", *object, 0, kInBytes + kOutBytes);
  const uint64_t huge = std::numeric_limits<uint64_t>::max() - 3;
  const std::string huge_text = std::to_string(huge);
  for (const SharedMemoryIo &io : {Io("io", huge, "io", kInBytes), Io("io", 0, "io", huge)}) {
    const Status s = Resolve(registry, io);
    EXPECT_EQ(s.code(), Status::Code::kInvalidArgument) << s.message();
    EXPECT_TRUE(Mentions(s, huge_text + " lies beyond region \"io\"")) << s.message();
    // Before: "bytes [18446744073709551612, 23996) lie beyond ...", an end below its start.
    EXPECT_FALSE(Mentions(s, huge_text + ", ")) << s.message();
  }
}

}  // namespace

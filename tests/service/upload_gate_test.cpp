// Normal-map uploads in progress are bounded (server/upload_gate.h): at most 16 at once, and at
// most 2 x --normal-map-max-upload-mb of file bytes buffered over all of them; beyond either, an
// upload is refused with RESOURCE_EXHAUSTED and the retry pushback, and once the others are
// answered it succeeds. Before, every upload buffered its file until its client half-closed (six
// open streams of 250 MB held 1.6 GB) and decoded concurrently with the others (six concurrent
// 55 KB PNG "bombs" of 4096^2 flat texels took glintd from 0.6 to 4.6 GB), without a bound.
// Against a real glintd; the uploads are held open by not half-closing their streams.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <httplib.h>

#include <memory>
#include <string>
#include <vector>

#include "glint/v1/glint.grpc.pb.h"
#include "glintd_process.h"
#include "scraped_metric.h"

namespace {

namespace v1 = glint::v1;

// An upload whose first chunk (`bytes` of file data) has been sent and which is held open.
struct OpenUpload {
  grpc::ClientContext ctx;
  v1::NormalMapInfo info;
  std::unique_ptr<grpc::ClientWriter<v1::NormalMapChunk>> writer;
  bool first_write_ok = false;

  OpenUpload(v1::GlintService::Stub *stub, const std::string &name, size_t bytes) {
    writer = stub->UploadNormalMap(&ctx, &info);
    v1::NormalMapChunk chunk;
    chunk.set_filename(name);
    chunk.set_data(std::string(bytes, 'x'));
    first_write_ok = writer->Write(chunk);
  }
  grpc::Status Finish() {
    writer->WritesDone();
    return writer->Finish();
  }
  std::string Pushback() const {
    const auto &trailers = ctx.GetServerTrailingMetadata();
    const auto it = trailers.find("glint-retry-pushback-ms");
    return it == trailers.end() ? "" : std::string(it->second.data(), it->second.size());
  }
};

// A valid 4 x 4 flat normal map (8-bit RGB PNG written by hand: stored zlib blocks, no
// compression library needed).
std::string FlatPng() {
  auto crc = [](const std::string &s) {
    uint32_t c = 0xffffffffu;
    for (unsigned char b : s) {
      c ^= b;
      for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
    }
    return c ^ 0xffffffffu;
  };
  auto be32 = [](uint32_t v) {
    return std::string{char(v >> 24), char(v >> 16), char(v >> 8), char(v)};
  };
  auto chunk = [&](const std::string &type, const std::string &data) {
    return be32(uint32_t(data.size())) + type + data + be32(crc(type + data));
  };
  std::string raw;
  for (int y = 0; y < 4; ++y) {
    raw += '\0';  // filter: none
    for (int x = 0; x < 4; ++x) raw += std::string{char(128), char(128), char(255)};
  }
  uint32_t a = 1, b = 0;  // adler32
  for (unsigned char c : raw) {
    a = (a + c) % 65521;
    b = (b + a) % 65521;
  }
  const uint16_t len = uint16_t(raw.size());
  std::string z = {char(0x78),
                   char(0x01),
                   char(1),
                   char(len & 0xff),
                   char(len >> 8),
                   char(~len & 0xff),
                   char((~len >> 8) & 0xff)};
  z += raw + be32((b << 16) | a);
  const std::string ihdr = be32(4) + be32(4) + std::string{char(8), char(2), 0, 0, 0};
  return std::string("\x89PNG\r\n\x1a\n", 8) + chunk("IHDR", ihdr) + chunk("IDAT", z) +
         chunk("IEND", "");
}

class UploadGate : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string error;
    // 1 MiB files: the buffered-bytes bound is 2 MiB.
    server_ = glint::test::Glintd::Start(
        glint::test::GlintdUnderTest(GLINTD_PATH), dir_, "glintd",
        {"--normal-map-max-upload-mb", "1", "--warm", "none", "--metrics-listen", "127.0.0.1:0"},
        &error);
    ASSERT_NE(server_, nullptr) << error;
    const int metrics_port = server_->MetricsPort();  // --metrics-listen 127.0.0.1:0
    ASSERT_GT(metrics_port, 0) << server_->Stderr();
    http_ = std::make_unique<httplib::Client>("127.0.0.1", metrics_port);
    stub_ = v1::GlintService::NewStub(
        grpc::CreateChannel(server_->address(), grpc::InsecureChannelCredentials()));
  }
  // A real map uploads once the gate has room again.
  void ExpectAnUploadSucceeds() {
    OpenUpload ok(stub_.get(), "flat.png", 0);
    v1::NormalMapChunk chunk;
    chunk.set_data(FlatPng());
    ASSERT_TRUE(ok.writer->Write(chunk));
    const grpc::Status s = ok.Finish();
    EXPECT_TRUE(s.ok()) << s.error_message();
    EXPECT_EQ(ok.info.width(), 4u);
  }

  glint::test::TempDir dir_{"upload_gate_test"};
  std::unique_ptr<glint::test::Glintd> server_;
  std::unique_ptr<v1::GlintService::Stub> stub_;
  std::unique_ptr<httplib::Client> http_;
};

// Opens `n` uploads of `bytes` each and holds them all open, then finishes them: exactly one
// (whichever the server reached last) must be refused with `words` and the pushback, the others
// answered as the unreadable files they are (INVALID_ARGUMENT). The order in which the server
// reads the streams is its own, so which one is refused is not checked.
//
// A client's Write returns once gRPC has queued the chunk, not once the server has read it, so
// before finishing any upload the test waits until the server has answered one with
// RESOURCE_EXHAUSTED (/metrics): a refusal means the others hold their shares. Finishing at once
// let the server answer the first upload, freeing its share, before it read the last one's chunk
// (seen in CI under load: no refusal, all three answered).
void ExpectExactlyOneRefused(v1::GlintService::Stub *stub, httplib::Client &http, int n,
                             size_t bytes, const std::string &words) {
  const std::string refusals = glint::test::HandledSeries("UploadNormalMap", "RESOURCE_EXHAUSTED");
  const double before = glint::test::ScrapedValue(http, refusals);
  ASSERT_GE(before, 0) << "/metrics unreadable";
  std::vector<std::unique_ptr<OpenUpload>> uploads;
  for (int i = 0; i < n; ++i)
    uploads.push_back(std::make_unique<OpenUpload>(stub, "u" + std::to_string(i) + ".exr", bytes));
  EXPECT_EQ(glint::test::WaitForScrapedValue(http, refusals, before + 1, std::chrono::seconds(60)),
            before + 1);
  int refused = 0, unreadable = 0;
  for (auto &u : uploads) {
    const grpc::Status s = u->Finish();
    if (s.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) {
      ++refused;
      EXPECT_NE(s.error_message().find(words), std::string::npos) << s.error_message();
      EXPECT_EQ(u->Pushback(), "50");  // --slice-ms: may succeed later
    } else {
      EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << s.error_message();
      unreadable += s.error_code() == grpc::StatusCode::INVALID_ARGUMENT;
    }
  }
  EXPECT_EQ(refused, 1);
  EXPECT_EQ(unreadable, n - 1);
}

// Two 1 MiB files fill the 2 MiB bound; a third is refused while both are held.
TEST_F(UploadGate, BufferedBytesOfAllUploadsAreBounded) {
  ExpectExactlyOneRefused(stub_.get(), *http_, 3, size_t{1} << 20, "buffers at most 2097152");
  ExpectAnUploadSucceeds();  // the refused and the answered ones freed their share
  EXPECT_TRUE(server_->Alive());
}

// Sixteen small uploads in progress; a seventeenth is refused while they are held.
TEST_F(UploadGate, UploadsInProgressAreCounted) {
  ExpectExactlyOneRefused(stub_.get(), *http_, 17, 16, "16 already in progress");
  ExpectAnUploadSucceeds();
  EXPECT_TRUE(server_->Alive());
}

}  // namespace

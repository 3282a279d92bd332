// Normal maps as resources (issue 11): decoding (EXR, 8/16-bit PNG, refusals), content
// addressing, NOT_FOUND, LRU eviction under the budget, delete, concurrent uploads, and the
// preprocessed table (vertex grid and min-max quadtree) against explicit recomputation.
#include "server/normal_map_store.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <thread>
#include <vector>

#include "models/normal_map/normal_map_params.h"
#include "models/normal_map/normal_map_table.h"
#include "normal_map_files.h"
#include "server/normal_map_decode.h"

namespace glint {
namespace {

using test::ExrBytes;
using test::PngBytes;
using test::RippleNormals;

TEST(NormalMapDecode, ExrRoundTripsTheNormals) {
  const auto xyz = RippleNormals(7, 5, 0.1, -0.2, 0.3);
  DecodedNormalMap map;
  ASSERT_TRUE(DecodeNormalMap("a.exr", ExrBytes(7, 5, xyz), 1000, &map).ok());
  ASSERT_EQ(map.width, 7u);
  ASSERT_EQ(map.height, 5u);
  // The input is unit to float rounding; renormalising moves it by a few ulp at most.
  for (size_t k = 0; k < xyz.size(); ++k) EXPECT_NEAR(map.xyz[k], xyz[k], 4e-7) << k;
}

TEST(NormalMapDecode, PngIsTwoCOverMaxMinusOneRenormalised) {
  for (bool sixteen : {false, true}) {
    const auto xyz = RippleNormals(6, 4, 0.0, 0.0, 0.4);
    DecodedNormalMap map;
    ASSERT_TRUE(DecodeNormalMap("b.PNG", PngBytes(6, 4, xyz, sixteen), 1000, &map).ok());
    const double max = sixteen ? 65535.0 : 255.0;
    for (size_t t = 0; t < 24; ++t) {
      double c[3], len = 0.0;
      for (int k = 0; k < 3; ++k) {
        c[k] = 2.0 * std::round((xyz[3 * t + k] + 1.0) / 2.0 * max) / max - 1.0;
        len += c[k] * c[k];
      }
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(map.xyz[3 * t + k], c[k] / std::sqrt(len), 1e-6);
    }
  }
}

TEST(NormalMapDecode, RefusesBadFilesNamingTheFileAndTheProblem) {
  const auto xyz = RippleNormals(4, 4, 0.0, 0.0, 0.2);
  DecodedNormalMap map;
  const std::string png = PngBytes(4, 4, xyz, false);
  Status s = DecodeNormalMap("t.png", png.substr(0, png.size() / 2), 1000, &map);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("t.png"), std::string::npos) << s.message();
  EXPECT_TRUE(map.xyz.empty());
  const std::string exr = ExrBytes(4, 4, xyz);
  s = DecodeNormalMap("t.exr", exr.substr(0, exr.size() - 40), 1000, &map);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("t.exr"), std::string::npos) << s.message();
  s = DecodeNormalMap("big.exr", exr, 15, &map);
  EXPECT_NE(s.message().find("16 texels"), std::string::npos) << s.message();
  s = DecodeNormalMap("x.tif", exr, 1000, &map);
  EXPECT_NE(s.message().find("expected .exr"), std::string::npos) << s.message();
  auto bad = xyz;
  bad[3 * 5] = bad[3 * 5 + 1] = bad[3 * 5 + 2] = 0.0f;
  s = DecodeNormalMap("z.exr", ExrBytes(4, 4, bad), 1000, &map);
  EXPECT_NE(s.message().find("texel (1, 1) has zero length"), std::string::npos) << s.message();
  bad = xyz;
  bad[3 * 2 + 1] = NAN;
  s = DecodeNormalMap("n.exr", ExrBytes(4, 4, bad), 1000, &map);
  EXPECT_NE(s.message().find("texel (2, 0) is not finite"), std::string::npos) << s.message();
  bad = xyz;
  bad[3 * 3 + 2] = -0.5f;
  s = DecodeNormalMap("d.exr", ExrBytes(4, 4, bad), 1000, &map);
  EXPECT_NE(s.message().find("z < 0"), std::string::npos) << s.message();
}

TEST(NormalMapStore, SameNormalsAreStoredOnceDifferentNormalsApart) {
  NormalMapStore store;
  // A float EXR and a 16-bit PNG of the same normals decode differently (PNG quantises), so
  // use normals a 16-bit PNG represents exactly: (0, 0, 1) -> c = (32768, 32768, 65535) is not
  // exact (2 * 32768 / 65535 - 1 != 0); compare EXR with EXR and PNG with PNG instead.
  const auto xyz = RippleNormals(8, 8, 0.0, 0.0, 0.2);
  glint::v1::NormalMapInfo a, b, c;
  ASSERT_TRUE(store.Upload("one.exr", ExrBytes(8, 8, xyz), &a).ok());
  ASSERT_TRUE(store.Upload("two.exr", ExrBytes(8, 8, xyz), &b).ok());
  EXPECT_FALSE(a.already_present());
  EXPECT_TRUE(b.already_present());
  EXPECT_EQ(a.digest(), b.digest());
  EXPECT_TRUE(IsNormalMapDigest(a.digest())) << a.digest();
  EXPECT_EQ(b.filename(), "one.exr");
  ASSERT_TRUE(store.Upload("three.png", PngBytes(8, 8, xyz, false), &c).ok());
  EXPECT_NE(c.digest(), a.digest());
  glint::v1::ListNormalMapsResponse list;
  ASSERT_TRUE(store.List({}, &list).ok());
  ASSERT_EQ(list.maps_size(), 2);
  EXPECT_LT(list.maps(0).digest(), list.maps(1).digest());  // by digest (paging's order)
}

TEST(NormalMapStore, NotFoundNamesTheDigestUntilUploadedAgain) {
  NormalMapStore store;
  const auto xyz = RippleNormals(4, 4, 0.1, 0.0, 0.1);
  glint::v1::NormalMapInfo info;
  ASSERT_TRUE(store.Upload("m.exr", ExrBytes(4, 4, xyz), &info).ok());
  NormalMapTable table;
  ASSERT_TRUE(store.Table(info.digest(), 1, &table).ok());
  ASSERT_TRUE(store.Delete(info.digest()).ok());
  EXPECT_EQ(store.bytes(), 0u);
  // A request that still holds the table keeps it alive.
  EXPECT_EQ((*table)[0], 4.0f);
  Status s = store.Table(info.digest(), 1, &table);
  EXPECT_EQ(s.code(), Status::Code::kNotFound);
  EXPECT_NE(s.message().find(info.digest()), std::string::npos) << s.message();
  EXPECT_EQ(store.Delete(info.digest()).code(), Status::Code::kNotFound);
  ASSERT_TRUE(store.Upload("m.exr", ExrBytes(4, 4, xyz), &info).ok());
  EXPECT_FALSE(info.already_present());
  EXPECT_TRUE(store.Table(info.digest(), 1, &table).ok());
}

// DeleteNormalMap with something that is not a digest is refused INVALID_ARGUMENT saying what a
// digest is; NOT_FOUND (upload again) is for well-formed digests the server does not hold. Before,
// "", "sha256:" and an upper-case digest all answered NOT_FOUND "is not held by this server".
TEST(NormalMapStore, DeleteRefusesAMalformedDigestAsInvalid) {
  NormalMapStore store;
  const std::string hex64(64, 'a');
  for (const std::string &bad :
       {std::string(), std::string("sha256:"), "SHA256:" + hex64, "sha256:" + std::string(63, 'a'),
        "sha256:" + std::string(64, 'A'), "sha256:" + hex64 + "0", std::string("bumpy.exr")}) {
    Status s = store.Delete(bad);
    EXPECT_EQ(s.code(), Status::Code::kInvalidArgument) << '"' << bad << "\": " << s.message();
    EXPECT_NE(s.message().find("digest: \"" + bad + "\""), std::string::npos) << s.message();
    EXPECT_NE(s.message().find("\"sha256:\" and 64 lowercase hex digits"), std::string::npos)
        << s.message();
  }
  Status s = store.Delete("sha256:" + hex64);  // well formed, not held
  EXPECT_EQ(s.code(), Status::Code::kNotFound) << s.message();
}

// A filename is at most kMaxNormalMapFilenameBytes (255): the store keeps it and every upload
// and ListNormalMaps reply carries it, so longer ones made those replies outgrow the message limit
// (two 0.9 MB names broke ListNormalMaps at --max-message-mb 1). The refusal names the length and
// the limit without echoing the whole name; 255 bytes are accepted and listed as given.
TEST(NormalMapStore, FilenamesLongerThanNameMaxAreRefused) {
  NormalMapStore store;
  const auto xyz = RippleNormals(4, 4, 0.1, 0.0, 0.1);
  glint::v1::NormalMapInfo info;
  const std::string longest = std::string(251, 'n') + ".exr";
  ASSERT_EQ(longest.size(), 255u);
  Status s = store.Upload(std::string(100000, 'n') + ".exr", ExrBytes(4, 4, xyz), &info);
  EXPECT_EQ(s.code(), Status::Code::kInvalidArgument);
  EXPECT_NE(s.message().find("has 100004 bytes; expected a file name of at most 255 bytes"),
            std::string::npos)
      << s.message();
  EXPECT_LT(s.message().size(), 300u);
  EXPECT_EQ(store.Upload("n" + longest, ExrBytes(4, 4, xyz), &info).code(),
            Status::Code::kInvalidArgument);
  EXPECT_EQ(store.bytes(), 0u);
  ASSERT_TRUE(store.Upload(longest, ExrBytes(4, 4, xyz), &info).ok());
  glint::v1::ListNormalMapsResponse list;
  ASSERT_TRUE(store.List({}, &list).ok());
  ASSERT_EQ(list.maps_size(), 1);
  EXPECT_EQ(list.maps(0).filename(), longest);
}

TEST(NormalMapStore, EvictsLeastRecentlyUsedUnderTheBudget) {
  // Each 16 x 16 map's table: header + 2 floats per vertex + the quadtree levels 1..4.
  const uint64_t one = BuildNormalMapTable(16, 16, std::vector<float>(512), 1).size() * 4;
  NormalMapStore store(
      {.budget_bytes = 3 * one, .max_upload_bytes = 1 << 20, .max_texels = 1 << 20});
  std::vector<std::string> digests;
  for (int k = 0; k < 4; ++k) {
    glint::v1::NormalMapInfo info;
    ASSERT_TRUE(
        store.Upload("m.exr", ExrBytes(16, 16, RippleNormals(16, 16, 0.05 * k, 0, 0.1)), &info)
            .ok());
    EXPECT_EQ(info.bytes(), one);
    digests.push_back(info.digest());
    if (k == 1) {  // touch map 0: map 1 becomes the least recently used
      NormalMapTable t;
      ASSERT_TRUE(store.Table(digests[0], 1, &t).ok());
    }
  }
  EXPECT_LE(store.bytes(), 3 * one);
  NormalMapTable t;
  EXPECT_TRUE(store.Table(digests[0], 1, &t).ok());
  EXPECT_EQ(store.Table(digests[1], 1, &t).code(), Status::Code::kNotFound);
  EXPECT_TRUE(store.Table(digests[2], 1, &t).ok());
  EXPECT_TRUE(store.Table(digests[3], 1, &t).ok());
  // Subdivision 4 adds a table 16 times larger than the map's own: over this budget it is
  // refused and nothing changes; with room it is kept with the map (and evicts others).
  EXPECT_EQ(store.Table(digests[3], 4, &t).code(), Status::Code::kResourceExhausted);
  EXPECT_EQ(store.bytes(), 3 * one);
  store.Configure({.budget_bytes = 18 * one, .max_upload_bytes = 1 << 20, .max_texels = 1 << 20});
  ASSERT_TRUE(store.Table(digests[3], 4, &t).ok());
  EXPECT_EQ((*t)[0], 64.0f);
  EXPECT_LE(store.bytes(), 18 * one);
  EXPECT_TRUE(store.Table(digests[3], 1, &t).ok());
}

TEST(NormalMapStore, RefusesOversizeAndCorruptUploadsStoringNothing) {
  NormalMapStore store({.budget_bytes = 1 << 20, .max_upload_bytes = 4096, .max_texels = 64 * 64});
  glint::v1::NormalMapInfo info;
  const auto big = ExrBytes(65, 64, RippleNormals(65, 64, 0, 0, 0.1));
  Status s = store.Upload("big.exr", big, &info);
  EXPECT_FALSE(s.ok());
  s = store.Upload("big.png", PngBytes(65, 64, RippleNormals(65, 64, 0, 0, 0.1), false), &info);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("max_normal_map"), std::string::npos) << s.message();
  const auto png = PngBytes(8, 8, RippleNormals(8, 8, 0, 0, 0.1), false);
  s = store.Upload("cut.png", png.substr(0, png.size() - 30), &info);
  EXPECT_EQ(s.code(), Status::Code::kInvalidArgument);
  s = store.Upload("empty.png", "", &info);
  EXPECT_EQ(s.code(), Status::Code::kInvalidArgument);
  glint::v1::ListNormalMapsResponse list;
  ASSERT_TRUE(store.List({}, &list).ok());
  EXPECT_EQ(list.maps_size(), 0);
  EXPECT_EQ(store.bytes(), 0u);
}

// ListNormalMaps is paged (AIP-158): with 1000 maps of 255-byte names held (one page of the
// old unpaged reply was ~0.36 MB and grew with every map), pages of every size give each map
// exactly once, in digest order, whatever is used in between; the largest page stays well
// inside the smallest message limit (1 MiB); bad sizes and tokens are refused by field name.
TEST(NormalMapStore, ListPagesEveryMapOnceInDigestOrder) {
  NormalMapStore store;
  constexpr int kMaps = 1000;
  std::vector<std::string> digests;
  for (int i = 0; i < kMaps; ++i) {
    DecodedNormalMap map;
    map.width = map.height = 2;
    // Distinct unit normals per map: a tilt of i / kMaps in x.
    const float x = 0.5f * float(i) / kMaps, z = std::sqrt(1.0f - x * x);
    for (int t = 0; t < 4; ++t) map.xyz.insert(map.xyz.end(), {x, 0.0f, z});
    std::string name(kMaxNormalMapFilenameBytes, 'a' + char(i % 26));
    glint::v1::NormalMapInfo info;
    ASSERT_TRUE(store.Insert(name, map, &info).ok());
    ASSERT_FALSE(info.already_present()) << i;
    digests.push_back(info.digest());
  }
  std::sort(digests.begin(), digests.end());

  for (int page_size : {0, 1, 7, 100, 999, 1000, 5000}) {
    std::vector<std::string> seen;
    glint::v1::ListNormalMapsRequest request;
    request.set_page_size(page_size);
    const size_t expected_page = page_size == 0
                                     ? kDefaultNormalMapPageSize
                                     : std::min<size_t>(page_size, kMaxNormalMapPageSize);
    for (int pages = 0;; ++pages) {
      ASSERT_LE(pages, kMaps) << "paging does not end";
      glint::v1::ListNormalMapsResponse page;
      Status s = store.List(request, &page);
      ASSERT_TRUE(s.ok()) << s.message();
      EXPECT_LE(page.ByteSizeLong(), size_t{1} << 20);
      for (const auto &m : page.maps()) seen.push_back(m.digest());
      if (page.next_page_token().empty()) {
        EXPECT_LE(size_t(page.maps_size()), expected_page);
        break;
      }
      EXPECT_EQ(size_t(page.maps_size()), expected_page);
      // Using a map between pages (recency changes) must not move it between pages.
      NormalMapTable table;
      ASSERT_TRUE(store.Table(digests[size_t(pages) % digests.size()], 1, &table).ok());
      request.set_page_token(page.next_page_token());
    }
    EXPECT_EQ(seen, digests) << "page_size " << page_size;
  }

  // A map deleted between pages is skipped; the others still come once each.
  glint::v1::ListNormalMapsRequest request;
  request.set_page_size(10);
  glint::v1::ListNormalMapsResponse first;
  ASSERT_TRUE(store.List(request, &first).ok());
  ASSERT_TRUE(store.Delete(first.maps(9).digest()).ok());  // the token's own digest
  ASSERT_TRUE(store.Delete(digests[10]).ok());
  request.set_page_token(first.next_page_token());
  glint::v1::ListNormalMapsResponse second;
  ASSERT_TRUE(store.List(request, &second).ok());
  EXPECT_EQ(second.maps(0).digest(), digests[11]);

  request.set_page_size(-1);
  Status s = store.List(request, &second);
  EXPECT_EQ(s.code(), Status::Code::kInvalidArgument);
  EXPECT_NE(s.message().find("page_size: -1"), std::string::npos) << s.message();
  for (const char *token : {"garbage", "after:sha256:00", "sha256:"}) {
    request.set_page_size(0);
    request.set_page_token(token);
    s = store.List(request, &second);
    EXPECT_EQ(s.code(), Status::Code::kInvalidArgument) << token;
    EXPECT_NE(s.message().find("page_token"), std::string::npos) << s.message();
  }
}

TEST(NormalMapStore, TwoClientsUploadingTheSameMapAtOnceStoreItOnce) {
  NormalMapStore store;
  const std::string bytes = ExrBytes(32, 32, RippleNormals(32, 32, 0, 0, 0.3));
  glint::v1::NormalMapInfo a, b;
  Status sa, sb;
  std::thread ta([&] { sa = store.Upload("a.exr", bytes, &a); });
  std::thread tb([&] { sb = store.Upload("b.exr", bytes, &b); });
  ta.join();
  tb.join();
  ASSERT_TRUE(sa.ok() && sb.ok());
  EXPECT_EQ(a.digest(), b.digest());
  EXPECT_NE(a.already_present(), b.already_present());
  glint::v1::ListNormalMapsResponse list;
  ASSERT_TRUE(store.List({}, &list).ok());
  EXPECT_EQ(list.maps_size(), 1);
  EXPECT_EQ(store.bytes(), a.bytes());
}

// Subdivision 4 is built on first use, on the requests' workers: eight requests asking for the
// same new table at once get one build and one table between them (the others wait for it).
TEST(NormalMapStore, ConcurrentFirstUsesOfSubdivisionFourBuildItOnce) {
  NormalMapStore store;
  glint::v1::NormalMapInfo info;
  ASSERT_TRUE(
      store.Upload("a.exr", ExrBytes(256, 256, RippleNormals(256, 256, 0, 0, 0.3)), &info).ok());
  std::vector<NormalMapTable> tables(8);
  std::vector<Status> status(8);
  std::vector<std::thread> threads;
  for (size_t k = 0; k < tables.size(); ++k)
    threads.emplace_back([&, k] { status[k] = store.Table(info.digest(), 4, &tables[k]); });
  for (std::thread &t : threads) t.join();
  for (size_t k = 0; k < tables.size(); ++k) {
    ASSERT_TRUE(status[k].ok()) << status[k].message();
    EXPECT_EQ(tables[k].get(), tables[0].get()) << "request " << k;
  }
  EXPECT_EQ(store.subdivision_builds(), 1u);
  NormalMapTable again;
  ASSERT_TRUE(store.Table(info.digest(), 4, &again).ok());
  EXPECT_EQ(again.get(), tables[0].get());
  EXPECT_EQ(store.subdivision_builds(), 1u);
}

// The quadtree against a brute-force min / max over each node's cells' vertices.
TEST(NormalMapTable, QuadtreeBoundsAreTheMinMaxOfEachNodesVertices) {
  for (auto [w, h] : {std::pair{13u, 7u}, {1u, 1u}, {16u, 16u}, {33u, 2u}}) {
    std::vector<float> st(size_t(w) * h * 2);
    for (size_t k = 0; k < st.size(); ++k)
      st[k] = float(0.7 * std::sin(0.37 * double(k * k % 101)));
    const std::vector<float> t = BuildNormalMapTable(w, h, st, 1);
    const int levels = NormalMapLevels(w, h);
    ASSERT_EQ(t[2], float(levels));
    ASSERT_GE(1u << (levels - 1), std::max(w, h));
    size_t offset = GLINT_NM_HEADER_FLOATS + size_t(w) * h * 2;
    for (int k = 1; k < levels; ++k) {
      const uint32_t nw = (w + (1u << k) - 1) >> k, nh = (h + (1u << k) - 1) >> k;
      for (uint32_t y = 0; y < nh; ++y)
        for (uint32_t x = 0; x < nw; ++x) {
          float b[4] = {INFINITY, -INFINITY, INFINITY, -INFINITY};
          for (uint32_t cy = y << k; cy < std::min((y + 1) << k, h); ++cy)
            for (uint32_t cx = x << k; cx < std::min((x + 1) << k, w); ++cx)
              for (uint32_t dy = 0; dy < 2; ++dy)
                for (uint32_t dx = 0; dx < 2; ++dx) {
                  const size_t v = (size_t((cy + dy) % h) * w + (cx + dx) % w) * 2;
                  b[0] = std::min(b[0], st[v]);
                  b[1] = std::max(b[1], st[v]);
                  b[2] = std::min(b[2], st[v + 1]);
                  b[3] = std::max(b[3], st[v + 1]);
                }
          for (int c = 0; c < 4; ++c)
            ASSERT_EQ(t[offset + (size_t(y) * nw + x) * 4 + c], b[c])
                << w << "x" << h << " level " << k;
        }
      offset += size_t(nw) * nh * 4;
    }
    EXPECT_EQ(offset, t.size());
  }
}

// Subdivision 4 interpolates: sub-vertices 4 i + 1.5 sit on input vertex i (Catmull-Rom passes
// through its control points), so the grid between them reproduces a linear ramp of s exactly.
TEST(NormalMapTable, CatmullRomSubdivisionInterpolatesTheTexels) {
  const uint32_t w = 8, h = 8;
  std::vector<float> st(size_t(w) * h * 2);
  for (uint32_t j = 0; j < h; ++j)
    for (uint32_t i = 0; i < w; ++i) {
      st[(j * w + i) * 2] = 0.05f * float(i);
      st[(j * w + i) * 2 + 1] = -0.03f * float(j);
    }
  const std::vector<float> t = BuildNormalMapTable(w, h, st, 4);
  ASSERT_EQ(t[0], 32.0f);
  // Away from the periodic seam (i in [1, 6]), s at sub-vertex I is the ramp at x = (I + .5)/4 -
  // .5.
  for (uint32_t J = 8; J < 24; ++J)
    for (uint32_t I = 8; I < 24; ++I) {
      const float *v = &t[GLINT_NM_HEADER_FLOATS + (size_t(J) * 32 + I) * 2];
      EXPECT_NEAR(v[0], 0.05 * ((I + 0.5) / 4.0 - 0.5), 1e-6);
      EXPECT_NEAR(v[1], -0.03 * ((J + 0.5) / 4.0 - 0.5), 1e-6);
    }
}

}  // namespace
}  // namespace glint

// The fast PNG decoder against cv::imdecode: bit-exact on the shared sequences and on
// synthetic images (every filter type, layout and odd size), corrupt input refused with a
// reason, unsupported layouts decoded by the OpenCV fallback.
#include <gtest/gtest.h>
#include <libdeflate.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <iterator>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <thread>
#include <vector>

#include "pplvo/dataset/dataset.h"
#include "pplvo/dataset/png_decode.h"

namespace fs = std::filesystem;
using namespace pplvo::dataset;
using Bytes = std::vector<uint8_t>;

namespace {

std::string sharedData() {
  const char* env = std::getenv("PPLVO_SHARED_DATA");
  return env ? env : "../shared/data";
}

Bytes readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return Bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// ---- A small independent PNG writer / reader for building test files -------------------

void put32(Bytes& b, uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) b.push_back(uint8_t(v >> s));
}
uint32_t get32(const uint8_t* p) {
  return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | p[3];
}

struct Chunk {
  std::string type;
  Bytes data;
};

const Bytes kSig = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

Bytes assemble(const std::vector<Chunk>& chunks) {
  Bytes out = kSig;
  for (const auto& c : chunks) {
    put32(out, uint32_t(c.data.size()));
    Bytes typed(c.type.begin(), c.type.end());
    typed.insert(typed.end(), c.data.begin(), c.data.end());
    out.insert(out.end(), typed.begin(), typed.end());
    put32(out, libdeflate_crc32(0, typed.data(), typed.size()));
  }
  return out;
}

/// Chunks of a well-formed PNG (no checks: test input only).
std::vector<Chunk> parseChunks(const Bytes& png) {
  std::vector<Chunk> out;
  size_t pos = 8;
  while (pos + 12 <= png.size()) {
    const uint32_t len = get32(&png[pos]);
    Chunk c;
    c.type.assign(png.begin() + long(pos) + 4, png.begin() + long(pos) + 8);
    c.data.assign(png.begin() + long(pos) + 8, png.begin() + long(pos) + 8 + len);
    out.push_back(c);
    pos += 12 + len;
  }
  return out;
}

Bytes ihdr(uint32_t w, uint32_t h, int depth, int colour_type, int interlace = 0) {
  Bytes b;
  put32(b, w);
  put32(b, h);
  b.push_back(uint8_t(depth));
  b.push_back(uint8_t(colour_type));
  b.push_back(0);
  b.push_back(0);
  b.push_back(uint8_t(interlace));
  return b;
}

Bytes zlibCompress(const Bytes& raw, int level = 6) {
  libdeflate_compressor* c = libdeflate_alloc_compressor(level);
  Bytes out(libdeflate_zlib_compress_bound(c, raw.size()));
  out.resize(libdeflate_zlib_compress(c, raw.data(), raw.size(), out.data(), out.size()));
  libdeflate_free_compressor(c);
  return out;
}

/// A PNG from IHDR fields and filtered scanlines (filter byte + row bytes each), the zlib
/// stream split into `idat_chunks` IDAT chunks; `extra` chunks go before the IDATs.
Bytes buildPng(const Bytes& header, const Bytes& scanlines, int idat_chunks = 1,
               const std::vector<Chunk>& extra = {}) {
  std::vector<Chunk> chunks = {{"IHDR", header}};
  chunks.insert(chunks.end(), extra.begin(), extra.end());
  const Bytes z = zlibCompress(scanlines);
  const size_t part = z.size() / size_t(idat_chunks) + 1;
  for (int i = 0; i < idat_chunks; ++i) {
    const size_t b = std::min(z.size(), size_t(i) * part), e = std::min(z.size(), b + part);
    chunks.push_back({"IDAT", Bytes(z.begin() + long(b), z.begin() + long(e))});
  }
  chunks.push_back({"IEND", {}});
  return assemble(chunks);
}

int channelsOf(int colour_type) {
  return colour_type == 0   ? 1
         : colour_type == 2 ? 3
         : colour_type == 4 ? 2
         : colour_type == 6 ? 4
                            : 1;
}

/// Filter bytes of a non-interlaced PNG (the IDAT stream inflated).
std::vector<int> filterTypes(const Bytes& png) {
  const auto chunks = parseChunks(png);
  const Bytes& h = chunks.at(0).data;
  const uint32_t w = get32(&h[0]), rows = get32(&h[4]);
  const size_t row_bytes = (size_t(w) * channelsOf(h[9]) * h[8] + 7) / 8;
  Bytes z;
  for (const auto& c : chunks)
    if (c.type == "IDAT") z.insert(z.end(), c.data.begin(), c.data.end());
  Bytes raw((row_bytes + 1) * rows);
  libdeflate_decompressor* d = libdeflate_alloc_decompressor();
  const auto r = libdeflate_zlib_decompress(d, z.data(), z.size(), raw.data(), raw.size(), nullptr);
  libdeflate_free_decompressor(d);
  EXPECT_EQ(r, LIBDEFLATE_SUCCESS);
  std::vector<int> types;
  for (uint32_t y = 0; y < rows; ++y) types.push_back(raw[y * (row_bytes + 1)]);
  return types;
}

int paethSpec(int a, int b, int c) {  // as written in the PNG specification
  const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return a;
  if (pb <= pc) return b;
  return c;
}

/// Filters unfiltered rows (`rows` x `row_bytes`) with filter filter_of(y) per row.
Bytes filterRows(const Bytes& pixels, size_t rows, size_t row_bytes, int bpp,
                 const std::function<int(size_t)>& filter_of) {
  Bytes out;
  for (size_t y = 0; y < rows; ++y) {
    const int f = filter_of(y);
    out.push_back(uint8_t(f));
    for (size_t i = 0; i < row_bytes; ++i) {
      const int x = pixels[y * row_bytes + i];
      const int a = i >= size_t(bpp) ? pixels[y * row_bytes + i - bpp] : 0;
      const int b = y > 0 ? pixels[(y - 1) * row_bytes + i] : 0;
      const int c = (y > 0 && i >= size_t(bpp)) ? pixels[(y - 1) * row_bytes + i - bpp] : 0;
      int pred = 0;
      if (f == 1) pred = a;
      if (f == 2) pred = b;
      if (f == 3) pred = (a + b) / 2;
      if (f == 4) pred = paethSpec(a, b, c);
      out.push_back(uint8_t(x - pred));
    }
  }
  return out;
}

/// Pixel bytes with smooth ramps, flat runs, noise and values near 0 and 255.
Bytes samplePixels(size_t n, uint64_t seed) {
  cv::RNG rng(seed);
  Bytes p(n);
  for (size_t i = 0; i < n; ++i) {
    const int region = int((i / 97) % 4);
    if (region == 0) p[i] = uint8_t(i * 3);
    if (region == 1) p[i] = 250;
    if (region == 2) p[i] = uint8_t(rng.uniform(0, 256));
    if (region == 3) p[i] = uint8_t(255 - (i % 7) + rng.uniform(0, 3));
  }
  return p;
}

/// A cv::Mat of `type` with ramps, flat patches and noise (so encoders pick varied filters).
cv::Mat sampleImage(int rows, int cols, int type, uint64_t seed) {
  cv::Mat m(rows, cols, type);
  cv::RNG rng(seed);
  const int cn = m.channels();
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < cols; ++x) {
      for (int c = 0; c < cn; ++c) {
        double v = 0;
        const int zone = ((x / 16) + (y / 8)) % 4;
        if (zone == 0) v = x * 2.0 + y * 3.0 + c * 40;
        if (zone == 1) v = 128 + c;
        if (zone == 2) v = rng.uniform(0.0, 256.0);
        if (zone == 3) v = (x * 7 + y * 11) % 256 + rng.uniform(0.0, 4.0);
        if (m.depth() == CV_8U) {
          m.ptr<uint8_t>(y)[x * cn + c] = cv::saturate_cast<uint8_t>(std::fmod(v, 256.0));
        } else {
          m.ptr<uint16_t>(y)[x * cn + c] =
              cv::saturate_cast<uint16_t>(std::fmod(v, 256.0) * 256 + rng.uniform(0, 256));
        }
      }
    }
  }
  return m;
}

::testing::AssertionResult identical(const cv::Mat& a, const cv::Mat& b) {
  if (a.type() != b.type() || a.size() != b.size()) {
    return ::testing::AssertionFailure()
           << "type/size " << a.type() << " " << a.cols << "x" << a.rows << " vs " << b.type()
           << " " << b.cols << "x" << b.rows;
  }
  const size_t row = size_t(a.cols) * a.elemSize();
  for (int y = 0; y < a.rows; ++y) {
    if (std::memcmp(a.ptr(y), b.ptr(y), row) != 0) {
      return ::testing::AssertionFailure() << "pixels differ in row " << y;
    }
  }
  return ::testing::AssertionSuccess();
}

/// Decodes with both decoders and compares; returns the path taken.
PngDecodePath expectSameAsOpenCv(const Bytes& png, int flags, const std::string& what) {
  const cv::Mat ref = cv::imdecode(png, flags);
  EXPECT_FALSE(ref.empty()) << what;
  PngDecodePath path{};
  cv::Mat got;
  try {
    got = decodePng(png.data(), png.size(), flags, &path);
  } catch (const PngError& e) {
    ADD_FAILURE() << what << ": " << e.what();
    return path;
  }
  EXPECT_TRUE(identical(got, ref)) << what << " flags " << flags;
  return path;
}

std::string errorOf(const Bytes& png, int flags = cv::IMREAD_COLOR) {
  try {
    decodePng(png.data(), png.size(), flags);
  } catch (const PngError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

// (a) The shared sequences: colour (IMREAD_COLOR) and depth (IMREAD_UNCHANGED), fast path.
TEST(PngDecode, SharedSequencesBitExact) {
  int checked = 0;
  for (const char* seq : {"icl_living_room_kt0_short", "tum_fr3_sitting_static_short"}) {
    const std::string dir = sharedData() + "/" + seq;
    if (!fs::is_directory(dir)) continue;
    for (const char* sub : {"rgb", "depth"}) {
      std::vector<std::string> files;
      for (const auto& e : fs::directory_iterator(dir + "/" + sub)) files.push_back(e.path());
      std::sort(files.begin(), files.end());
      files.resize(std::min<size_t>(files.size(), 6));
      for (const auto& f : files) {
        const Bytes png = readFile(f);
        const int flags = std::string(sub) == "rgb" ? cv::IMREAD_COLOR : cv::IMREAD_UNCHANGED;
        EXPECT_EQ(expectSameAsOpenCv(png, flags, f), PngDecodePath::kFast) << f;
        // Depth read as colour too (16-bit grey -> high byte, replicated).
        if (flags == cv::IMREAD_UNCHANGED) {
          EXPECT_EQ(expectSameAsOpenCv(png, cv::IMREAD_COLOR, f), PngDecodePath::kFast) << f;
        }
        ++checked;
      }
    }
  }
  if (checked == 0) GTEST_SKIP() << "no shared data under " << sharedData();
  EXPECT_EQ(checked, 24);
}

// (b) cv::imencode output over layouts, odd sizes, compression levels and strategies; the
// filter bytes seen (with the hand-filtered images below) cover all five filter types.
TEST(PngDecode, SyntheticImencodeImagesBitExact) {
  const std::vector<int> types = {CV_8UC3, CV_8UC1, CV_16UC1, CV_8UC4, CV_16UC3, CV_16UC4};
  const std::vector<cv::Size> sizes = {{1, 1}, {3, 1},   {641, 1}, {1, 7},
                                       {3, 5}, {641, 9}, {64, 48}};
  const std::vector<int> strategies = {
      cv::IMWRITE_PNG_STRATEGY_DEFAULT, cv::IMWRITE_PNG_STRATEGY_FILTERED,
      cv::IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY, cv::IMWRITE_PNG_STRATEGY_RLE,
      cv::IMWRITE_PNG_STRATEGY_FIXED};
  std::map<int, int> filters;
  int seed = 1;
  for (int type : types) {
    for (const auto& sz : sizes) {
      const cv::Mat img = sampleImage(sz.height, sz.width, type, uint64_t(seed++));
      for (int level : {0, 1, 6, 9}) {
        for (int strategy : strategies) {
          Bytes png;
          ASSERT_TRUE(cv::imencode(
              ".png", img, png,
              {cv::IMWRITE_PNG_COMPRESSION, level, cv::IMWRITE_PNG_STRATEGY, strategy}));
          for (int f : filterTypes(png)) ++filters[f];
          const std::string what = "type " + std::to_string(type) + " " + std::to_string(sz.width) +
                                   "x" + std::to_string(sz.height) + " level " +
                                   std::to_string(level) + " strategy " + std::to_string(strategy);
          EXPECT_EQ(expectSameAsOpenCv(png, cv::IMREAD_COLOR, what), PngDecodePath::kFast) << what;
          const PngDecodePath unchanged = expectSameAsOpenCv(png, cv::IMREAD_UNCHANGED, what);
          const bool grey = CV_MAT_CN(type) == 1;
          EXPECT_EQ(unchanged, grey ? PngDecodePath::kFast : PngDecodePath::kOpenCv) << what;
        }
      }
    }
  }
  std::string seen;
  for (const auto& [f, n] : filters) seen += " " + std::to_string(f) + ":" + std::to_string(n);
  std::cout << "filter types written by cv::imencode (type:rows):" << seen << "\n";
  for (int f = 0; f < 5; ++f)
    EXPECT_GT(filters[f], 0) << "filter " << f << " never written;" << seen;
}

// Every filter type on every row position, every bytes-per-pixel of the fast path, odd sizes,
// the zlib stream split over several IDAT chunks (one of them empty).
TEST(PngDecode, HandFilteredRowsAllFiltersAllLayouts) {
  struct L {
    int depth, colour_type;
  };
  const std::vector<L> layouts = {{8, 0}, {16, 0}, {8, 2}, {16, 2},
                                  {8, 4}, {16, 4}, {8, 6}, {16, 6}};
  const std::vector<cv::Size> sizes = {{1, 1}, {1, 6}, {2, 2}, {3, 5}, {5, 11}, {641, 7}};
  std::map<int, int> filters;
  uint64_t seed = 100;
  for (const auto& l : layouts) {
    const int bpp = channelsOf(l.colour_type) * l.depth / 8;
    for (const auto& sz : sizes) {
      for (int shift = 0; shift < 7; ++shift) {
        const size_t row_bytes = size_t(sz.width) * size_t(bpp);
        const Bytes pixels = samplePixels(row_bytes * size_t(sz.height), seed++);
        // Filters 0-4 in turn, or (shift >= 5) runs of Paeth rows broken by the others, as
        // camera images have them (the decoder unfilters Paeth row pairs together).
        const Bytes rows = filterRows(pixels, size_t(sz.height), row_bytes, bpp, [&](size_t y) {
          if (shift < 5) return int((y + size_t(shift)) % 5);
          const size_t k = y + size_t(shift - 5);
          return k % 6 < 3 ? 4 : int(k % 4);
        });
        for (size_t y = 0; y < size_t(sz.height); ++y) ++filters[rows[y * (row_bytes + 1)]];
        const Bytes png =
            buildPng(ihdr(uint32_t(sz.width), uint32_t(sz.height), l.depth, l.colour_type), rows,
                     1 + shift % 3);
        const std::string what = "depth " + std::to_string(l.depth) + " colour type " +
                                 std::to_string(l.colour_type) + " " + std::to_string(sz.width) +
                                 "x" + std::to_string(sz.height) + " shift " +
                                 std::to_string(shift);
        EXPECT_EQ(expectSameAsOpenCv(png, cv::IMREAD_COLOR, what), PngDecodePath::kFast);
        if (l.colour_type == 0) {
          EXPECT_EQ(expectSameAsOpenCv(png, cv::IMREAD_UNCHANGED, what), PngDecodePath::kFast);
          // Also the actual values: 16-bit samples in native order.
          const cv::Mat m = decodePng(png.data(), png.size(), cv::IMREAD_UNCHANGED);
          const size_t last = row_bytes * size_t(sz.height) - size_t(bpp);
          const int want = l.depth == 8 ? pixels[last] : (pixels[last] << 8) | pixels[last + 1];
          const int got = l.depth == 8 ? m.at<uint8_t>(sz.height - 1, sz.width - 1)
                                       : m.at<uint16_t>(sz.height - 1, sz.width - 1);
          EXPECT_EQ(got, want) << what;
        }
      }
    }
  }
  // An empty IDAT chunk among the others is fine.
  const Bytes pixels = samplePixels(3 * 4 * 4, 7);
  const Bytes rows = filterRows(pixels, 4, 12, 3, [](size_t y) { return int(y % 5); });
  auto chunks = parseChunks(buildPng(ihdr(4, 4, 8, 2), rows, 2));
  chunks.insert(chunks.begin() + 2, Chunk{"IDAT", {}});
  EXPECT_EQ(expectSameAsOpenCv(assemble(chunks), cv::IMREAD_COLOR, "empty IDAT"),
            PngDecodePath::kFast);
  for (int f = 0; f < 5; ++f) EXPECT_GT(filters[f], 0);
}

// Ancillary chunks libpng reads but OpenCV does not apply (gamma, significant bits,
// chromaticities, sRGB, transparency, background, text, an unknown private chunk): the fast
// path ignores them too, and the pixels still equal OpenCV's.
TEST(PngDecode, AncillaryChunksIgnoredLikeOpenCv) {
  struct Case {
    int depth, colour_type;
  };
  for (const Case& c : std::vector<Case>{{8, 0}, {16, 0}, {8, 2}, {16, 2}, {8, 6}, {8, 4}}) {
    const int channels = channelsOf(c.colour_type);
    const int bpp = channels * c.depth / 8;
    const Bytes pixels = samplePixels(size_t(bpp) * 13 * 6, 11);
    const Bytes rows =
        filterRows(pixels, 6, size_t(bpp) * 13, bpp, [](size_t y) { return int(y % 5); });
    Bytes gama;
    put32(gama, 45455);  // 1/2.2
    Bytes chrm;
    for (uint32_t v : {31270u, 32900u, 64000u, 33000u, 30000u, 60000u, 15000u, 6000u})
      put32(chrm, v);
    Bytes sbit(size_t(c.colour_type == 0   ? 1
                      : c.colour_type == 4 ? 2
                                           : channels),
               uint8_t(c.depth == 8 ? 5 : 12));
    Bytes trns;  // a grey / RGB key colour equal to the first pixel
    if (c.colour_type == 0 || c.colour_type == 2) {
      for (int ch = 0; ch < (c.colour_type == 0 ? 1 : 3); ++ch) {
        const int v = c.depth == 8 ? pixels[size_t(ch)]
                                   : (pixels[size_t(ch) * 2] << 8) | pixels[size_t(ch) * 2 + 1];
        trns.push_back(uint8_t(v >> 8));
        trns.push_back(uint8_t(v));
      }
    }
    Bytes bkgd(c.colour_type == 0 || c.colour_type == 4 ? 2 : 6, 0);  // 16-bit samples 0x0040
    for (size_t i = 1; i < bkgd.size(); i += 2) bkgd[i] = 0x40;
    const Bytes text = {'C', 'o', 'm', 'm', 'e', 'n', 't', 0, 'h', 'i'};
    std::vector<std::vector<Chunk>> extras = {
        {{"gAMA", gama}},
        {{"sBIT", sbit}},
        {{"cHRM", chrm}},
        {{"sRGB", {0}}},
        {{"bKGD", bkgd}},
        {{"tEXt", text}, {"prVt", {1, 2, 3}}},
        {{"gAMA", gama}, {"sBIT", sbit}, {"sRGB", {0}}, {"cHRM", chrm}}};
    if (!trns.empty()) extras.push_back({{"tRNS", trns}});
    if (!trns.empty()) extras.push_back({{"gAMA", gama}, {"tRNS", trns}, {"bKGD", bkgd}});
    for (const auto& extra : extras) {
      const Bytes png = buildPng(ihdr(13, 6, c.depth, c.colour_type), rows, 1, extra);
      std::string what =
          "depth " + std::to_string(c.depth) + " type " + std::to_string(c.colour_type) + " with";
      for (const auto& ch : extra) what += " " + ch.type;
      EXPECT_EQ(expectSameAsOpenCv(png, cv::IMREAD_COLOR, what), PngDecodePath::kFast) << what;
      const PngDecodePath p = expectSameAsOpenCv(png, cv::IMREAD_UNCHANGED, what);
      EXPECT_EQ(p, c.colour_type == 0 ? PngDecodePath::kFast : PngDecodePath::kOpenCv) << what;
    }
    // A text chunk after the image data.
    auto chunks = parseChunks(buildPng(ihdr(13, 6, c.depth, c.colour_type), rows));
    chunks.insert(chunks.end() - 1, Chunk{"tEXt", text});
    EXPECT_EQ(expectSameAsOpenCv(assemble(chunks), cv::IMREAD_COLOR, "tEXt after IDAT"),
              PngDecodePath::kFast);
  }
}

// (d) Layouts the fast path leaves to OpenCV still decode, identically.
TEST(PngDecode, UnsupportedLayoutsFallBackToOpenCv) {
  // Palette, 8-bit and 4-bit indices.
  Bytes plte;
  for (int i = 0; i < 16; ++i) {
    plte.push_back(uint8_t(i * 16));
    plte.push_back(uint8_t(255 - i * 9));
    plte.push_back(uint8_t(i * i));
  }
  {
    Bytes idx = samplePixels(9 * 5, 3);
    for (auto& v : idx) v %= 16;
    const Bytes png = buildPng(ihdr(9, 5, 8, 3), filterRows(idx, 5, 9, 1, [](size_t) { return 1; }),
                               1, {{"PLTE", plte}});
    EXPECT_EQ(expectSameAsOpenCv(png, cv::IMREAD_COLOR, "palette 8"), PngDecodePath::kOpenCv);
    EXPECT_EQ(expectSameAsOpenCv(png, cv::IMREAD_UNCHANGED, "palette 8"), PngDecodePath::kOpenCv);
    const cv::Mat m = decodePng(png.data(), png.size(), cv::IMREAD_COLOR);
    const auto px = m.at<cv::Vec3b>(4, 8);
    const int i = idx[4 * 9 + 8];
    EXPECT_EQ(px, cv::Vec3b(uint8_t(i * i), uint8_t(255 - i * 9), uint8_t(i * 16)));
  }
  {
    const Bytes packed = samplePixels(5 * 5, 4);  // 9 pixels at 4 bits: 5 bytes a row
    const Bytes png =
        buildPng(ihdr(9, 5, 4, 3), filterRows(packed, 5, 5, 1, [](size_t) { return 0; }), 1,
                 {{"PLTE", plte}});
    EXPECT_EQ(expectSameAsOpenCv(png, cv::IMREAD_COLOR, "palette 4"), PngDecodePath::kOpenCv);
  }
  // 1-bit and 4-bit grey.
  for (int depth : {1, 2, 4}) {
    const size_t row_bytes = (size_t(11) * size_t(depth) + 7) / 8;
    const Bytes packed = samplePixels(row_bytes * 3, 5);
    const Bytes png = buildPng(ihdr(11, 3, depth, 0), filterRows(packed, 3, row_bytes, 1,
                                                                 [](size_t y) { return int(y); }));
    EXPECT_EQ(expectSameAsOpenCv(png, cv::IMREAD_COLOR, "grey low depth"), PngDecodePath::kOpenCv);
    EXPECT_EQ(expectSameAsOpenCv(png, cv::IMREAD_UNCHANGED, "grey low depth"),
              PngDecodePath::kOpenCv);
  }
  // Adam7 interlaced RGB, built by hand: equal to the same pixels non-interlaced.
  {
    const int w = 13, h = 11, bpp = 3;
    const Bytes pixels = samplePixels(size_t(w * h * bpp), 6);
    const int px0[7] = {0, 4, 0, 2, 0, 1, 0}, py0[7] = {0, 0, 4, 0, 2, 0, 1};
    const int pdx[7] = {8, 8, 4, 4, 2, 2, 1}, pdy[7] = {8, 8, 8, 4, 4, 2, 2};
    Bytes scan;
    for (int p = 0; p < 7; ++p) {
      const int pw = (w - px0[p] + pdx[p] - 1) / pdx[p], ph = (h - py0[p] + pdy[p] - 1) / pdy[p];
      if (pw <= 0 || ph <= 0) continue;
      Bytes sub;
      for (int y = py0[p]; y < h; y += pdy[p])
        for (int x = px0[p]; x < w; x += pdx[p])
          for (int c = 0; c < bpp; ++c) sub.push_back(pixels[size_t((y * w + x) * bpp + c)]);
      const Bytes f =
          filterRows(sub, size_t(ph), size_t(pw * bpp), bpp, [](size_t y) { return int(y % 5); });
      scan.insert(scan.end(), f.begin(), f.end());
    }
    const Bytes interlaced = buildPng(ihdr(w, h, 8, 2, 1), scan);
    const Bytes plain = buildPng(ihdr(w, h, 8, 2), filterRows(pixels, size_t(h), size_t(w * bpp),
                                                              bpp, [](size_t) { return 0; }));
    EXPECT_EQ(expectSameAsOpenCv(interlaced, cv::IMREAD_COLOR, "interlaced"),
              PngDecodePath::kOpenCv);
    EXPECT_TRUE(identical(decodePng(interlaced.data(), interlaced.size(), cv::IMREAD_COLOR),
                          decodePng(plain.data(), plain.size(), cv::IMREAD_COLOR)));
  }
  // Other flags and colour layouts read unchanged.
  const cv::Mat rgba = sampleImage(5, 7, CV_8UC4, 9);
  Bytes png;
  ASSERT_TRUE(cv::imencode(".png", rgba, png));
  EXPECT_EQ(expectSameAsOpenCv(png, cv::IMREAD_GRAYSCALE, "grayscale flag"),
            PngDecodePath::kOpenCv);
  EXPECT_EQ(expectSameAsOpenCv(png, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR, "any"),
            PngDecodePath::kOpenCv);
  // An eXIf orientation with IMREAD_COLOR: OpenCV's business.
  Bytes exif = {'M', 'M', 0, 42, 0, 0, 0, 8, 0, 1, 0x01, 0x12, 0, 3,
                0,   0,   0, 1,  0, 6, 0, 0, 0, 0, 0,    0,    0, 0};
  auto chunks = parseChunks(png);
  chunks.insert(chunks.begin() + 1, Chunk{"eXIf", exif});
  const Bytes with_exif = assemble(chunks);
  EXPECT_EQ(expectSameAsOpenCv(with_exif, cv::IMREAD_COLOR, "eXIf"), PngDecodePath::kOpenCv);
  // OpenCV 4.6 does rotate it (orientation 6): 7x5 becomes 5x7.
  EXPECT_EQ(decodePng(with_exif.data(), with_exif.size(), cv::IMREAD_COLOR).size(), cv::Size(5, 7));
  // IMREAD_UNCHANGED ignores the orientation: fast path for grey.
  Bytes grey;
  ASSERT_TRUE(cv::imencode(".png", sampleImage(5, 7, CV_16UC1, 10), grey));
  chunks = parseChunks(grey);
  chunks.insert(chunks.begin() + 1, Chunk{"eXIf", exif});
  EXPECT_EQ(expectSameAsOpenCv(assemble(chunks), cv::IMREAD_UNCHANGED, "eXIf grey"),
            PngDecodePath::kFast);
}

// (c) Corrupt input: an error with a reason, never a crash or an image.
TEST(PngDecode, TruncatedAtEveryOffset) {
  for (int type : {CV_8UC3, CV_16UC1}) {
    Bytes png;
    ASSERT_TRUE(cv::imencode(".png", sampleImage(24, 31, type, 21), png));
    for (size_t n = 0; n < png.size(); ++n) {
      const Bytes cut(png.begin(), png.begin() + long(n));
      for (int flags : {cv::IMREAD_COLOR, cv::IMREAD_UNCHANGED}) {
        const std::string e = errorOf(cut, flags);
        EXPECT_FALSE(e.empty()) << "truncated to " << n << " of " << png.size() << " accepted";
      }
    }
    EXPECT_EQ(errorOf(Bytes(png.begin(), png.begin() + 5)), "bad PNG signature");
    EXPECT_NE(errorOf(Bytes(png.begin(), png.end() - 12)).find("missing IEND"), std::string::npos);
    EXPECT_NE(errorOf(Bytes(png.begin(), png.end() - 20)).find("truncated IDAT chunk"),
              std::string::npos);
  }
}

TEST(PngDecode, EveryFlippedBitIsCaught) {
  Bytes png;
  ASSERT_TRUE(cv::imencode(".png", sampleImage(9, 10, CV_8UC3, 22), png));
  for (size_t i = 0; i < png.size(); ++i) {
    for (int bit : {0, 3, 7}) {
      Bytes bad = png;
      bad[i] ^= uint8_t(1 << bit);
      EXPECT_FALSE(errorOf(bad).empty()) << "flip of bit " << bit << " at " << i << " accepted";
    }
  }
  Bytes bad = png;
  bad[png.size() - 30] ^= 0x10;  // inside IDAT
  EXPECT_NE(errorOf(bad).find("CRC error in IDAT chunk"), std::string::npos) << errorOf(bad);
  bad = png;
  bad[png.size() - 1] ^= 1;  // IEND's CRC
  EXPECT_NE(errorOf(bad).find("CRC error in IEND"), std::string::npos) << errorOf(bad);
}

// Corrupt content behind correct CRCs: the zlib stream, the IHDR fields, the filter bytes,
// the inflated size, the chunk order.
TEST(PngDecode, CorruptContentWithValidCrcs) {
  const int w = 17, h = 6, bpp = 3;
  const Bytes pixels = samplePixels(size_t(w * h * bpp), 31);
  const Bytes rows =
      filterRows(pixels, size_t(h), size_t(w * bpp), bpp, [](size_t y) { return int(y % 5); });
  const Bytes good = buildPng(ihdr(w, h, 8, 2), rows);
  ASSERT_TRUE(errorOf(good).empty());
  const auto chunks = parseChunks(good);

  // Every byte of the zlib stream changed (CRC recomputed): the inflater or Adler-32 catches it.
  const Bytes& z = chunks[1].data;
  for (size_t i = 0; i < z.size(); ++i) {
    auto c = chunks;
    c[1].data[i] ^= 0x24;
    const std::string e = errorOf(assemble(c));
    EXPECT_FALSE(e.empty()) << "zlib byte " << i << " changed, accepted";
  }
  auto c = chunks;
  c[1].data[0] = 0x79;  // zlib header check bits wrong
  EXPECT_NE(errorOf(assemble(c)).find("bad zlib stream"), std::string::npos);

  // IHDR fields.
  const std::vector<std::pair<Bytes, std::string>> headers = {
      {ihdr(w + 1, h, 8, 2), "inflates to fewer"},
      {ihdr(w, h + 1, 8, 2), "inflates to fewer"},
      {ihdr(w, h - 1, 8, 2), "inflates to more"},
      {ihdr(w, h, 16, 2), "inflates to fewer"},
      {ihdr(0, h, 8, 2), "bad image size"},
      {ihdr(w, 0x80000000u, 8, 2), "bad image size"},
      {ihdr(1u << 21, 1, 8, 2), "image too large"},
      {ihdr(60000, 60000, 8, 2), "image too large"},
      {ihdr(w, h, 7, 2), "bad bit depth"},
      {ihdr(w, h, 4, 2), "bad bit depth"},
      {ihdr(w, h, 8, 5), "bad colour type"},
      {ihdr(w, h, 8, 2, 2), "unknown interlace method"},
      {ihdr(30000, 30000, 8, 2), "too short"}};
  for (const auto& [hdr, msg] : headers) {
    c = chunks;
    c[0].data = hdr;
    const std::string e = errorOf(assemble(c));
    EXPECT_NE(e.find(msg), std::string::npos) << "want '" << msg << "', got '" << e << "'";
  }
  for (int field : {10, 11}) {
    c = chunks;
    c[0].data[size_t(field)] = 1;
    EXPECT_NE(errorOf(assemble(c)).find("unknown"), std::string::npos);
  }
  c = chunks;
  c[0].data.push_back(0);
  EXPECT_NE(errorOf(assemble(c)).find("IHDR length 14"), std::string::npos);

  // Bad filter bytes (5 and 255) in the middle row, the stream otherwise valid.
  for (int f : {5, 255}) {
    Bytes r = rows;
    r[3 * (w * bpp + 1)] = uint8_t(f);
    const Bytes png = buildPng(ihdr(w, h, 8, 2), r);
    EXPECT_NE(errorOf(png).find("unknown filter type " + std::to_string(f) + " in row 3"),
              std::string::npos)
        << errorOf(png);
  }
  // Inflated size off by one either way.
  Bytes longer = rows;
  longer.push_back(0);
  EXPECT_NE(errorOf(buildPng(ihdr(w, h, 8, 2), longer)).find("inflates to more"),
            std::string::npos);
  const Bytes shorter(rows.begin(), rows.end() - 1);
  EXPECT_NE(errorOf(buildPng(ihdr(w, h, 8, 2), shorter)).find("inflates to fewer"),
            std::string::npos);

  // Chunk structure.
  c = {chunks[0], chunks[2]};
  EXPECT_EQ(errorOf(assemble(c)), "no IDAT chunk");
  c = {chunks[1], chunks[0], chunks[2]};
  EXPECT_EQ(errorOf(assemble(c)), "first chunk is IDAT, not IHDR");
  c = parseChunks(buildPng(ihdr(w, h, 8, 2), rows, 2));
  c.insert(c.begin() + 2, Chunk{"tEXt", {'a', 0, 'b'}});
  EXPECT_EQ(errorOf(assemble(c)), "IDAT chunks are not consecutive");
  c = chunks;
  c.insert(c.begin() + 1, Chunk{"ABCD", {1}});
  EXPECT_EQ(errorOf(assemble(c)), "unknown critical chunk ABCD");
  c = chunks;
  c.insert(c.begin() + 1, Chunk{"ab1d", {1}});
  EXPECT_NE(errorOf(assemble(c)).find("bad chunk type ab\\x31d"), std::string::npos)
      << errorOf(assemble(c));
  c = chunks;
  c.insert(c.begin() + 1, chunks[0]);
  EXPECT_EQ(errorOf(assemble(c)), "second IHDR chunk");
  // A palette image without its palette: the fallback's failure is an error too.
  c = chunks;
  c[0].data = ihdr(w * 3, h, 8, 3);
  EXPECT_NE(errorOf(assemble(c)).find("OpenCV"), std::string::npos);
}

// loadRawFrame turns decoder errors into FrameLoadError naming the file and the reason.
// The size an IHDR announces is bounded before anything is allocated, on OpenCV's path too
// (issue 20): IDAT data too short to inflate to the image, a size over the pixel limit, a size
// other than the expected one. Before, the fallback layouts (interlaced, palette, ...) went to
// cv::imdecode, which allocated a 20000x20000 image (1.2 GB) before it found the data short
// ("OpenCV could not decode this PNG layout").
TEST(PngDecode, AnnouncedSizeIsBoundedBeforeDecoding) {
  const Bytes one_row(1 + 3 * 4, 0);
  const Bytes plte = {0, 0, 0, 255, 255, 255};
  const std::vector<std::pair<Bytes, const char*>> huge = {
      {buildPng(ihdr(20000, 20000, 8, 2, 1), one_row), "interlaced RGB"},
      {buildPng(ihdr(20000, 20000, 1, 3), one_row, 1, {{"PLTE", plte}}), "1-bit palette"},
      {buildPng(ihdr(20000, 20000, 8, 2), one_row), "RGB (fast path)"}};
  for (const auto& [png, what] : huge) {
    for (const int flags : {cv::IMREAD_COLOR, cv::IMREAD_UNCHANGED, cv::IMREAD_GRAYSCALE}) {
      const std::string e = errorOf(png, flags);
      EXPECT_NE(e.find("too short for a 20000x20000 image"), std::string::npos)
          << what << " flags " << flags << ": " << e;
    }
  }

  // A real 4100x4100 grey PNG (zeros: deflate near its 1032:1 maximum) is over the default
  // limit of 4096 x 4096 pixels on both paths; a raised limit decodes it.
  const int side = 4100;
  const Bytes big = buildPng(ihdr(side, side, 8, 0), Bytes(size_t(side) * (side + 1), 0));
  for (const int flags : {cv::IMREAD_UNCHANGED, cv::IMREAD_GRAYSCALE}) {
    const std::string e = errorOf(big, flags);
    EXPECT_NE(e.find("PNG announced size 4100x4100 is over the limit of 16777216 pixels"),
              std::string::npos)
        << "flags " << flags << ": " << e;
  }
  pplvo::ImageLimits raised;
  raised.max_pixels = uint64_t(side) * side;
  PngDecodePath path{};
  EXPECT_EQ(decodePng(big.data(), big.size(), cv::IMREAD_UNCHANGED, &path, raised).size(),
            cv::Size(side, side));
  EXPECT_EQ(path, PngDecodePath::kFast);

  // A known size: the IHDR must announce it (or its transpose when OpenCV rotates by eXIf).
  Bytes small;
  ASSERT_TRUE(cv::imencode(".png", cv::Mat(7, 5, CV_8UC3, cv::Scalar(1, 2, 3)), small));  // 5x7
  pplvo::ImageLimits expect;
  expect.expected = cv::Size(5, 7);
  EXPECT_EQ(decodePng(small.data(), small.size(), cv::IMREAD_COLOR, nullptr, expect).size(),
            cv::Size(5, 7));
  expect.expected = cv::Size(7, 7);
  try {
    decodePng(small.data(), small.size(), cv::IMREAD_COLOR, nullptr, expect);
    ADD_FAILURE() << "a 5x7 PNG passed for 7x7";
  } catch (const PngError& e) {
    EXPECT_NE(std::string(e.what()).find("announced size 5x7 differs from the expected 7x7"),
              std::string::npos)
        << e.what();
  }
  const Bytes exif = {'M', 'M', 0, 42, 0, 0, 0, 8, 0, 1, 0x01, 0x12, 0, 3,
                      0,   0,   0, 1,  0, 6, 0, 0, 0, 0, 0, 0,    0,    0};
  auto chunks = parseChunks(small);
  chunks.insert(chunks.begin() + 1, Chunk{"eXIf", exif});
  const Bytes rotated = assemble(chunks);
  expect.expected = cv::Size(7, 5);  // OpenCV's rotated image
  EXPECT_EQ(decodePng(rotated.data(), rotated.size(), cv::IMREAD_COLOR, nullptr, expect).size(),
            cv::Size(7, 5));
  EXPECT_THROW(decodePng(rotated.data(), rotated.size(), cv::IMREAD_UNCHANGED, nullptr, expect),
               PngError);  // not rotated: 5x7
}

TEST(PngDecode, LoadRawFrameReportsTheReason) {
  const fs::path dir = fs::temp_directory_path() / ("pplvo_test_png_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  Bytes rgb, depth;
  ASSERT_TRUE(cv::imencode(".png", sampleImage(6, 8, CV_8UC3, 41), rgb));
  ASSERT_TRUE(cv::imencode(".png", sampleImage(6, 8, CV_16UC1, 42), depth));
  auto write = [&](const std::string& name, const Bytes& b) {
    std::ofstream(dir / name, std::ios::binary)
        .write(reinterpret_cast<const char*>(b.data()), long(b.size()));
    return (dir / name).string();
  };
  DatasetEntry e;
  e.rgb_path = write("rgb.png", rgb);
  e.depth_path = write("depth.png", depth);
  const RawFrame f = loadRawFrame(e, 5000.0);
  EXPECT_TRUE(identical(f.bgr, cv::imdecode(rgb, cv::IMREAD_COLOR)));
  cv::Mat want = cv::imdecode(depth, cv::IMREAD_UNCHANGED);
  want.setTo(0, want > 65534);
  EXPECT_TRUE(identical(f.depth_units, want));

  Bytes bad = depth;
  bad[bad.size() - 20] ^= 1;
  e.depth_path = write("bad.png", bad);
  try {
    loadRawFrame(e, 5000.0);
    FAIL() << "corrupt depth accepted";
  } catch (const FrameLoadError& err) {
    const std::string m = err.what();
    EXPECT_NE(m.find("corrupt image file (CRC error in IDAT chunk"), std::string::npos) << m;
    EXPECT_NE(m.find("bad.png"), std::string::npos) << m;
    EXPECT_EQ(err.path(), e.depth_path);
  }
  fs::remove_all(dir);
}

// One decompressor and scratch buffers per thread: concurrent decoding is safe and exact.
TEST(PngDecode, ConcurrentThreads) {
  Bytes a, b;
  ASSERT_TRUE(cv::imencode(".png", sampleImage(120, 160, CV_8UC3, 51), a));
  ASSERT_TRUE(cv::imencode(".png", sampleImage(200, 90, CV_16UC1, 52), b));
  const cv::Mat ra = cv::imdecode(a, cv::IMREAD_COLOR), rb = cv::imdecode(b, cv::IMREAD_UNCHANGED);
  std::array<int, 3> bad{};
  std::vector<std::thread> threads;
  for (int t = 0; t < 3; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < 40; ++i) {
        const bool first = (i + t) % 2 == 0;
        const Bytes& png = first ? a : b;
        const cv::Mat m =
            decodePng(png.data(), png.size(), first ? cv::IMREAD_COLOR : cv::IMREAD_UNCHANGED);
        if (!identical(m, first ? ra : rb)) ++bad[size_t(t)];
      }
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(bad, (std::array<int, 3>{}));
}

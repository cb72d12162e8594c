// OpenCV's imgcodecs is loaded only when a frame needs OpenCV's decoder (opencv_codecs.h):
// this binary does not link it, so the library must be absent until a palette PNG arrives.
#include <gtest/gtest.h>
#include <libdeflate.h>

#include <cstdint>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "pplvo/core/opencv_codecs.h"
#include "pplvo/dataset/png_decode.h"

namespace {

using Bytes = std::vector<uint8_t>;

void put32(Bytes& b, uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) b.push_back(uint8_t(v >> s));
}

void chunk(Bytes& png, const char* type, const Bytes& data) {
  put32(png, uint32_t(data.size()));
  Bytes typed(type, type + 4);
  typed.insert(typed.end(), data.begin(), data.end());
  png.insert(png.end(), typed.begin(), typed.end());
  put32(png, libdeflate_crc32(0, typed.data(), typed.size()));
}

/// A w x h PNG of bit depth 8 and this colour type (2: RGB, 3: palette) whose rows are
/// `pixels` (bytes per pixel: 3 or 1), filter type 0, optionally with a PLTE chunk.
Bytes makePng(int w, int h, int colour_type, const Bytes& pixels, const Bytes& plte = {}) {
  Bytes png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  Bytes ihdr;
  put32(ihdr, uint32_t(w));
  put32(ihdr, uint32_t(h));
  ihdr.insert(ihdr.end(), {8, uint8_t(colour_type), 0, 0, 0});
  chunk(png, "IHDR", ihdr);
  if (!plte.empty()) chunk(png, "PLTE", plte);
  const size_t row = pixels.size() / size_t(h);
  Bytes raw;
  for (int y = 0; y < h; ++y) {
    raw.push_back(0);
    raw.insert(raw.end(), pixels.begin() + long(y * row), pixels.begin() + long((y + 1) * row));
  }
  libdeflate_compressor* c = libdeflate_alloc_compressor(6);
  Bytes z(libdeflate_zlib_compress_bound(c, raw.size()));
  z.resize(libdeflate_zlib_compress(c, raw.data(), raw.size(), z.data(), z.size()));
  libdeflate_free_compressor(c);
  chunk(png, "IDAT", z);
  chunk(png, "IEND", {});
  return png;
}

TEST(LazyOpenCvCodecs, LoadedOnlyWhenAFrameNeedsOpenCvsDecoder) {
  namespace pd = pplvo::dataset;
  ASSERT_FALSE(pplvo::openCvCodecsLoaded()) << "this test must not link opencv_imgcodecs";

  // An ordinary RGB PNG: the fast path, no OpenCV.
  const int w = 7, h = 3;
  Bytes rgb;
  for (int i = 0; i < w * h; ++i) rgb.insert(rgb.end(), {uint8_t(i), uint8_t(2 * i), 200});
  const Bytes plain = makePng(w, h, 2, rgb);
  pd::PngDecodePath path{};
  const cv::Mat a = pd::decodePng(plain.data(), plain.size(), cv::IMREAD_COLOR, &path);
  EXPECT_EQ(path, pd::PngDecodePath::kFast);
  EXPECT_EQ(a.at<cv::Vec3b>(2, 6), cv::Vec3b(200, 40, 20));  // BGR of pixel 20
  EXPECT_FALSE(pplvo::openCvCodecsLoaded());

  // A palette PNG: OpenCV decodes it, loaded on demand.
  const Bytes plte = {10, 20, 30, 40, 50, 60};
  Bytes idx;
  for (int i = 0; i < w * h; ++i) idx.push_back(uint8_t(i % 2));
  const Bytes palette = makePng(w, h, 3, idx, plte);
  const cv::Mat b = pd::decodePng(palette.data(), palette.size(), cv::IMREAD_COLOR, &path);
  EXPECT_EQ(path, pd::PngDecodePath::kOpenCv);
  EXPECT_TRUE(pplvo::openCvCodecsLoaded());
  ASSERT_EQ(b.type(), CV_8UC3);
  EXPECT_EQ(b.at<cv::Vec3b>(0, 1), cv::Vec3b(60, 50, 40));
  EXPECT_EQ(b.at<cv::Vec3b>(0, 0), cv::Vec3b(30, 20, 10));

  // Bytes OpenCV cannot decode either: empty, not a crash.
  const Bytes junk = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  EXPECT_TRUE(pplvo::openCvImdecode(junk.data(), junk.size(), cv::IMREAD_COLOR).empty());
}

}  // namespace

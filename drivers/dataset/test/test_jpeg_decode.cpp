// The TurboJPEG decoder against cv::imdecode: the same pixels on colour and grey JPEGs of
// several sizes, qualities and subsamplings and on the shared sequences' frames re-encoded;
// truncated or corrupt JPEGs refused with a reason (cv::imdecode returns them part grey);
// Exif-rotated and CMYK files left to OpenCV; safe from several threads; the dataset reader
// reading rgb/*.jpg.
#include <gtest/gtest.h>
#include <turbojpeg.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <thread>
#include <vector>

#include "pplvo/dataset/dataset.h"
#include "pplvo/dataset/jpeg_decode.h"

namespace fs = std::filesystem;
using namespace pplvo::dataset;
using Bytes = std::vector<uint8_t>;

namespace {

std::string sharedData() {
  const char* env = std::getenv("PPLVO_SHARED_DATA");
  return env ? env : "../shared/data";
}

/// Smooth gradients plus seeded noise: realistic for JPEG (pure noise would be mostly
/// quantisation error).
cv::Mat sampleImage(int rows, int cols, int type, uint64_t seed) {
  cv::Mat m(rows, cols, type);
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::UNIFORM, 0, 40);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const int v = (r * 255 / std::max(rows - 1, 1) + c * 97 / std::max(cols - 1, 1)) % 216;
      uint8_t* px = m.ptr<uint8_t>(r) + c * m.channels();
      for (int k = 0; k < m.channels(); ++k) px[k] = uint8_t(px[k] + (v + 60 * k) % 216);
    }
  }
  return m;
}

/// variant 0: baseline, 1: progressive, 2: optimised Huffman tables, 3: restart intervals.
Bytes encode(const cv::Mat& m, int quality, int variant = 0) {
  std::vector<int> params = {cv::IMWRITE_JPEG_QUALITY, quality};
  if (variant == 1) params.insert(params.end(), {cv::IMWRITE_JPEG_PROGRESSIVE, 1});
  if (variant == 2) params.insert(params.end(), {cv::IMWRITE_JPEG_OPTIMIZE, 1});
  if (variant == 3) params.insert(params.end(), {cv::IMWRITE_JPEG_RST_INTERVAL, 2});
  Bytes out;
  EXPECT_TRUE(cv::imencode(".jpg", m, out, params));
  return out;
}

::testing::AssertionResult identical(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) {
    return ::testing::AssertionFailure() << "size/type " << a.cols << "x" << a.rows << "/"
                                         << a.type() << " vs " << b.cols << "x" << b.rows << "/"
                                         << b.type();
  }
  const double diff = cv::norm(a, b, cv::NORM_INF);
  if (diff != 0) return ::testing::AssertionFailure() << "max difference " << diff;
  return ::testing::AssertionSuccess();
}

std::string errorOf(const Bytes& b, int flags = cv::IMREAD_COLOR) {
  try {
    decodeJpeg(b.data(), b.size(), flags);
  } catch (const JpegError& e) {
    return e.what();
  }
  return "";
}

/// The first bytes of a JPEG, up to the middle of its entropy-coded data (after the last SOS).
Bytes cutInScan(const Bytes& jpg) {
  size_t sos = 0;
  for (size_t i = 2; i + 1 < jpg.size(); ++i) {
    if (jpg[i] == 0xFF && jpg[i + 1] == 0xDA) sos = i;
  }
  EXPECT_GT(sos, 0u);
  return Bytes(jpg.begin(), jpg.begin() + long(sos + (jpg.size() - sos) / 2));
}

void expectSameAsOpenCv(const Bytes& jpg, const std::string& what,
                        JpegDecodePath want = JpegDecodePath::kTurbo) {
  for (int flags : {cv::IMREAD_COLOR, cv::IMREAD_GRAYSCALE, cv::IMREAD_UNCHANGED}) {
    JpegDecodePath path;
    const cv::Mat got = decodeJpeg(jpg.data(), jpg.size(), flags, &path);
    EXPECT_TRUE(identical(got, cv::imdecode(jpg, flags))) << what << " flags " << flags;
    EXPECT_EQ(path, want) << what << " flags " << flags;
  }
}

// (a) The same pixels as cv::imdecode.
TEST(JpegDecode, SameAsOpenCvOnSyntheticImages) {
  uint64_t seed = 1;
  for (const cv::Size sz : {cv::Size(1, 1), cv::Size(17, 5), cv::Size(33, 64), cv::Size(640, 480)}) {
    for (int quality : {50, 95, 100}) {
      for (int variant : {0, 1, 2, 3}) {
        const std::string what = std::to_string(sz.width) + "x" + std::to_string(sz.height) +
                                 " q" + std::to_string(quality) + " v" + std::to_string(variant);
        expectSameAsOpenCv(encode(sampleImage(sz.height, sz.width, CV_8UC3, seed++), quality,
                                  variant),
                           "colour " + what);
      }
      expectSameAsOpenCv(encode(sampleImage(sz.height, sz.width, CV_8UC1, seed++), quality),
                         "grey " + std::to_string(sz.width) + "x" + std::to_string(sz.height));
    }
  }
  // The channel layouts: a grey JPEG gives one channel unchanged, three as colour.
  const Bytes grey = encode(sampleImage(8, 8, CV_8UC1, 99), 90);
  EXPECT_EQ(decodeJpeg(grey.data(), grey.size(), cv::IMREAD_UNCHANGED).type(), CV_8UC1);
  EXPECT_EQ(decodeJpeg(grey.data(), grey.size(), cv::IMREAD_COLOR).type(), CV_8UC3);
}

TEST(JpegDecode, SameAsOpenCvOnSharedFramesReencoded) {
  for (const char* seq : {"icl_living_room_kt0_short", "tum_fr1_xyz_short"}) {
    const std::string dir = sharedData() + "/" + seq + "/rgb";
    if (!fs::is_directory(dir)) GTEST_SKIP() << "no shared data at " << dir;
    std::vector<std::string> files;
    for (const auto& e : fs::directory_iterator(dir)) files.push_back(e.path().string());
    std::sort(files.begin(), files.end());
    files.resize(std::min<size_t>(files.size(), 5));
    for (const auto& f : files) {
      const Bytes jpg = encode(cv::imread(f, cv::IMREAD_COLOR), 95);
      JpegDecodePath path;
      const cv::Mat got = decodeJpeg(jpg.data(), jpg.size(), cv::IMREAD_COLOR, &path);
      EXPECT_EQ(path, JpegDecodePath::kTurbo);
      EXPECT_TRUE(identical(got, cv::imdecode(jpg, cv::IMREAD_COLOR))) << f;
    }
  }
}

// (b) Corrupt input: an error with a reason, never an image.
TEST(JpegDecode, TruncatedAtEveryOffsetIsAnError) {
  const Bytes jpg = encode(sampleImage(24, 31, CV_8UC3, 21), 90);
  // cv::imdecode accepts a truncated JPEG (libjpeg pads it with grey): the reason for this
  // decoder.
  const Bytes half = cutInScan(jpg);
  EXPECT_FALSE(cv::imdecode(half, cv::IMREAD_COLOR).empty());
  // The last two bytes are the EOI marker, which libjpeg does not need to finish the scan.
  for (size_t n = 0; n + 2 < jpg.size(); ++n) {
    const Bytes cut(jpg.begin(), jpg.begin() + long(n));
    for (int flags : {cv::IMREAD_COLOR, cv::IMREAD_UNCHANGED}) {
      EXPECT_FALSE(errorOf(cut, flags).empty())
          << "truncated to " << n << " of " << jpg.size() << " accepted";
    }
  }
  EXPECT_EQ(errorOf(Bytes(jpg.begin(), jpg.begin() + 2)), "bad JPEG signature");
  EXPECT_NE(errorOf(half).find("corrupt JPEG data"), std::string::npos) << errorOf(half);
}

TEST(JpegDecode, CorruptHeaderAndDataAreErrors) {
  const Bytes jpg = encode(sampleImage(40, 48, CV_8UC3, 31), 90);
  EXPECT_EQ(errorOf(Bytes{'n', 'o', 't', ' ', 'j', 'p', 'e', 'g'}), "bad JPEG signature");
  // A marker in the middle of the entropy-coded data: "premature end of data segment".
  size_t sos = 0;
  for (size_t i = 2; i + 1 < jpg.size(); ++i) {
    if (jpg[i] == 0xFF && jpg[i + 1] == 0xDA) sos = i;
  }
  ASSERT_GT(sos, 0u);
  Bytes bad = jpg;
  const size_t mid = sos + (jpg.size() - sos) / 2;
  bad[mid] = 0xFF;
  bad[mid + 1] = 0xD9;
  EXPECT_NE(errorOf(bad).find("corrupt JPEG data"), std::string::npos) << errorOf(bad);
  // A zero height in the frame header (SOF0: FF C0, length, precision, height, width).
  bad = jpg;
  for (size_t i = 2; i + 9 < bad.size(); ++i) {
    if (bad[i] == 0xFF && bad[i + 1] == 0xC0) {
      bad[i + 5] = bad[i + 6] = 0;
      break;
    }
  }
  EXPECT_NE(errorOf(bad).find("bad JPEG header"), std::string::npos) << errorOf(bad);
  // Garbage after the SOI marker.
  bad = Bytes{0xFF, 0xD8, 0xFF, 0x00, 0x01, 0x02, 0x03};
  EXPECT_FALSE(errorOf(bad).empty());
}

// (c) What OpenCV treats differently is left to it: Exif orientation (rotated by OpenCV for
// COLOR and GRAYSCALE), other flags.
TEST(JpegDecode, ExifOrientationIsLeftToOpenCv) {
  const Bytes jpg = encode(sampleImage(20, 36, CV_8UC3, 41), 90);
  for (bool big_endian : {true, false}) {
    // APP1 "Exif\0\0" + TIFF header + IFD0 with one entry: orientation (0x0112, SHORT) = 6.
    Bytes tiff = big_endian ? Bytes{'M', 'M', 0, 42, 0, 0, 0, 8, 0, 1, 0x01, 0x12, 0, 3,
                                    0,   0,   0, 1,  0, 6, 0, 0, 0, 0, 0, 0,    0,    0}
                            : Bytes{'I', 'I', 42, 0, 8, 0, 0, 0, 1, 0, 0x12, 0x01, 3, 0,
                                    1,   0,   0,  0, 6, 0, 0, 0, 0, 0, 0, 0,    0,    0};
    Bytes payload = {'E', 'x', 'i', 'f', 0, 0};
    payload.insert(payload.end(), tiff.begin(), tiff.end());
    const size_t len = payload.size() + 2;
    Bytes rotated = {0xFF, 0xD8, 0xFF, 0xE1, uint8_t(len >> 8), uint8_t(len)};
    rotated.insert(rotated.end(), payload.begin(), payload.end());
    rotated.insert(rotated.end(), jpg.begin() + 2, jpg.end());
    JpegDecodePath path;
    const cv::Mat colour = decodeJpeg(rotated.data(), rotated.size(), cv::IMREAD_COLOR, &path);
    EXPECT_EQ(path, JpegDecodePath::kOpenCv);
    EXPECT_EQ(colour.rows, 36);  // rotated by 90 degrees
    EXPECT_TRUE(identical(colour, cv::imdecode(rotated, cv::IMREAD_COLOR)));
    // Unchanged: OpenCV does not rotate, nor does TurboJPEG.
    const cv::Mat raw = decodeJpeg(rotated.data(), rotated.size(), cv::IMREAD_UNCHANGED, &path);
    EXPECT_EQ(path, JpegDecodePath::kTurbo);
    EXPECT_TRUE(identical(raw, cv::imdecode(rotated, cv::IMREAD_UNCHANGED)));
  }
  // Other flags: OpenCV.
  JpegDecodePath path;
  const cv::Mat half = decodeJpeg(jpg.data(), jpg.size(), cv::IMREAD_REDUCED_COLOR_2, &path);
  EXPECT_EQ(path, JpegDecodePath::kOpenCv);
  EXPECT_TRUE(identical(half, cv::imdecode(jpg, cv::IMREAD_REDUCED_COLOR_2)));
}

/// The JPEG with its frame header's size replaced (the first SOFn marker).
Bytes withFrameSize(Bytes jpg, int width, int height) {
  for (size_t i = 2; i + 9 < jpg.size(); ++i) {
    if (jpg[i] == 0xFF && jpg[i + 1] >= 0xC0 && jpg[i + 1] <= 0xC2) {
      jpg[i + 5] = uint8_t(height >> 8);
      jpg[i + 6] = uint8_t(height);
      jpg[i + 7] = uint8_t(width >> 8);
      jpg[i + 8] = uint8_t(width);
      return jpg;
    }
  }
  ADD_FAILURE() << "no frame header";
  return jpg;
}

/// The JPEG with an Exif APP1 block (orientation 6: OpenCV rotates it by 90 degrees).
Bytes withExifOrientation6(const Bytes& jpg) {
  const Bytes payload = {'E', 'x', 'i', 'f', 0, 0, 'M', 'M', 0, 42, 0, 0, 0, 8, 0, 1, 0x01, 0x12,
                         0,   3,   0, 0, 0,   1, 0,   6,  0, 0, 0, 0, 0, 0, 0, 0};
  const size_t len = payload.size() + 2;
  Bytes out = {0xFF, 0xD8, 0xFF, 0xE1, uint8_t(len >> 8), uint8_t(len)};
  out.reserve(out.size() + payload.size() + jpg.size());
  out.insert(out.end(), payload.begin(), payload.end());
  out.insert(out.end(), jpg.begin() + 2, jpg.end());
  return out;
}

// (c2) The size a header announces is bounded before anything is allocated (issue 20): a
// file too short for a Huffman-coded image of that size, a size over the pixel limit, a size
// other than the expected one. Before the bounds, the 20000x20000 header of a 1 KB file (400
// Mpixels, under the old 2^30 limit) had a 1.2 GB image allocated (on the OpenCV path, written
// in full) before the data was read; those files then failed with "corrupt JPEG data".
TEST(JpegDecode, AnnouncedSizeIsBoundedBeforeDecoding) {
  const Bytes small = encode(sampleImage(16, 16, CV_8UC3, 51), 90);
  ASSERT_LT(small.size(), 2000u);
  for (const int variant : {0, 1}) {  // baseline, progressive
    const Bytes huge = withFrameSize(encode(sampleImage(16, 16, CV_8UC3, 52), 90, variant),
                                     20000, 20000);
    for (const Bytes& b : {huge, withExifOrientation6(huge)}) {
      for (const int flags : {cv::IMREAD_COLOR, cv::IMREAD_GRAYSCALE, cv::IMREAD_UNCHANGED}) {
        const std::string e = errorOf(b, flags);
        EXPECT_NE(e.find("too short for a Huffman-coded 20000x20000 image"), std::string::npos)
            << e;
      }
    }
  }
  // 60000 x 60000 (over 2^30 too): the same refusal.
  EXPECT_NE(errorOf(withFrameSize(small, 60000, 60000)).find("too short"), std::string::npos);

  // A real 4100x4100 image (uniform: about 2 bits per block, well within the Huffman bound) is
  // over the default limit of 4096 x 4096 pixels; a raised limit decodes it.
  const Bytes big = encode(cv::Mat(4100, 4100, CV_8UC1, cv::Scalar(90)), 90);
  EXPECT_NE(errorOf(big, cv::IMREAD_UNCHANGED)
                .find("JPEG announced size 4100x4100 is over the limit of 16777216 pixels"),
            std::string::npos)
      << errorOf(big, cv::IMREAD_UNCHANGED);
  pplvo::ImageLimits raised;
  raised.max_pixels = 4100 * 4100;
  EXPECT_EQ(decodeJpeg(big.data(), big.size(), cv::IMREAD_UNCHANGED, nullptr, raised).size(),
            cv::Size(4100, 4100));

  // A known size: the header must announce it (or its transpose when OpenCV rotates).
  const Bytes wide = encode(sampleImage(16, 24, CV_8UC3, 53), 90);  // 24 x 16
  pplvo::ImageLimits expect;
  expect.expected = cv::Size(24, 16);
  EXPECT_EQ(decodeJpeg(wide.data(), wide.size(), cv::IMREAD_COLOR, nullptr, expect).size(),
            cv::Size(24, 16));
  expect.expected = cv::Size(32, 16);
  try {
    decodeJpeg(wide.data(), wide.size(), cv::IMREAD_COLOR, nullptr, expect);
    ADD_FAILURE() << "a 24x16 JPEG passed for 32x16";
  } catch (const JpegError& e) {
    EXPECT_NE(std::string(e.what()).find("announced size 24x16 differs from the expected 32x16"),
              std::string::npos)
        << e.what();
  }
  const Bytes rotated = withExifOrientation6(wide);
  expect.expected = cv::Size(16, 24);  // OpenCV's rotated image
  EXPECT_EQ(decodeJpeg(rotated.data(), rotated.size(), cv::IMREAD_COLOR, nullptr, expect).size(),
            cv::Size(16, 24));
}

// The Huffman bound holds on the files that compress best: uniform images, every TurboJPEG
// subsampling (grey, 4:4:4 to 4:1:1), baseline and progressive, low to top quality (each file
// at least min_entropy_bits long).
TEST(JpegDecode, HuffmanLengthBoundHoldsOnUniformImages) {
  const int width = 1400, height = 1000;
  const std::vector<uint8_t> bgr(size_t(width) * height * 3, 128);
  for (const int sampling : {TJSAMP_GRAY, TJSAMP_444, TJSAMP_422, TJSAMP_420, TJSAMP_440,
                             TJSAMP_411}) {
    for (const int tj_flags : {0, TJFLAG_PROGRESSIVE}) {
      for (const int quality : {10, 50, 100}) {
        // A fresh handle per file: with one handle reused after a progressive file, libjpeg-turbo
        // 2.1.5 wrote baseline files that libjpeg then read as truncated.
        const std::unique_ptr<void, int (*)(tjhandle)> tj(tjInitCompress(), tjDestroy);
        ASSERT_TRUE(tj);
        unsigned char* out = nullptr;
        unsigned long out_size = 0;
        ASSERT_EQ(tjCompress2(tj.get(), bgr.data(), width, 0, height, TJPF_BGR, &out, &out_size,
                              sampling, quality, tj_flags),
                  0)
            << tjGetErrorStr2(tj.get());
        const Bytes jpg(out, out + out_size);
        tjFree(out);
        const auto h = pplvo::readJpegHeader(jpg.data(), jpg.size());
        ASSERT_TRUE(h.has_value());
        EXPECT_EQ(h->width, width);
        EXPECT_EQ(h->height, height);
        EXPECT_GT(h->min_entropy_bits, 0u);
        EXPECT_LE(h->min_entropy_bits, jpg.size() * 8)
            << "sampling " << sampling << " flags " << tj_flags << " quality " << quality;
        EXPECT_EQ(errorOf(jpg, cv::IMREAD_UNCHANGED), "")
            << "sampling " << sampling << " flags " << tj_flags << " quality " << quality;
      }
    }
  }
}

// (d) One TurboJPEG handle per thread: concurrent decoding is safe and exact.
TEST(JpegDecode, ConcurrentThreads) {
  const Bytes a = encode(sampleImage(120, 160, CV_8UC3, 51), 95);
  const Bytes b = encode(sampleImage(200, 90, CV_8UC1, 52), 80);
  const cv::Mat ra = cv::imdecode(a, cv::IMREAD_COLOR), rb = cv::imdecode(b, cv::IMREAD_UNCHANGED);
  std::array<int, 3> bad{};
  std::vector<std::thread> threads;
  for (int t = 0; t < 3; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < 40; ++i) {
        const bool first = (i + t) % 2 == 0;
        const Bytes& jpg = first ? a : b;
        const cv::Mat m =
            decodeJpeg(jpg.data(), jpg.size(), first ? cv::IMREAD_COLOR : cv::IMREAD_UNCHANGED);
        if (!identical(m, first ? ra : rb)) ++bad[size_t(t)];
      }
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(bad, (std::array<int, 3>{0, 0, 0}));
}

// (e) The dataset reader: rgb/*.jpg read like cv::imdecode reads it; a corrupt JPEG is a
// FrameLoadError naming the file (the reader counts it as a skip with skip_bad).
TEST(JpegDecode, DatasetReaderReadsJpegColour) {
  const fs::path dir = fs::temp_directory_path() / ("pplvo_jpeg_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const Bytes rgb = encode(sampleImage(48, 64, CV_8UC3, 61), 95);
  Bytes depth;
  ASSERT_TRUE(cv::imencode(".png", cv::Mat(48, 64, CV_16UC1, cv::Scalar(5000)), depth));
  auto write = [&](const std::string& name, const Bytes& b) {
    std::ofstream(dir / name, std::ios::binary)
        .write(reinterpret_cast<const char*>(b.data()), long(b.size()));
    return (dir / name).string();
  };
  DatasetEntry e;
  e.rgb_path = write("rgb.jpg", rgb);
  e.depth_path = write("depth.png", depth);
  const RawFrame f = loadRawFrame(e, 5000.0);
  EXPECT_TRUE(identical(f.bgr, cv::imdecode(rgb, cv::IMREAD_COLOR)));

  e.rgb_path = write("cut.jpg", cutInScan(rgb));
  try {
    loadRawFrame(e, 5000.0);
    FAIL() << "truncated colour JPEG accepted";
  } catch (const FrameLoadError& err) {
    const std::string m = err.what();
    EXPECT_NE(m.find("corrupt image file (corrupt JPEG data"), std::string::npos) << m;
    EXPECT_NE(m.find("cut.jpg"), std::string::npos) << m;
    EXPECT_EQ(err.path(), e.rgb_path);
  }
  fs::remove_all(dir);
}

}  // namespace

// Writes the seed corpus of fuzz_jpeg_decode (scripts/fuzz.sh): each given image, scaled to
// 160x120, as baseline, progressive, restart-interval and grey JPEGs, plus one with an Exif
// block (big-endian, orientation 6) and one little-endian with two IFD0 entries (orientation
// 3 second). A synthetic gradient stands in when no image is given or readable.
//
//   make_jpeg_seeds OUT_DIR [IMAGE...]
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

namespace {

using Bytes = std::vector<uint8_t>;

void write(const std::string& path, const Bytes& b) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
}

Bytes encode(const cv::Mat& m, std::vector<int> params) {
  Bytes out;
  cv::imencode(".jpg", m, out, params);
  return out;
}

/// `jpg` with an APP1 segment "Exif\0\0" + `tiff` inserted after the SOI marker.
Bytes withExif(const Bytes& jpg, const Bytes& tiff) {
  Bytes payload = {'E', 'x', 'i', 'f', 0, 0};
  payload.insert(payload.end(), tiff.begin(), tiff.end());
  const size_t len = payload.size() + 2;
  Bytes out = {0xFF, 0xD8, 0xFF, 0xE1, uint8_t(len >> 8), uint8_t(len)};
  out.insert(out.end(), payload.begin(), payload.end());
  out.insert(out.end(), jpg.begin() + 2, jpg.end());
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: make_jpeg_seeds OUT_DIR [IMAGE...]\n");
    return 2;
  }
  const std::string out = argv[1];
  std::vector<cv::Mat> images;
  for (int i = 2; i < argc; ++i) {
    cv::Mat m = cv::imread(argv[i], cv::IMREAD_COLOR);
    if (m.empty()) continue;
    cv::resize(m, m, cv::Size(160, 120), 0, 0, cv::INTER_AREA);
    images.push_back(m);
  }
  if (images.empty()) {
    cv::Mat m(120, 160, CV_8UC3);
    for (int r = 0; r < m.rows; ++r)
      for (int c = 0; c < m.cols; ++c)
        m.at<cv::Vec3b>(r, c) = cv::Vec3b(uint8_t(r * 2), uint8_t(c), uint8_t(r + c));
    images.push_back(m);
  }
  for (size_t k = 0; k < images.size(); ++k) {
    const std::string p = out + "/jpeg" + std::to_string(k) + "_";
    cv::Mat grey;
    cv::cvtColor(images[k], grey, cv::COLOR_BGR2GRAY);
    write(p + "baseline", encode(images[k], {cv::IMWRITE_JPEG_QUALITY, 90}));
    write(p + "progressive",
          encode(images[k], {cv::IMWRITE_JPEG_QUALITY, 75, cv::IMWRITE_JPEG_PROGRESSIVE, 1}));
    write(p + "restart",
          encode(images[k], {cv::IMWRITE_JPEG_QUALITY, 60, cv::IMWRITE_JPEG_RST_INTERVAL, 2}));
    write(p + "grey", encode(grey, {cv::IMWRITE_JPEG_QUALITY, 90}));
  }
  const Bytes small = encode(images[0], {cv::IMWRITE_JPEG_QUALITY, 50});
  // IFD0 at offset 8 with one entry: orientation (0x0112, SHORT, count 1) = 6.
  write(out + "/jpeg_exif_be",
        withExif(small, {'M', 'M', 0, 42, 0, 0, 0, 8, 0, 1, 0x01, 0x12, 0, 3,
                         0,   0,   0, 1,  0, 6, 0, 0, 0, 0, 0,    0,    0, 0}));
  // Two entries: image width (0x0100, LONG) then orientation = 3.
  write(
      out + "/jpeg_exif_le",
      withExif(small, {'I', 'I', 42, 0,    8,    0, 0, 0, 2, 0, 0x00, 0x01, 4, 0, 1, 0, 0, 0, 160,
                       0,   0,   0,  0x12, 0x01, 3, 0, 1, 0, 0, 0,    3,    0, 0, 0, 0, 0, 0, 0}));
  return 0;
}

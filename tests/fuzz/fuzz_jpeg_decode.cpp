// libFuzzer harness: the dataset reader's JPEG decoder (pplvo::dataset::decodeJpeg: TurboJPEG,
// with its own Exif orientation parser deciding which files go to OpenCV) on any bytes, with
// its default size limits (pplvo::kMaxImagePixels, the Huffman length bound: checked on the
// header before anything is allocated, so no input is skipped here). The documented error is
// JpegError only: any other exception escapes and libFuzzer reports it, as it does a crash, a
// sanitizer report or an allocation over its limit.
#include <cstddef>
#include <cstdint>
#include <opencv2/imgcodecs.hpp>

#include "pplvo/dataset/jpeg_decode.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  for (const int flags : {cv::IMREAD_COLOR, cv::IMREAD_GRAYSCALE, cv::IMREAD_UNCHANGED}) {
    try {
      const cv::Mat m = pplvo::dataset::decodeJpeg(data, size, flags);
      // A decoded image is whole, of the documented type and within the size limit.
      if (m.empty() || (m.type() != CV_8UC1 && m.type() != CV_8UC3) ||
          (flags == cv::IMREAD_COLOR && m.type() != CV_8UC3) ||
          (flags == cv::IMREAD_GRAYSCALE && m.type() != CV_8UC1) ||
          m.total() > pplvo::kMaxImagePixels) {
        __builtin_trap();
      }
      volatile uint8_t sink = m.data[m.total() * m.elemSize() - 1];
      (void)sink;
    } catch (const pplvo::dataset::JpegError&) {
    }
  }
  return 0;
}

// libFuzzer harness: the project's own PNG decoder (pplvo::dataset::decodePng, the fast path
// for 8-bit colour and 16-bit depth, OpenCV otherwise) on any bytes. A PngError or another
// std::exception is a frame the reader skips and counts; a crash or a sanitizer report is a
// finding.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <opencv2/imgcodecs.hpp>

#include "pplvo/dataset/png_decode.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  for (const int flags : {cv::IMREAD_COLOR, cv::IMREAD_UNCHANGED}) {
    try {
      const cv::Mat m = pplvo::dataset::decodePng(data, size, flags);
      if (!m.empty() && m.total() * m.elemSize() > 0) {
        volatile uint8_t sink = m.data[m.total() * m.elemSize() - 1];  // the whole image exists
        (void)sink;
      }
    } catch (const std::exception&) {
    }
  }
  return 0;
}

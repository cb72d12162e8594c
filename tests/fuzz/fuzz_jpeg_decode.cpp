// libFuzzer harness: the dataset reader's JPEG decoder (pplvo::dataset::decodeJpeg: TurboJPEG,
// with its own Exif orientation parser deciding which files go to OpenCV) on any bytes. The
// documented error is JpegError only: any other exception escapes and libFuzzer reports it, as
// it does a crash or a sanitizer report.
#include <turbojpeg.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <opencv2/imgcodecs.hpp>

#include "pplvo/dataset/jpeg_decode.h"

namespace {

// Headers announcing more pixels than this are skipped (as libjpeg-turbo's own fuzzers do):
// a 100-byte file may announce a 1-gigapixel image, whose buffer decodeJpeg allocates before
// it reads the data (3 GB, over libFuzzer's malloc limit). 16 Mpixels is four times the
// largest dataset frame we read and still decodes in milliseconds.
constexpr uint64_t kMaxFuzzPixels = 1ull << 24;

/// A fresh handle per input: libjpeg-turbo 2.1 leaves a handle that failed on a header unable
/// to read the next valid one (a reused handle let a 487-Mpixel header through this check).
bool announcesHugeImage(const uint8_t* data, size_t size) {
  const std::unique_ptr<void, int (*)(tjhandle)> h(tjInitDecompress(), tjDestroy);
  int width = 0, height = 0, subsamp = 0, colorspace = 0;
  if (!h || tjDecompressHeader3(h.get(), data, static_cast<unsigned long>(size), &width, &height,
                                &subsamp, &colorspace) != 0) {
    return false;  // decodeJpeg must refuse it itself
  }
  return uint64_t(width) * uint64_t(height) > kMaxFuzzPixels;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (pplvo::dataset::looksLikeJpeg(data, size) && announcesHugeImage(data, size)) return 0;
  for (const int flags : {cv::IMREAD_COLOR, cv::IMREAD_GRAYSCALE, cv::IMREAD_UNCHANGED}) {
    try {
      const cv::Mat m = pplvo::dataset::decodeJpeg(data, size, flags);
      // A decoded image is whole and of the documented type.
      if (m.empty() || (m.type() != CV_8UC1 && m.type() != CV_8UC3) ||
          (flags == cv::IMREAD_COLOR && m.type() != CV_8UC3) ||
          (flags == cv::IMREAD_GRAYSCALE && m.type() != CV_8UC1)) {
        __builtin_trap();
      }
      volatile uint8_t sink = m.data[m.total() * m.elemSize() - 1];
      (void)sink;
    } catch (const pplvo::dataset::JpegError&) {
    }
  }
  return 0;
}

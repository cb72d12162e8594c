#pragma once
/// A fast PNG decoder for dataset frames: libdeflate inflates the image data in one call and
/// the rows are unfiltered straight into the cv::Mat. The result is bit-identical to
/// cv::imdecode with the same flags. Layouts datasets use (non-interlaced, 8-bit RGB / RGBA /
/// grey, 16-bit grey; 16-bit RGB/RGBA and grey+alpha for IMREAD_COLOR) take the fast path;
/// every other valid PNG (palette, interlaced, 1/2/4-bit grey, other flags) is decoded by
/// cv::imdecode. Corrupt data is never handed to OpenCV: it raises PngError with the reason.
#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <stdexcept>

#include "pplvo/core/image_header.h"

namespace pplvo::dataset {

/// A corrupt or truncated PNG: bad signature, truncated chunk, CRC mismatch, bad IHDR, missing
/// IEND or IDAT, bad zlib stream, wrong inflated size, unknown filter type. what() says which.
class PngError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Which decoder produced the image.
enum class PngDecodePath { kFast, kOpenCv };

/// True when the buffer starts like a PNG (the first four signature bytes "\x89PNG"); such a
/// buffer goes to decodePng, which checks the whole signature.
bool looksLikePng(const uint8_t* data, size_t size);

/// Decodes a PNG held in memory like cv::imdecode(bytes, flags). The fast path serves
/// flags == cv::IMREAD_COLOR (CV_8UC3 BGR; alpha dropped, grey replicated, 16-bit reduced to
/// its high byte as libpng's strip_16) and flags == cv::IMREAD_UNCHANGED for grey (CV_8UC1 or
/// CV_16UC1 in native byte order). Every chunk's length and CRC is checked before anything is
/// decoded, on both paths. Throws PngError on corrupt input, also when OpenCV cannot decode a
/// fallback layout. Thread-safe: each thread keeps its own libdeflate decompressor and scratch
/// buffers (thread_local), reused from call to call. `path`, if given, receives the decoder used.
///
/// Before anything is allocated, on both paths: the IDAT data must be long enough to inflate
/// to the image (DEFLATE expands at most 1032:1), then the IHDR size is checked against
/// `limits` (equal to limits.expected when given, else at most limits.max_pixels,
/// pplvo::kMaxImagePixels by default; with an eXIf orientation OpenCV applies, the transposed
/// size too): otherwise PngError ("... too short ..." / "PNG announced
/// size ...").
cv::Mat decodePng(const uint8_t* data, size_t size, int flags, PngDecodePath* path = nullptr,
                  const ImageLimits& limits = {});

}  // namespace pplvo::dataset

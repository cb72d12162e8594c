#pragma once
/// JPEG decoding for dataset colour frames (7-Scenes-style folders with rgb/*.jpg): libjpeg-turbo's
/// TurboJPEG API decodes straight into the cv::Mat, with the same pixels as cv::imdecode (both
/// use libjpeg-turbo's default accurate integer DCT and fancy upsampling). Unlike cv::imdecode,
/// which fills a truncated or corrupt JPEG with grey and returns it with a message on stderr,
/// every libjpeg warning (premature end of data, corrupt entropy data, ...) is an error here.
#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <stdexcept>

#include "pplvo/core/image_header.h"

namespace pplvo::dataset {

/// A corrupt or truncated JPEG (bad header, premature end of data, corrupt entropy-coded
/// data, ...). what() gives libjpeg-turbo's reason.
class JpegError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Which decoder produced the image.
enum class JpegDecodePath { kTurbo, kOpenCv };

/// True when the buffer starts like a JPEG (SOI marker FF D8 followed by a marker FF).
bool looksLikeJpeg(const uint8_t* data, size_t size);

/// Decodes a JPEG held in memory like cv::imdecode(bytes, flags): flags == cv::IMREAD_COLOR
/// gives CV_8UC3 BGR, cv::IMREAD_GRAYSCALE CV_8UC1, cv::IMREAD_UNCHANGED CV_8UC1 for a grey
/// JPEG and CV_8UC3 BGR otherwise. Served by TurboJPEG, except what cv::imdecode would treat
/// differently: CMYK/YCCK JPEGs, an Exif orientation other than 1 with IMREAD_COLOR or
/// IMREAD_GRAYSCALE (OpenCV rotates the image), and other flags go to cv::imdecode. Throws
/// JpegError on corrupt input (on the OpenCV path: when it returns no image). Thread-safe:
/// each thread keeps its own TurboJPEG handle (thread_local). `path`, if given, receives the
/// decoder used.
///
/// Before anything is allocated, the frame header's size is checked against `limits` (equal to
/// limits.expected when given, else at most limits.max_pixels, pplvo::kMaxImagePixels by
/// default; with an Exif orientation OpenCV applies, the transposed size too; with
/// IMREAD_REDUCED_* flags, the stored full size), and a Huffman-coded file must be long enough to hold one bit per 8x8 block of its
/// smallest component (ImageHeader::min_entropy_bits): otherwise JpegError ("announced size
/// ..." / "... too short for ..."), on both paths.
cv::Mat decodeJpeg(const uint8_t* data, size_t size, int flags, JpegDecodePath* path = nullptr,
                   const ImageLimits& limits = {});

}  // namespace pplvo::dataset

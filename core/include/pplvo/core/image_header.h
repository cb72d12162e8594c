#pragma once
/// Image sizes read from a PNG or JPEG header without decoding anything, and the size bounds
/// every image decoder of the project checks on that header BEFORE it allocates the image
/// (pplvo/dataset decodePng / decodeJpeg, msgs::decodeImage). A few bytes of header may
/// announce any size up to 65535 x 65535 (JPEG) or 2^31 x 2^31 (PNG); decoders allocate the
/// announced image before they read the data, so without these bounds a 100-byte file costs
/// gigabytes. docs/fuzzing.md gives the reasoning.
#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

namespace pplvo {

/// Most pixels of one frame when its size is not known beforehand: 4096 x 4096 = 16.8 Mpixels.
/// The largest colour sensor of the RGB-D cameras in use fits (Azure Kinect: 4096 x 3072 =
/// 12.6 Mpixels); the project's datasets (TUM RGB-D, ICL-NUIM, 7-Scenes) and drivers
/// (freenect, OpenNI2) deliver 640 x 480, at most 1280 x 1024. Raise ImageLimits::max_pixels
/// for anything bigger.
constexpr uint64_t kMaxImagePixels = 4096ull * 4096ull;

/// What a decoder accepts, checked on the header before anything is allocated.
struct ImageLimits {
  /// The size the image must have when the caller knows it (the camera calibration, the
  /// message's width and height); empty (0 x 0) = not known. A known size is checked for
  /// equality instead of max_pixels.
  cv::Size expected;
  /// Most pixels accepted when `expected` is empty.
  uint64_t max_pixels = kMaxImagePixels;
};

/// Why an image announcing `width` x `height` must not be allocated under `limits`, e.g.
/// "announced size 60000x60000 is over the limit of 16777216 pixels" or "announced size
/// 320x240 differs from the expected 640x480"; empty when it may. Non-positive sizes are a
/// problem too. `either_orientation`: the decoder may transpose the image (an Exif orientation
/// of 5-8, which OpenCV applies), so height x width may match `expected` too.
std::string imageSizeProblem(int64_t width, int64_t height, const ImageLimits& limits,
                             bool either_orientation = false);

/// What an image header announces.
struct ImageHeader {
  int64_t width = 0;
  int64_t height = 0;
  /// JPEG only: the fewest bits a complete Huffman-coded (baseline, extended or progressive
  /// sequential) file of this frame header holds in its entropy-coded data: one bit per 8x8
  /// block of the component with the fewest blocks (its first scan codes every block's DC
  /// difference, a Huffman code of at least one bit). 0 for arithmetic-coded and lossless files,
  /// which can compress a uniform image to almost nothing, and for PNG.
  uint64_t min_entropy_bits = 0;
};

/// The PNG IHDR (the first chunk, as libpng requires), without checking its CRC; nullopt when
/// the bytes do not start with a PNG signature and an IHDR chunk header.
std::optional<ImageHeader> readPngHeader(const uint8_t* data, size_t size);

/// The first JPEG frame header (SOF0-SOF15 but DHT/JPG/DAC), walking the marker segments after
/// SOI the way libjpeg does (fill bytes skipped, stray bytes between segments skipped);
/// nullopt when the bytes do not start with SOI or no frame header comes before the first scan.
std::optional<ImageHeader> readJpegHeader(const uint8_t* data, size_t size);

}  // namespace pplvo

// JPEG decoding for dataset frames with libjpeg-turbo's TurboJPEG API (jpeg_decode.h).
#include "pplvo/dataset/jpeg_decode.h"


#include <turbojpeg.h>

#include <memory>
#include <optional>
#include <opencv2/imgcodecs.hpp>

#include "pplvo/core/opencv_codecs.h"
#include <string>

namespace pplvo::dataset {
namespace {

struct HandleDeleter {
  void operator()(void* h) const { tjDestroy(h); }
};

/// One decompressor per thread (a handle is not thread-safe; creating one per image costs an
/// allocation of libjpeg's state). After a failed decode the handle is replaced: libjpeg-turbo
/// 2.1 leaves a handle that stopped on an error mid-stream, and the next header read then
/// fails on a valid file ("Bogus DQT index").
std::unique_ptr<void, HandleDeleter>& threadHandleSlot() {
  thread_local std::unique_ptr<void, HandleDeleter> handle;
  return handle;
}
tjhandle threadHandle() {
  auto& handle = threadHandleSlot();
  if (!handle) {
    handle.reset(tjInitDecompress());
    if (!handle) throw std::bad_alloc();
  }
  return handle.get();
}
/// Throws JpegError with `what` and TurboJPEG's reason, dropping the thread's handle.
[[noreturn]] void fail(const char* what, tjhandle h) {
  const std::string reason = tjGetErrorStr2(h);
  threadHandleSlot().reset();
  throw JpegError(std::string(what) + " (" + reason + ")");
}

uint16_t read16(const uint8_t* p, bool big_endian) {
  return big_endian ? uint16_t(p[0] << 8 | p[1]) : uint16_t(p[1] << 8 | p[0]);
}
uint32_t read32(const uint8_t* p, bool big_endian) {
  return big_endian ? uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3]
                    : uint32_t(p[3]) << 24 | uint32_t(p[2]) << 16 | uint32_t(p[1]) << 8 | p[0];
}

/// The orientation tag (0x0112) of IFD0 in an Exif APP1 payload ("Exif\0\0" + TIFF), 1 when
/// absent or unreadable.
int exifOrientation(const uint8_t* p, size_t n) {
  if (n < 6 + 8 || std::string(reinterpret_cast<const char*>(p), 6) != std::string("Exif\0\0", 6))
    return 1;
  const uint8_t* t = p + 6;
  const size_t tn = n - 6;
  bool be;
  if (t[0] == 'M' && t[1] == 'M')
    be = true;
  else if (t[0] == 'I' && t[1] == 'I')
    be = false;
  else
    return 1;
  const uint32_t ifd = read32(t + 4, be);
  if (uint64_t(ifd) + 2 > tn) return 1;
  const uint16_t count = read16(t + ifd, be);
  for (uint32_t i = 0; i < count; ++i) {
    const uint64_t e = uint64_t(ifd) + 2 + 12ull * i;
    if (e + 12 > tn) break;
    if (read16(t + e, be) == 0x0112 && read16(t + e + 2, be) == 3) return read16(t + e + 8, be);
  }
  return 1;
}

/// Walks the marker segments before the first SOS for an Exif orientation. A malformed
/// segment list stops the walk (TurboJPEG then reports the corruption).
int orientationOf(const uint8_t* data, size_t size) {
  size_t pos = 2;
  while (pos + 4 <= size) {
    if (data[pos] != 0xFF) return 1;
    const uint8_t marker = data[pos + 1];
    if (marker == 0xFF) {  // fill byte
      ++pos;
      continue;
    }
    if (marker == 0xDA || marker == 0xD9) return 1;  // start of scan / end of image
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) {  // no length field
      pos += 2;
      continue;
    }
    const size_t len = size_t(data[pos + 2]) << 8 | data[pos + 3];
    if (len < 2 || pos + 2 + len > size) return 1;
    if (marker == 0xE1) {
      const int o = exifOrientation(data + pos + 4, len - 2);
      if (o != 1) return o;
    }
    pos += 2 + len;
  }
  return 1;
}

cv::Mat decodeWithOpenCv(const uint8_t* data, size_t size, int flags) {
  cv::Mat out;
  try {
    out = openCvImdecode(data, size, flags);
  } catch (const cv::Exception& e) {
    throw JpegError(std::string("OpenCV could not decode the JPEG: ") + e.what());
  } catch (const OpenCvCodecsUnavailable& e) {
    throw JpegError(std::string("a JPEG only OpenCV decodes, and ") + e.what());
  }
  if (out.empty()) throw JpegError("OpenCV could not decode the JPEG");
  return out;
}

}  // namespace

bool looksLikeJpeg(const uint8_t* data, size_t size) {
  return size >= 3 && data[0] == 0xFF && data[1] == 0xD8 && data[2] == 0xFF;
}

cv::Mat decodeJpeg(const uint8_t* data, size_t size, int flags, JpegDecodePath* path,
                   const ImageLimits& limits) {
  if (path) *path = JpegDecodePath::kTurbo;
  if (!looksLikeJpeg(data, size)) throw JpegError("bad JPEG signature");
  if (size > 0xFFFFFFFFul) throw JpegError("JPEG larger than 4 GiB");
  tjhandle h = threadHandle();
  int width = 0, height = 0, subsamp = 0, colorspace = 0;
  if (tjDecompressHeader3(h, data, static_cast<unsigned long>(size), &width, &height, &subsamp,
                          &colorspace) != 0) {
    fail("bad JPEG header", h);
  }
  // Before either path allocates the image (TurboJPEG's size is the one both allocate: OpenCV
  // reads the header with the same libjpeg): a Huffman-coded file must be long enough for its
  // frame, and the size must pass the limits.
  const std::optional<ImageHeader> frame = readJpegHeader(data, size);
  if (frame && frame->width == width && frame->height == height &&
      frame->min_entropy_bits > uint64_t(size) * 8) {
    throw JpegError("JPEG of " + std::to_string(size) + " bytes too short for a Huffman-coded " +
                    std::to_string(width) + "x" + std::to_string(height) + " image (at least " +
                    std::to_string((frame->min_entropy_bits + 7) / 8) + " bytes of scan data)");
  }
  // OpenCV applies an Exif orientation unless told not to (IMREAD_UNCHANGED or
  // IMREAD_IGNORE_ORIENTATION): the decoded image may be transposed.
  const bool may_rotate =
      flags != cv::IMREAD_UNCHANGED && (flags & cv::IMREAD_IGNORE_ORIENTATION) == 0;
  const std::string problem = imageSizeProblem(width, height, limits, may_rotate);
  if (!problem.empty()) throw JpegError("JPEG " + problem);
  const bool rotating = flags == cv::IMREAD_COLOR || flags == cv::IMREAD_GRAYSCALE;
  const bool known_flags = rotating || flags == cv::IMREAD_UNCHANGED;
  if (!known_flags || colorspace == TJCS_CMYK || colorspace == TJCS_YCCK ||
      (rotating && orientationOf(data, size) != 1)) {
    if (path) *path = JpegDecodePath::kOpenCv;
    return decodeWithOpenCv(data, size, flags);
  }
  const bool grey =
      flags == cv::IMREAD_GRAYSCALE || (flags == cv::IMREAD_UNCHANGED && colorspace == TJCS_GRAY);
  cv::Mat out(height, width, grey ? CV_8UC1 : CV_8UC3);
  // Every warning (truncated data, corrupt entropy data, ...) stops the decode: an error.
  if (tjDecompress2(h, data, static_cast<unsigned long>(size), out.data, width,
                    static_cast<int>(out.step[0]), height, grey ? TJPF_GRAY : TJPF_BGR,
                    TJFLAG_STOPONWARNING) != 0) {
    fail("corrupt JPEG data", h);
  }
  return out;
}

}  // namespace pplvo::dataset

// Image header sizes and the decoders' size bounds (image_header.h).
#include "pplvo/core/image_header.h"

#include <algorithm>
#include <cstring>

namespace pplvo {
namespace {

uint32_t be16(const uint8_t* p) { return uint32_t(p[0]) << 8 | p[1]; }
uint32_t be32(const uint8_t* p) {
  return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3];
}

std::string sizeText(int64_t width, int64_t height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

uint64_t ceilDiv(uint64_t a, uint64_t b) { return (a + b - 1) / b; }

/// A frame header's size and, for Huffman coding, the fewest entropy-coded bits of a complete
/// file (image_header.h). nullopt when libjpeg would refuse the segment (bad length, component
/// count or sampling factors): it then allocates nothing either.
std::optional<ImageHeader> parseFrameHeader(uint8_t marker, const uint8_t* p, size_t len) {
  if (len < 8) return std::nullopt;
  const size_t components = p[7];
  if (components == 0 || len != 8 + 3 * components) return std::nullopt;
  ImageHeader h;
  h.height = be16(p + 3);
  h.width = be16(p + 5);
  int h_max = 1, v_max = 1;
  for (size_t c = 0; c < components; ++c) {
    const int hs = p[8 + 3 * c + 1] >> 4, vs = p[8 + 3 * c + 1] & 15;
    if (hs < 1 || hs > 4 || vs < 1 || vs > 4) return std::nullopt;
    h_max = std::max(h_max, hs);
    v_max = std::max(v_max, vs);
  }
  // SOF0 baseline, SOF1 extended and SOF2 progressive are Huffman-coded DCT: the first scan
  // of a component codes the DC difference of each of its blocks with a code of >= 1 bit.
  if (marker <= 0xC2) {
    uint64_t fewest = UINT64_MAX;
    for (size_t c = 0; c < components; ++c) {
      const int hs = p[8 + 3 * c + 1] >> 4, vs = p[8 + 3 * c + 1] & 15;
      const uint64_t cols = ceilDiv(ceilDiv(uint64_t(h.width) * hs, h_max), 8);
      const uint64_t rows = ceilDiv(ceilDiv(uint64_t(h.height) * vs, v_max), 8);
      fewest = std::min(fewest, cols * rows);
    }
    h.min_entropy_bits = fewest;
  }
  return h;
}

}  // namespace

std::string imageSizeProblem(int64_t width, int64_t height, const ImageLimits& limits,
                             bool either_orientation) {
  if (width <= 0 || height <= 0) return "announced size " + sizeText(width, height) + " is empty";
  if (!limits.expected.empty()) {
    const int64_t w = limits.expected.width, h = limits.expected.height;
    if ((width != w || height != h) && !(either_orientation && width == h && height == w)) {
      return "announced size " + sizeText(width, height) + " differs from the expected " +
             sizeText(limits.expected.width, limits.expected.height);
    }
    return "";
  }
  if (uint64_t(width) * uint64_t(height) > limits.max_pixels) {
    return "announced size " + sizeText(width, height) + " is over the limit of " +
           std::to_string(limits.max_pixels) + " pixels";
  }
  return "";
}

std::optional<ImageHeader> readPngHeader(const uint8_t* data, size_t size) {
  static const uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (size < 24 || std::memcmp(data, kSignature, 8) != 0 || std::memcmp(data + 12, "IHDR", 4) != 0)
    return std::nullopt;
  ImageHeader h;
  h.width = be32(data + 16);
  h.height = be32(data + 20);
  return h;
}

std::optional<ImageHeader> readJpegHeader(const uint8_t* data, size_t size) {
  if (size < 2 || data[0] != 0xFF || data[1] != 0xD8) return std::nullopt;
  size_t pos = 2;
  for (;;) {
    // libjpeg's next_marker: bytes other than 0xFF before a marker are skipped (with a
    // warning), as are fill bytes 0xFF; FF 00 is no marker.
    while (pos < size && data[pos] != 0xFF) ++pos;
    while (pos < size && data[pos] == 0xFF) ++pos;
    if (pos >= size) return std::nullopt;
    const uint8_t marker = data[pos++];
    if (marker == 0x00) continue;
    if (marker == 0xD8 || marker == 0xD9 || marker == 0xDA) return std::nullopt;  // SOI, EOI, SOS
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) continue;  // no length field
    if (size - pos < 2) return std::nullopt;
    const size_t len = be16(data + pos);
    if (len < 2 || len > size - pos) return std::nullopt;
    const bool frame = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 &&
                       marker != 0xCC;
    if (frame) return parseFrameHeader(marker, data + pos, len);
    pos += len;
  }
}

}  // namespace pplvo

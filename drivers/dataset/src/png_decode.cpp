// PNG decoding for dataset frames: chunk walk with CRC checks, one libdeflate inflate, row
// unfiltering fused with the conversion to OpenCV's layout. See png_decode.h.
#include "pplvo/dataset/png_decode.h"


#include <libdeflate.h>

#include <climits>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <opencv2/imgcodecs.hpp>

#include "pplvo/core/opencv_codecs.h"
#include <string>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace pplvo::dataset {
namespace {

constexpr uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
// Largest image any IHDR may announce, as OpenCV's own limits (1 << 20 pixels a side and
// 1 << 30 pixels): anything bigger is a bad IHDR. The caller's ImageLimits (by default
// pplvo::kMaxImagePixels) are checked after the chunk walk, before anything is allocated.
constexpr uint32_t kMaxSide = 1u << 20;
constexpr uint64_t kMaxPixels = 1ull << 30;
// DEFLATE cannot expand by more than 1032:1 (a 258-byte match in two bits), so an IDAT
// shorter than this bound cannot hold the image: refuse before allocating its buffer.
constexpr uint64_t kMaxDeflateRatio = 1032;
constexpr size_t kPad = 16;  // slack after buffers: SIMD loads read up to 8 bytes per pixel

uint32_t be32(const uint8_t* p) {
  return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | p[3];
}

bool isLetter(uint8_t c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); }

bool validChunkType(const uint8_t* t) {
  return isLetter(t[0]) && isLetter(t[1]) && isLetter(t[2]) && isLetter(t[3]);
}

/// The chunk type for messages; bytes that are not letters as \xNN.
std::string chunkName(const uint8_t* t) {
  std::string s;
  for (int i = 0; i < 4; ++i)
    s += isLetter(t[i]) ? std::string(1, char(t[i])) : cv::format("\\x%02x", t[i]);
  return s;
}

bool isType(const uint8_t* t, const char* name) { return std::memcmp(t, name, 4) == 0; }

/// Samples per pixel of a PNG colour type (validateHeader has checked it).
int channelsOf(int colour_type) {
  switch (colour_type) {
    case 0: return 1;  // grey
    case 2: return 3;  // RGB
    case 3: return 1;  // palette index
    case 4: return 2;  // grey + alpha
    default: return 4;  // 6: RGBA
  }
}

/// An uninitialised byte buffer that only grows (kept per thread: no page faults or zeroing
/// per frame once it has reached the frame size).
class Buffer {
 public:
  uint8_t* get(size_t n) {
    if (n > cap_) {
      data_.reset(new uint8_t[n]);
      cap_ = n;
    }
    return data_.get();
  }

 private:
  std::unique_ptr<uint8_t[]> data_;
  size_t cap_ = 0;
};

struct DecompressorDeleter {
  void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
};

/// Per-thread state: a decompressor (libdeflate's are not thread-safe, and allocating one per
/// image costs more than the small images it would decode) and the scratch buffers.
struct ThreadState {
  std::unique_ptr<libdeflate_decompressor, DecompressorDeleter> inflater;
  Buffer idat;      // IDAT payloads joined, when there is more than one IDAT chunk
  Buffer raw;       // inflated scanlines (filter byte + row bytes each)
  Buffer zero_row;  // the "previous row" of the first row
  std::vector<std::pair<const uint8_t*, size_t>> idat_spans;
};

ThreadState& threadState() {
  thread_local ThreadState state;
  if (!state.inflater) {
    state.inflater.reset(libdeflate_alloc_decompressor());
    if (!state.inflater) throw std::bad_alloc();
  }
  return state;
}

struct Header {
  uint32_t width = 0, height = 0;
  int bit_depth = 0, colour_type = 0, interlace = 0;
};

struct Scan {
  Header ihdr;
  size_t idat_bytes = 0;
  bool has_exif = false;
};

void validateHeader(const uint8_t* p, Header& h) {
  h.width = be32(p);
  h.height = be32(p + 4);
  h.bit_depth = p[8];
  h.colour_type = p[9];
  h.interlace = p[12];
  if (h.width == 0 || h.height == 0 || h.width > 0x7fffffffu || h.height > 0x7fffffffu) {
    throw PngError("bad image size " + std::to_string(h.width) + "x" + std::to_string(h.height) +
                   " in IHDR");
  }
  bool depth_ok = false;
  const int d = h.bit_depth;
  switch (h.colour_type) {
    case 0:
      depth_ok = d == 1 || d == 2 || d == 4 || d == 8 || d == 16;
      break;
    case 3:
      depth_ok = d == 1 || d == 2 || d == 4 || d == 8;
      break;
    case 2:
    case 4:
    case 6:
      depth_ok = d == 8 || d == 16;
      break;
    default:
      throw PngError("bad colour type " + std::to_string(h.colour_type) + " in IHDR");
  }
  if (!depth_ok) {
    throw PngError("bad bit depth " + std::to_string(d) + " for colour type " +
                   std::to_string(h.colour_type) + " in IHDR");
  }
  if (p[10] != 0) throw PngError("unknown compression method " + std::to_string(p[10]));
  if (p[11] != 0) throw PngError("unknown filter method " + std::to_string(p[11]));
  if (h.interlace > 1) throw PngError("unknown interlace method " + std::to_string(h.interlace));
  if (h.width > kMaxSide || h.height > kMaxSide || uint64_t(h.width) * h.height > kMaxPixels) {
    throw PngError("image too large: " + std::to_string(h.width) + "x" + std::to_string(h.height));
  }
}

/// Walks every chunk up to IEND: lengths inside the buffer, CRCs, IHDR first and valid, IDAT
/// chunks consecutive. Collects the IDAT payloads into `spans`.
Scan scanChunks(const uint8_t* data, size_t size,
                std::vector<std::pair<const uint8_t*, size_t>>& spans) {
  if (size < 8 || std::memcmp(data, kSignature, 8) != 0) {
    throw PngError("bad PNG signature");
  }
  Scan scan;
  spans.clear();
  size_t pos = 8;
  bool have_ihdr = false, seen_idat = false, idat_ended = false;
  for (;;) {
    if (pos == size)
      throw PngError("missing IEND chunk (file ends after " + std::to_string(size) + " bytes)");
    if (size - pos < 12) {
      throw PngError("truncated chunk header at offset " + std::to_string(pos) + " (" +
                     std::to_string(size - pos) + " bytes left)");
    }
    const uint8_t* c = data + pos;
    const uint32_t len = be32(c);
    const uint8_t* type = c + 4;
    const std::string name = chunkName(type);
    if (len > 0x7fffffffu) {
      throw PngError("bad length " + std::to_string(len) + " of chunk " + name + " at offset " +
                     std::to_string(pos));
    }
    if (len > size - pos - 12) {
      throw PngError("truncated " + name + " chunk at offset " + std::to_string(pos) + " (length " +
                     std::to_string(len) + ", " + std::to_string(size - pos - 12) + " bytes left)");
    }
    if (!validChunkType(type))
      throw PngError("bad chunk type " + name + " at offset " + std::to_string(pos));
    const uint32_t crc = be32(c + 8 + len);
    if (libdeflate_crc32(0, type, size_t(len) + 4) != crc) {
      throw PngError("CRC error in " + name + " chunk at offset " + std::to_string(pos));
    }
    const uint8_t* payload = c + 8;
    pos += size_t(len) + 12;
    if (!have_ihdr) {
      if (!isType(type, "IHDR")) throw PngError("first chunk is " + name + ", not IHDR");
      if (len != 13) throw PngError("IHDR length " + std::to_string(len) + ", not 13");
      validateHeader(payload, scan.ihdr);
      have_ihdr = true;
      continue;
    }
    if (isType(type, "IDAT")) {
      if (idat_ended) throw PngError("IDAT chunks are not consecutive");
      seen_idat = true;
      if (len > 0) spans.emplace_back(payload, len);
      scan.idat_bytes += len;
      continue;
    }
    if (seen_idat) idat_ended = true;
    if (isType(type, "IEND")) break;
    if (isType(type, "IHDR")) throw PngError("second IHDR chunk");
    if (isType(type, "eXIf")) scan.has_exif = true;
    // An unknown critical chunk (upper-case first letter) may change how the image reads:
    // libpng refuses such files too. Ancillary chunks are skipped, as libpng does by default
    // (the tests check that OpenCV applies none of the standard ones either).
    if (!(type[0] & 0x20) && !isType(type, "PLTE")) {
      throw PngError("unknown critical chunk " + name);
    }
  }
  if (!seen_idat) throw PngError("no IDAT chunk");
  if (scan.idat_bytes == 0) throw PngError("empty image data (IDAT chunks of length 0)");
  return scan;
}

// ---- Row unfiltering ---------------------------------------------------------------------

/// Paeth predictor (PNG spec 9.4), without branches: the compiler turns the selects into
/// conditional moves.
inline uint8_t paeth(int a, int b, int c) {
  const int pa = std::abs(b - c);
  const int pb = std::abs(a - c);
  const int pc = std::abs(a + b - 2 * c);
  const int bc = pb <= pc ? b : c;
  return uint8_t(pa <= pb && pa <= pc ? a : bc);
}

template <int kBpp>
void paethRowScalar(uint8_t* cur, const uint8_t* prev, size_t n) {
  for (size_t i = 0; i < size_t(kBpp); ++i) cur[i] = uint8_t(cur[i] + prev[i]);
  for (size_t i = kBpp; i < n; ++i) {
    cur[i] = uint8_t(cur[i] + paeth(cur[i - kBpp], prev[i], prev[i - kBpp]));
  }
}

#if defined(__SSE2__)
/// Paeth over whole pixels of 3 to 8 bytes: the bytes of one pixel are 16-bit lanes of one
/// register, so the chain from one pixel to the next (its left neighbour) is a handful of
/// vector instructions instead of one scalar chain per byte. Reads up to 8 bytes at the last
/// pixel of `cur` and `prev` (the buffers are padded); writes exactly kBpp bytes per pixel.
template <int kBpp>
void paethRowSse2(uint8_t* cur, const uint8_t* prev, size_t n) {
  static_assert(kBpp >= 3 && kBpp <= 8, "pixel must fit 8 lanes");
  const __m128i zero = _mm_setzero_si128();
  auto load = [&](const uint8_t* p) {
    if constexpr (kBpp <= 4) {
      uint32_t v;
      std::memcpy(&v, p, 4);
      return _mm_unpacklo_epi8(_mm_cvtsi32_si128(int(v)), zero);
    } else {
      return _mm_unpacklo_epi8(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p)), zero);
    }
  };
  auto select = [](__m128i mask, __m128i yes, __m128i no) {
    return _mm_or_si128(_mm_and_si128(mask, yes), _mm_andnot_si128(mask, no));
  };
  // With p = a + b - c: pa = |p - a| = |b - c|, pb = |p - b| = |a - c|,
  // pc = |p - c| = |a + b - 2c|. Only pb and pc depend on a (the previous result), so
  // everything else is computed beside the chain, and each absolute value is the max of two
  // differences formed straight from a: the chain is about eight instructions deep.
  __m128i a = zero, c = zero;  // left and upper-left pixels (zero left of the first pixel)
  for (size_t i = 0; i < n; i += kBpp) {
    const __m128i b = load(prev + i);
    const __m128i x = load(cur + i);
    const __m128i pa = _mm_max_epi16(_mm_sub_epi16(b, c), _mm_sub_epi16(c, b));
    const __m128i b_2c = _mm_sub_epi16(_mm_sub_epi16(b, c), c);  // b - 2c
    const __m128i pb = _mm_max_epi16(_mm_sub_epi16(a, c), _mm_sub_epi16(c, a));
    const __m128i pc =
        _mm_max_epi16(_mm_add_epi16(a, b_2c), _mm_sub_epi16(_mm_sub_epi16(zero, b_2c), a));
    // Not a: pa > pb or pa > pc. Between b and c (ties to b): c when pb > pc.
    const __m128i not_a = _mm_or_si128(_mm_cmpgt_epi16(pa, pb), _mm_cmpgt_epi16(pa, pc));
    const __m128i b_or_c = select(_mm_cmpgt_epi16(pb, pc), c, b);
    const __m128i pred = select(not_a, b_or_c, a);
    // x + pred modulo 256 with byte adds: both have zero high bytes in their 16-bit lanes.
    a = _mm_add_epi8(x, pred);
    c = b;
    const __m128i packed = _mm_packus_epi16(a, a);
    if constexpr (kBpp <= 4) {
      const uint32_t v = uint32_t(_mm_cvtsi128_si32(packed));
      std::memcpy(cur + i, &v, kBpp);
    } else {
      uint64_t v;
      _mm_storel_epi64(reinterpret_cast<__m128i*>(&v), packed);
      std::memcpy(cur + i, &v, kBpp);
    }
  }
}

/// Two consecutive Paeth rows at once, pixels of 3 or 4 bytes: lanes 0-3 hold the upper row at
/// pixel k, lanes 4-7 the lower row at pixel k - 1, whose upper neighbours are the upper row's
/// results of the two previous steps. Both chains advance in the same instructions, so the
/// pair costs little more than one row. `lower` is the row after `upper` (its filter byte
/// between them is read, never written); reads stay within the padded buffers.
template <int kBpp>
void paethTwoRowsSse2(uint8_t* upper, uint8_t* lower, const uint8_t* prev, size_t width) {
  static_assert(kBpp == 3 || kBpp == 4, "two pixels must fit 8 lanes");
  const __m128i zero = _mm_setzero_si128();
  auto load = [&](const uint8_t* p) {
    uint32_t v;
    std::memcpy(&v, p, 4);
    return _mm_unpacklo_epi8(_mm_cvtsi32_si128(int(v)), zero);
  };
  auto select = [](__m128i mask, __m128i yes, __m128i no) {
    return _mm_or_si128(_mm_and_si128(mask, yes), _mm_andnot_si128(mask, no));
  };
  __m128i a = zero;  // [upper k-1 | lower k-2]
  __m128i c = zero;  // [prev k-1 | upper k-2]
  for (size_t k = 0; k <= width; ++k) {
    // b = [prev k | upper k-1]. At k == width the upper lanes compute a pixel that is not
    // stored; at k == 0 the lower lanes see a = b = c = x = 0 and so leave a zero left
    // neighbour for the lower row's first pixel.
    const __m128i b = _mm_unpacklo_epi64(load(prev + k * kBpp), a);
    const __m128i x =
        _mm_unpacklo_epi64(load(upper + k * kBpp), k > 0 ? load(lower + (k - 1) * kBpp) : zero);
    const __m128i b_c = _mm_sub_epi16(b, c);
    const __m128i pa = _mm_max_epi16(b_c, _mm_sub_epi16(zero, b_c));
    const __m128i b_2c = _mm_sub_epi16(b_c, c);
    const __m128i pb = _mm_max_epi16(_mm_sub_epi16(a, c), _mm_sub_epi16(c, a));
    const __m128i pc =
        _mm_max_epi16(_mm_add_epi16(a, b_2c), _mm_sub_epi16(_mm_sub_epi16(zero, b_2c), a));
    const __m128i not_a = _mm_or_si128(_mm_cmpgt_epi16(pa, pb), _mm_cmpgt_epi16(pa, pc));
    const __m128i b_or_c = select(_mm_cmpgt_epi16(pb, pc), c, b);
    a = _mm_add_epi8(x, select(not_a, b_or_c, a));
    c = b;
    const __m128i packed = _mm_packus_epi16(a, a);
    uint64_t both;
    _mm_storel_epi64(reinterpret_cast<__m128i*>(&both), packed);
    if (k < width) {
      const uint32_t u = uint32_t(both);
      std::memcpy(upper + k * kBpp, &u, kBpp);
    }
    if (k > 0) {
      const uint32_t l = uint32_t(both >> 32);
      std::memcpy(lower + (k - 1) * kBpp, &l, kBpp);
    }
  }
}
#endif

template <int kBpp>
void paethRow(uint8_t* cur, const uint8_t* prev, size_t n) {
#if defined(__SSE2__)
  if constexpr (kBpp >= 3) {
    paethRowSse2<kBpp>(cur, prev, n);
    return;
  }
#endif
  paethRowScalar<kBpp>(cur, prev, n);
}

/// Unfilters one row in place; `prev` is the unfiltered previous row (zeros for the first).
/// Returns false on an unknown filter type.
template <int kBpp>
bool unfilterRow(int filter, uint8_t* cur, const uint8_t* prev, size_t n) {
  switch (filter) {
    case 0:
      return true;
    case 1:
      for (size_t i = kBpp; i < n; ++i) cur[i] = uint8_t(cur[i] + cur[i - kBpp]);
      return true;
    case 2:
      for (size_t i = 0; i < n; ++i) cur[i] = uint8_t(cur[i] + prev[i]);
      return true;
    case 3:
      for (size_t i = 0; i < size_t(kBpp); ++i) cur[i] = uint8_t(cur[i] + (prev[i] >> 1));
      for (size_t i = kBpp; i < n; ++i) {
        cur[i] = uint8_t(cur[i] + ((unsigned(cur[i - kBpp]) + prev[i]) >> 1));
      }
      return true;
    case 4:
      paethRow<kBpp>(cur, prev, n);
      return true;
    default:
      return false;
  }
}

// ---- Conversion of unfiltered rows to OpenCV's layout --------------------------------------

/// IMREAD_COLOR: BGR from grey / grey+alpha / RGB / RGBA, 8 or 16 bits (high byte, libpng's
/// strip_16); alpha dropped (strip_alpha), grey replicated (gray_to_rgb).
template <int kChannels, int kBytes>
void toBgr(const uint8_t* s, uint8_t* d, size_t w) {
  constexpr int kStep = kChannels * kBytes;
  for (size_t x = 0; x < w; ++x, s += kStep, d += 3) {
    if constexpr (kChannels >= 3) {
      d[0] = s[2 * kBytes];
      d[1] = s[kBytes];
      d[2] = s[0];
    } else {
      d[0] = d[1] = d[2] = s[0];
    }
  }
}

void grey8(const uint8_t* s, uint8_t* d, size_t w) { std::memcpy(d, s, w); }

/// IMREAD_UNCHANGED 16-bit grey: big-endian samples to native uint16_t.
void grey16(const uint8_t* s, uint8_t* d, size_t w) {
  uint16_t* out = reinterpret_cast<uint16_t*>(d);
  for (size_t x = 0; x < w; ++x) out[x] = uint16_t((unsigned(s[2 * x]) << 8) | s[2 * x + 1]);
}

using ConvertFn = void (*)(const uint8_t*, uint8_t*, size_t);

struct Layout {
  int bpp = 0;  // bytes per pixel in the PNG rows (the filters' left distance)
  int cv_type = -1;
  ConvertFn convert = nullptr;
};

/// The fast path's layout for this header and flags, or cv_type -1 for the OpenCV fallback.
Layout fastLayout(const Header& h, int flags, bool has_exif) {
  Layout l;
  if (h.interlace != 0) return l;
  const int bytes = h.bit_depth / 8;
  if (h.bit_depth != 8 && h.bit_depth != 16) return l;  // 1/2/4-bit grey and palette
  if (flags == cv::IMREAD_COLOR) {
    // IMREAD_COLOR applies an eXIf orientation: leave that to OpenCV.
    if (has_exif) return l;
    l.cv_type = CV_8UC3;
    switch (h.colour_type * 100 + h.bit_depth) {
      case 8:
        l.convert = toBgr<1, 1>;
        break;
      case 16:
        l.convert = toBgr<1, 2>;
        break;
      case 208:
        l.convert = toBgr<3, 1>;
        break;
      case 216:
        l.convert = toBgr<3, 2>;
        break;
      case 408:
        l.convert = toBgr<2, 1>;
        break;
      case 416:
        l.convert = toBgr<2, 2>;
        break;
      case 608:
        l.convert = toBgr<4, 1>;
        break;
      case 616:
        l.convert = toBgr<4, 2>;
        break;
      default:
        return Layout{};  // palette
    }
    const int channels = h.colour_type == 0   ? 1
                         : h.colour_type == 4 ? 2
                         : h.colour_type == 2 ? 3
                                              : 4;
    l.bpp = channels * bytes;
    return l;
  }
  if (flags == cv::IMREAD_UNCHANGED && h.colour_type == 0) {
    l.bpp = bytes;
    l.cv_type = bytes == 1 ? CV_8UC1 : CV_16UC1;
    l.convert = bytes == 1 ? grey8 : grey16;
    return l;
  }
  return l;
}

template <int kBpp>
void unfilterAll(uint8_t* raw, const uint8_t* zero_row, size_t row_bytes, cv::Mat& out,
                 ConvertFn convert) {
  const uint8_t* prev = zero_row;
  for (int y = 0; y < out.rows; ++y) {
    uint8_t* line = raw + size_t(y) * (row_bytes + 1);
    uint8_t* cur = line + 1;
#if defined(__SSE2__)
    if constexpr (kBpp == 3 || kBpp == 4) {
      // Most rows of camera images are Paeth: take them two at a time.
      uint8_t* next = cur + row_bytes;  // the following row's filter byte
      if (line[0] == 4 && y + 1 < out.rows && next[0] == 4) {
        paethTwoRowsSse2<kBpp>(cur, next + 1, prev, size_t(out.cols));
        convert(cur, out.ptr(y), size_t(out.cols));
        convert(next + 1, out.ptr(y + 1), size_t(out.cols));
        prev = next + 1;
        ++y;
        continue;
      }
    }
#endif
    if (!unfilterRow<kBpp>(line[0], cur, prev, row_bytes)) {
      throw PngError("unknown filter type " + std::to_string(line[0]) + " in row " +
                     std::to_string(y));
    }
    convert(cur, out.ptr(y), size_t(out.cols));
    prev = cur;
  }
}

cv::Mat decodeWithOpenCv(const uint8_t* data, size_t size, int flags) {
  if (size > size_t(INT_MAX)) throw PngError("file too large for OpenCV");
  cv::Mat out;
  try {
    out = openCvImdecode(data, size, flags);
  } catch (const cv::Exception& e) {
    throw PngError(std::string("OpenCV: ") + e.what());
  } catch (const OpenCvCodecsUnavailable& e) {
    throw PngError(std::string("a layout only OpenCV decodes, and ") + e.what());
  }
  if (out.empty()) throw PngError("OpenCV could not decode this PNG layout");
  return out;
}

}  // namespace

bool looksLikePng(const uint8_t* data, size_t size) {
  return size >= 4 && std::memcmp(data, kSignature, 4) == 0;
}

cv::Mat decodePng(const uint8_t* data, size_t size, int flags, PngDecodePath* path,
                  const ImageLimits& limits) {
  ThreadState& ts = threadState();
  const Scan scan = scanChunks(data, size, ts.idat_spans);
  const Header& h = scan.ihdr;
  // Before either path allocates the image: the IDAT data must be able to inflate to the
  // image's samples (filter bytes left out, so the bound holds for Adam7 interlacing too), and
  // the size must pass the limits.
  const uint64_t sample_bytes =
      (uint64_t(h.width) * h.height * uint64_t(channelsOf(h.colour_type) * h.bit_depth) + 7) / 8;
  if (sample_bytes > scan.idat_bytes * kMaxDeflateRatio + 1024) {
    throw PngError("IDAT data (" + std::to_string(scan.idat_bytes) + " bytes) too short for a " +
                   std::to_string(h.width) + "x" + std::to_string(h.height) + " image");
  }
  // OpenCV applies an eXIf orientation unless told not to (IMREAD_UNCHANGED or
  // IMREAD_IGNORE_ORIENTATION): the decoded image may be transposed.
  const bool may_rotate = scan.has_exif && flags != cv::IMREAD_UNCHANGED &&
                          (flags & cv::IMREAD_IGNORE_ORIENTATION) == 0;
  const std::string problem = imageSizeProblem(h.width, h.height, limits, may_rotate);
  if (!problem.empty()) throw PngError("PNG " + problem);
  const Layout layout = fastLayout(h, flags, scan.has_exif);
  if (layout.cv_type < 0) {
    if (path) *path = PngDecodePath::kOpenCv;
    return decodeWithOpenCv(data, size, flags);
  }
  if (path) *path = PngDecodePath::kFast;

  const size_t row_bytes = size_t(h.width) * size_t(layout.bpp);
  const size_t expected = (row_bytes + 1) * h.height;
  if (expected > scan.idat_bytes * kMaxDeflateRatio + 1024) {
    throw PngError("IDAT data (" + std::to_string(scan.idat_bytes) + " bytes) too short for a " +
                   std::to_string(h.width) + "x" + std::to_string(h.height) + " image");
  }
  const uint8_t* zdata = ts.idat_spans.front().first;
  if (ts.idat_spans.size() > 1) {
    uint8_t* joined = ts.idat.get(scan.idat_bytes);
    size_t at = 0;
    for (const auto& s : ts.idat_spans) {
      std::memcpy(joined + at, s.first, s.second);
      at += s.second;
    }
    zdata = joined;
  }
  uint8_t* raw = ts.raw.get(expected + kPad);
  const libdeflate_result r =
      libdeflate_zlib_decompress(ts.inflater.get(), zdata, scan.idat_bytes, raw, expected, nullptr);
  switch (r) {
    case LIBDEFLATE_SUCCESS:
      break;
    case LIBDEFLATE_SHORT_OUTPUT:
      throw PngError("image data inflates to fewer than the " + std::to_string(expected) +
                     " bytes of a " + std::to_string(h.width) + "x" + std::to_string(h.height) +
                     " image");
    case LIBDEFLATE_INSUFFICIENT_SPACE:
      throw PngError("image data inflates to more than the " + std::to_string(expected) +
                     " bytes of a " + std::to_string(h.width) + "x" + std::to_string(h.height) +
                     " image");
    default:
      throw PngError("bad zlib stream in IDAT (corrupt compressed data or checksum)");
  }
  uint8_t* zero_row = ts.zero_row.get(row_bytes + kPad);
  std::memset(zero_row, 0, row_bytes + kPad);

  cv::Mat out(int(h.height), int(h.width), layout.cv_type);
  switch (layout.bpp) {
    case 1:
      unfilterAll<1>(raw, zero_row, row_bytes, out, layout.convert);
      break;
    case 2:
      unfilterAll<2>(raw, zero_row, row_bytes, out, layout.convert);
      break;
    case 3:
      unfilterAll<3>(raw, zero_row, row_bytes, out, layout.convert);
      break;
    case 4:
      unfilterAll<4>(raw, zero_row, row_bytes, out, layout.convert);
      break;
    case 6:
      unfilterAll<6>(raw, zero_row, row_bytes, out, layout.convert);
      break;
    case 8:
      unfilterAll<8>(raw, zero_row, row_bytes, out, layout.convert);
      break;
    default:
      throw PngError("internal: unexpected bytes per pixel");
  }
  return out;
}

}  // namespace pplvo::dataset

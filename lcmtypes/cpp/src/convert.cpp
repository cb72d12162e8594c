#include "pplvo/msgs/convert.h"

#include <unistd.h>

#include <cmath>
#include <cstring>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <libdeflate.h>
#include <zlib.h>

#include <memory>
#include <optional>

#include "pplvo/core/image_header.h"
#include "pplvo/core/opencv_codecs.h"

namespace pplvo::msgs {
namespace {
using Img = pplvo_msgs::image_t;

void setData(Img& msg, const uchar* data, size_t n) {
  msg.data.assign(data, data + n);
  msg.size = static_cast<int32_t>(msg.data.size());
}

std::vector<uint8_t> zlibCompress(const cv::Mat& m, int level) {
  // zlib's own deflate: at level 1 on label images (long runs) it takes half the time of
  // libdeflate's level 1 (0.9-1.2 against 1.9-2.0 ms for 640x480 labels, measured).
  const uLong src_len = static_cast<uLong>(m.total() * m.elemSize());
  uLongf dst_len = compressBound(src_len);
  std::vector<uint8_t> out(dst_len);
  if (compress2(out.data(), &dst_len, m.ptr(), src_len, level) != Z_OK) {
    throw MessageError("zlib compression failed");
  }
  out.resize(dst_len);
  return out;
}

// Inflating with libdeflate (the same zlib format): 4-8 times faster than zlib's uncompress on
// label images (0.05-0.12 against 0.26-0.46 ms, 640x480). One decompressor per thread, reused.
struct DecompressorDeleter {
  void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
};

void zlibDecompress(const Img& msg, cv::Mat& out) {
  thread_local std::unique_ptr<libdeflate_decompressor, DecompressorDeleter> d;
  if (!d) {
    d.reset(libdeflate_alloc_decompressor());
    if (!d) throw std::bad_alloc();
  }
  const size_t expected = out.total() * out.elemSize();
  // A zlib stream that fills the image exactly (as zlib's uncompress: bytes after the stream's
  // end are ignored); a short or long stream, bad data or a bad checksum are errors.
  const libdeflate_result rc = libdeflate_zlib_decompress(d.get(), msg.data.data(),
                                                          msg.data.size(), out.ptr(), expected,
                                                          nullptr);
  if (rc != LIBDEFLATE_SUCCESS) {
    throw MessageError("corrupt zlib image payload (" + std::to_string(msg.data.size()) +
                       " bytes, expected " + std::to_string(expected) + " decompressed)");
  }
}

int bytesPerPixel(int8_t encoding) {
  switch (encoding) {
    case Img::ENCODING_RAW_BGR8: return 3;
    case Img::ENCODING_RAW_GRAY8: return 1;
    case Img::ENCODING_RAW_U8: return 1;
    case Img::ENCODING_RAW_U16: return 2;
    case Img::ENCODING_RAW_F32: return 4;
    default: return 0;
  }
}

bool isContinuousCopy(const cv::Mat& m) { return m.isContinuous(); }

}  // namespace

std::string encodingName(int8_t e) {
  switch (e) {
    case Img::ENCODING_NONE: return "none";
    case Img::ENCODING_RAW_BGR8: return "raw_bgr8";
    case Img::ENCODING_RAW_GRAY8: return "raw_gray8";
    case Img::ENCODING_JPEG: return "jpeg";
    case Img::ENCODING_PNG: return "png";
    case Img::ENCODING_RAW_U16: return "raw_u16";
    case Img::ENCODING_ZLIB_U16: return "zlib_u16";
    case Img::ENCODING_PNG_U16: return "png_u16";
    case Img::ENCODING_RAW_F32: return "raw_f32";
    case Img::ENCODING_ZLIB_F32: return "zlib_f32";
    case Img::ENCODING_RAW_U8: return "raw_u8";
    case Img::ENCODING_ZLIB_U8: return "zlib_u8";
    default: return "unknown(" + std::to_string(static_cast<int>(e)) + ")";
  }
}

pplvo_msgs::camera_info_t toMsg(const PinholeCamera& c) {
  pplvo_msgs::camera_info_t m;
  m.width = c.width;
  m.height = c.height;
  m.fx = c.fx;
  m.fy = c.fy;
  m.cx = c.cx;
  m.cy = c.cy;
  for (int i = 0; i < 5; ++i) m.distortion[i] = c.distortion[i];
  m.readout_s = c.readout_s;
  return m;
}

PinholeCamera fromMsg(const pplvo_msgs::camera_info_t& m) {
  PinholeCamera c;
  c.width = m.width;
  c.height = m.height;
  c.fx = m.fx;
  c.fy = m.fy;
  c.cx = m.cx;
  c.cy = m.cy;
  for (int i = 0; i < 5; ++i) {
    if (!std::isfinite(m.distortion[i])) throw MessageError("camera distortion is not finite");
    c.distortion[i] = m.distortion[i];
  }
  c.readout_s = m.readout_s;
  if (!c.valid()) {
    throw MessageError(
        "camera intrinsics are invalid (size, zero or NaN focal, readout outside [0, 1) s)");
  }
  return c;
}

pplvo_msgs::image_t encodeImage(const cv::Mat& image_in, int8_t encoding, int jpeg_quality,
                                int zlib_level) {
  Img msg;
  msg.width = image_in.cols;
  msg.height = image_in.rows;
  msg.encoding = encoding;
  msg.size = 0;
  if (encoding == Img::ENCODING_NONE) {
    msg.width = msg.height = 0;
    return msg;
  }
  const cv::Mat image = isContinuousCopy(image_in) ? image_in : image_in.clone();
  const int type = image.type();
  auto require = [&](bool ok) {
    if (!ok) {
      throw MessageError("cannot encode image of type " + std::to_string(type) + " as " +
                         encodingName(encoding));
    }
  };
  switch (encoding) {
    case Img::ENCODING_RAW_BGR8: require(type == CV_8UC3); break;
    case Img::ENCODING_RAW_GRAY8:
    case Img::ENCODING_RAW_U8:
    case Img::ENCODING_ZLIB_U8: require(type == CV_8UC1); break;
    case Img::ENCODING_RAW_U16:
    case Img::ENCODING_ZLIB_U16:
    case Img::ENCODING_PNG_U16: require(type == CV_16UC1); break;
    case Img::ENCODING_RAW_F32:
    case Img::ENCODING_ZLIB_F32: require(type == CV_32FC1); break;
    case Img::ENCODING_JPEG:
    case Img::ENCODING_PNG: require(type == CV_8UC3 || type == CV_8UC1); break;
    default: throw MessageError("unknown image encoding " + encodingName(encoding));
  }
  if (bytesPerPixel(encoding) > 0) {
    setData(msg, image.ptr(), image.total() * image.elemSize());
  } else if (encoding == Img::ENCODING_ZLIB_U8 || encoding == Img::ENCODING_ZLIB_U16 ||
             encoding == Img::ENCODING_ZLIB_F32) {
    msg.data = zlibCompress(image, zlib_level);
    msg.size = static_cast<int32_t>(msg.data.size());
  } else {
    std::vector<uchar> buf;
    std::vector<int> params;
    const char* ext = ".png";
    if (encoding == Img::ENCODING_JPEG) {
      ext = ".jpg";
      params = {cv::IMWRITE_JPEG_QUALITY, jpeg_quality};
    } else {
      params = {cv::IMWRITE_PNG_COMPRESSION, 1};
    }
    bool encoded = false;
    try {
      encoded = openCvImencode(ext, image, buf, params);
    } catch (const OpenCvCodecsUnavailable& e) {
      throw MessageError(encodingName(encoding) + " encoding needs " + e.what());
    }
    if (!encoded) throw MessageError("image encoding failed");
    msg.data = std::move(buf);
    msg.size = static_cast<int32_t>(msg.data.size());
  }
  return msg;
}

namespace {
cv::Mat decodeImage(const pplvo_msgs::image_t& msg, bool view_raw);
}  // namespace

cv::Mat decodeImage(const pplvo_msgs::image_t& msg) { return decodeImage(msg, false); }
cv::Mat decodeImageView(const pplvo_msgs::image_t& msg) { return decodeImage(msg, true); }

namespace {
cv::Mat decodeImage(const pplvo_msgs::image_t& msg, bool view_raw) {
  if (msg.size != static_cast<int32_t>(msg.data.size())) {
    throw MessageError("image size field " + std::to_string(msg.size) + " disagrees with " +
                       std::to_string(msg.data.size()) + " data bytes");
  }
  if (msg.encoding == Img::ENCODING_NONE) return cv::Mat();
  // Every plane is allocated at the message's size before its payload is decoded: at most the
  // largest frame of a supported sensor (pplvo::kMaxImagePixels, pplvo/core/image_header.h).
  if (msg.width <= 0 || msg.height <= 0 ||
      uint64_t(msg.width) * uint64_t(msg.height) > kMaxImagePixels) {
    throw MessageError("image dimensions " + std::to_string(msg.width) + "x" +
                       std::to_string(msg.height) + " are invalid (at most " +
                       std::to_string(kMaxImagePixels) + " pixels)");
  }
  const int bpp = bytesPerPixel(msg.encoding);
  if (bpp > 0) {
    const size_t expected = static_cast<size_t>(msg.width) * msg.height * bpp;
    if (msg.data.size() != expected) {
      throw MessageError(encodingName(msg.encoding) + " image " + std::to_string(msg.width) + "x" +
                         std::to_string(msg.height) + " needs " + std::to_string(expected) +
                         " bytes, got " + std::to_string(msg.data.size()));
    }
    int type = CV_8UC1;
    if (msg.encoding == Img::ENCODING_RAW_BGR8) type = CV_8UC3;
    if (msg.encoding == Img::ENCODING_RAW_U16) type = CV_16UC1;
    if (msg.encoding == Img::ENCODING_RAW_F32) type = CV_32FC1;
    // A view: const only by convention (cv::Mat has no const element type).
    if (view_raw) return cv::Mat(msg.height, msg.width, type, const_cast<uint8_t*>(msg.data.data()));
    cv::Mat out(msg.height, msg.width, type);
    std::memcpy(out.ptr(), msg.data.data(), expected);
    return out;
  }
  if (msg.encoding == Img::ENCODING_ZLIB_U8 || msg.encoding == Img::ENCODING_ZLIB_U16 ||
      msg.encoding == Img::ENCODING_ZLIB_F32) {
    const int type = msg.encoding == Img::ENCODING_ZLIB_U8    ? CV_8UC1
                     : msg.encoding == Img::ENCODING_ZLIB_U16 ? CV_16UC1
                                                              : CV_32FC1;
    // DEFLATE expands at most 1032:1 (a 258-byte match in two bits): a payload too short for
    // the plane is refused before the plane is allocated.
    const uint64_t plane_bytes =
        uint64_t(msg.width) * uint64_t(msg.height) * uint64_t(CV_ELEM_SIZE(type));
    if (plane_bytes > uint64_t(msg.data.size()) * 1032 + 1024) {
      throw MessageError("corrupt zlib image payload (" + std::to_string(msg.data.size()) +
                         " bytes cannot inflate to the " + std::to_string(plane_bytes) +
                         " bytes of a " + std::to_string(msg.width) + "x" +
                         std::to_string(msg.height) + " " + encodingName(msg.encoding) +
                         " plane)");
    }
    cv::Mat out(msg.height, msg.width, type);
    zlibDecompress(msg, out);
    return out;
  }
  int flags = 0;
  switch (msg.encoding) {
    case Img::ENCODING_JPEG: flags = cv::IMREAD_COLOR; break;
    case Img::ENCODING_PNG: flags = cv::IMREAD_UNCHANGED; break;  // grey stays grey
    case Img::ENCODING_PNG_U16: flags = cv::IMREAD_ANYDEPTH; break;
    default: throw MessageError("unknown image encoding " + encodingName(msg.encoding));
  }
  // cv::imdecode takes any format OpenCV knows (some through temporary files): only the
  // signature the encoding names may reach it.
  static const uint8_t kPng[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  static const uint8_t kJpeg[] = {0xff, 0xd8, 0xff};
  const bool jpeg = msg.encoding == Img::ENCODING_JPEG;
  const uint8_t* signature = jpeg ? kJpeg : kPng;
  const size_t signature_size = jpeg ? sizeof(kJpeg) : sizeof(kPng);
  if (msg.data.size() < signature_size ||
      std::memcmp(msg.data.data(), signature, signature_size) != 0) {
    throw MessageError("corrupt " + encodingName(msg.encoding) + " payload: no " +
                       (jpeg ? "JPEG" : "PNG") + " signature");
  }
  // cv::imdecode allocates the size the payload's header announces before it reads the data:
  // that size must be the message's (or its transpose, when OpenCV applies an Exif
  // orientation: every flag here but IMREAD_UNCHANGED), checked first.
  const std::optional<ImageHeader> header = jpeg
                                                ? readJpegHeader(msg.data.data(), msg.data.size())
                                                : readPngHeader(msg.data.data(), msg.data.size());
  if (!header) {
    throw MessageError("corrupt " + encodingName(msg.encoding) + " payload: no " +
                       (jpeg ? "JPEG frame header" : "PNG IHDR"));
  }
  ImageLimits limits;
  limits.expected = cv::Size(msg.width, msg.height);
  const std::string problem =
      imageSizeProblem(header->width, header->height, limits, flags != cv::IMREAD_UNCHANGED);
  if (!problem.empty()) {
    throw MessageError("corrupt " + encodingName(msg.encoding) + " payload: " + problem);
  }
  cv::Mat out;
  try {
    out = openCvImdecode(msg.data.data(), msg.data.size(), flags);
  } catch (const cv::Exception& e) {
    throw MessageError("corrupt " + encodingName(msg.encoding) + " payload: " + e.what());
  } catch (const OpenCvCodecsUnavailable& e) {
    throw MessageError(encodingName(msg.encoding) + " payload needs " + e.what());
  }
  if (out.empty()) throw MessageError("corrupt " + encodingName(msg.encoding) + " payload");
  if (out.cols != msg.width || out.rows != msg.height) {
    throw MessageError(encodingName(msg.encoding) + " payload is " + std::to_string(out.cols) + "x" +
                       std::to_string(out.rows) + " but the message says " +
                       std::to_string(msg.width) + "x" + std::to_string(msg.height));
  }
  if (msg.encoding == Img::ENCODING_PNG_U16 && out.type() != CV_16UC1) {
    throw MessageError("png_u16 payload is not a 16-bit grey image");
  }
  if (msg.encoding == Img::ENCODING_PNG) {
    if (out.depth() != CV_8U) throw MessageError("png payload is not 8-bit");
    if (out.channels() == 4) cv::cvtColor(out, out, cv::COLOR_BGRA2BGR);
    if (out.channels() == 2) throw MessageError("png payload has an alpha-grey layout");
  }
  return out;
}
}  // namespace

namespace {

/// Size of an image a node does not decode, from its header; empty for ENCODING_NONE. The
/// payload is not read (decodeImage checks it where the image is used).
cv::Size headerSize(const pplvo_msgs::image_t& msg) {
  if (msg.encoding == Img::ENCODING_NONE) return cv::Size();
  if (msg.width <= 0 || msg.height <= 0 || msg.width > 16384 || msg.height > 16384) {
    throw MessageError("image dimensions " + std::to_string(msg.width) + "x" +
                       std::to_string(msg.height) + " are invalid");
  }
  return cv::Size(msg.width, msg.height);
}

bool isDepthEncoding(int8_t encoding) {
  return encoding == Img::ENCODING_RAW_U16 || encoding == Img::ENCODING_ZLIB_U16 ||
         encoding == Img::ENCODING_PNG_U16;
}

}  // namespace

RgbdFrame fromMsg(const pplvo_msgs::rgbd_frame_t& msg, int max_depth_units, FrameImages images) {
  RgbdFrame f;
  f.utime = msg.utime;
  f.depth_utime = msg.depth_utime;
  f.seq = msg.seq;
  f.stamp = msg.stamp;
  f.camera = fromMsg(msg.camera);
  if (!(msg.depth_scale > 0) || !std::isfinite(msg.depth_scale)) {
    throw MessageError("depth_scale must be positive, got " + std::to_string(msg.depth_scale));
  }
  const bool colour = images != FrameImages::kDepth, depth_too = images != FrameImages::kColour;
  cv::Size colour_size;
  if (colour) {
    f.bgr = decodeImage(msg.rgb);
    colour_size = f.bgr.size();
  } else {
    colour_size = headerSize(msg.rgb);
  }
  if (colour_size.empty()) throw MessageError("frame has no colour image");
  cv::Mat depth;
  cv::Size depth_size;
  if (depth_too) {
    depth = decodeImage(msg.depth);
    if (depth.empty()) throw MessageError("frame has no depth image");
    if (depth.type() != CV_16UC1) throw MessageError("depth must be a 16-bit encoding");
    depth_size = depth.size();
  } else {
    depth_size = headerSize(msg.depth);
    if (depth_size.empty()) throw MessageError("frame has no depth image");
    if (!isDepthEncoding(msg.depth.encoding)) {
      throw MessageError("depth must be a 16-bit encoding");
    }
  }
  f.depth_camera = depthCameraFromMsg(msg);
  const cv::Size expected_depth =
      f.depth_camera ? cv::Size(f.depth_camera->camera.width, f.depth_camera->camera.height)
                     : colour_size;
  if (depth_size != expected_depth || colour_size.width != f.camera.width ||
      colour_size.height != f.camera.height) {
    throw MessageError("colour " + std::to_string(colour_size.width) + "x" +
                       std::to_string(colour_size.height) + ", depth " +
                       std::to_string(depth_size.width) + "x" + std::to_string(depth_size.height) +
                       " and camera " + std::to_string(f.camera.width) + "x" +
                       std::to_string(f.camera.height) +
                       (f.depth_camera ? " (depth camera " + std::to_string(expected_depth.width) +
                                             "x" + std::to_string(expected_depth.height) + ")"
                                       : std::string()) +
                       " sizes disagree");
  }
  if (depth_too) f.depth_m = depthUnitsToMetres(depth, msg.depth_scale, max_depth_units);
  return f;
}

pplvo_msgs::rgbd_frame_t toMsg(const RgbdFrame& f, double depth_scale, int8_t rgb_encoding,
                               int8_t depth_encoding, const std::string& source) {
  pplvo_msgs::rgbd_frame_t m;
  m.utime = f.utime;
  m.depth_utime = f.depth_utime;
  m.seq = f.seq;
  m.stamp = f.stamp;
  m.source = source;
  m.camera = toMsg(f.camera);
  m.depth_scale = depth_scale;
  m.rgb = encodeImage(f.bgr, rgb_encoding);
  m.depth = encodeImage(depthMetresToUnits(f.depth_m, depth_scale), depth_encoding);
  setDepthCamera(f.depth_camera, &m);
  return m;
}

void setDepthCamera(const std::optional<DepthCamera>& depth, pplvo_msgs::rgbd_frame_t* m) {
  m->depth_frame = depth ? pplvo_msgs::rgbd_frame_t::DEPTH_OWN_CAMERA
                         : pplvo_msgs::rgbd_frame_t::DEPTH_REGISTERED;
  const DepthCamera d = depth.value_or(DepthCamera{});
  m->depth_camera = toMsg(d.camera);
  const Eigen::Matrix3d R = d.T_c_d.linear();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m->R_c_d[3 * r + c] = R(r, c);
    m->t_c_d_m[r] = d.T_c_d.translation()[r];
  }
}

std::optional<DepthCamera> depthCameraFromMsg(const pplvo_msgs::rgbd_frame_t& m) {
  if (m.depth_frame == pplvo_msgs::rgbd_frame_t::DEPTH_REGISTERED) return std::nullopt;
  if (m.depth_frame != pplvo_msgs::rgbd_frame_t::DEPTH_OWN_CAMERA) {
    throw MessageError("unknown depth_frame " + std::to_string(m.depth_frame));
  }
  DepthCamera d;
  d.camera = fromMsg(m.depth_camera);  // MessageError on invalid intrinsics
  Eigen::Matrix3d R;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) R(r, c) = m.R_c_d[3 * r + c];
    d.T_c_d.translation()[r] = m.t_c_d_m[r];
  }
  d.T_c_d.linear() = R;
  if (!isValidPose(d.T_c_d)) {
    throw MessageError("depth camera extrinsics R_c_d / t_c_d_m are not a rigid transform");
  }
  return d;
}

namespace {
/// The fields of a depth map message other than its two images and reference.
pplvo_msgs::depth_map_t depthMapFields(const DepthWithVariance& d, const PinholeCamera& camera,
                                       int64_t utime, int64_t seq, const std::string& stamp,
                                       int8_t stage) {
  pplvo_msgs::depth_map_t m;
  m.utime = utime;
  m.seq = seq;
  m.stamp = stamp;
  m.stage = stage;
  m.camera = toMsg(camera);
  m.window_length = d.window_length;
  m.time_alignment_scale = d.time_alignment.scale;
  m.time_alignment_motion_seq = d.time_alignment.motion_seq;
  return m;
}
}  // namespace

pplvo_msgs::depth_map_t toMsg(const DepthWithVariance& d, const PinholeCamera& camera,
                              int64_t utime, int64_t seq, const std::string& stamp, int8_t stage,
                              bool compress) {
  pplvo_msgs::depth_map_t m = depthMapFields(d, camera, utime, seq, stamp, stage);
  m.reference = 0;  // the depth filter passes the pose's on (pose_t.reference)
  const int8_t enc = compress ? Img::ENCODING_ZLIB_F32 : Img::ENCODING_RAW_F32;
  m.depth = encodeImage(d.depth_m, enc);
  m.variance = encodeImage(d.var_m2, enc);
  return m;
}

namespace {

/// Appends a big-endian int32, as LCM encodes one.
uint8_t* putInt32(uint8_t* out, int32_t value) {
  const auto v = static_cast<uint32_t>(value);
  for (int i = 0; i < 4; ++i) out[i] = static_cast<uint8_t>(v >> (24 - 8 * i));
  return out + 4;
}

/// Appends the rows of a CV_32FC1 plane as ENCODING_RAW_F32 data (host byte order: little-endian
/// on every platform pplvo builds for, as encodeImage()).
uint8_t* putPlane(uint8_t* out, const cv::Mat& plane) {
  const size_t row_bytes = static_cast<size_t>(plane.cols) * sizeof(float);
  for (int v = 0; v < plane.rows; ++v) {
    std::memcpy(out, plane.ptr(v), row_bytes);
    out += row_bytes;
  }
  return out;
}

}  // namespace

void encodeRawDepthMap(const DepthWithVariance& d, const PinholeCamera& camera, int64_t utime,
                       int64_t seq, const std::string& stamp, int8_t stage, int8_t reference,
                       std::vector<uint8_t>* wire) {
  if (d.depth_m.type() != CV_32FC1 || d.var_m2.type() != CV_32FC1) {
    throw MessageError("cannot encode depth map planes of types " +
                       std::to_string(d.depth_m.type()) + " and " +
                       std::to_string(d.var_m2.type()) + " as raw_f32");
  }
  if (d.depth_m.size() != d.var_m2.size()) {
    throw MessageError("depth and variance planes of different sizes");
  }
  const int64_t plane_bytes = static_cast<int64_t>(d.depth_m.total()) * 4;
  if (plane_bytes > (int64_t{1} << 30)) throw MessageError("depth map too large for a message");
  // The message without its two payloads, encoded by lcm-gen: everything but the data bytes.
  // Its tail is depth.size, variance {width, height, encoding, size}, reference and the time
  // alignment (a double and an int64): the payloads go after the first and second size fields
  // (image_t: width, height, encoding, size, data[size]; the test compares the result with
  // lcm-gen's encoding byte for byte).
  pplvo_msgs::depth_map_t shell = depthMapFields(d, camera, utime, seq, stamp, stage);
  shell.reference = reference;
  for (Img* img : {&shell.depth, &shell.variance}) {
    img->width = d.depth_m.cols;
    img->height = d.depth_m.rows;
    img->encoding = Img::ENCODING_RAW_F32;
    img->size = 0;
  }
  // Encoded at the start of the packet; its tail is kept aside and written after the planes.
  const int shell_size = shell.getEncodedSize();
  wire->resize(static_cast<size_t>(shell_size + 2 * plane_bytes));
  if (shell.encode(wire->data(), 0, shell_size) != shell_size) {
    throw MessageError("depth_map_t encoding failed");
  }
  constexpr int kAfterPlanes = 1 + 8 + 8;       // reference, time_alignment_scale, _motion_seq
  constexpr int kTail = 4 + 13 + kAfterPlanes;  // depth.size, variance header, the rest
  uint8_t tail[kTail];
  std::memcpy(tail, wire->data() + shell_size - kTail, kTail);
  uint8_t* out = wire->data() + shell_size - kTail;
  out = putInt32(out, static_cast<int32_t>(plane_bytes));
  out = putPlane(out, d.depth_m);
  std::memcpy(out, tail + 4, 9);  // variance width, height, encoding
  out = putInt32(out + 9, static_cast<int32_t>(plane_bytes));
  out = putPlane(out, d.var_m2);
  std::memcpy(out, tail + kTail - kAfterPlanes, kAfterPlanes);
}

DepthTimeAlignment depthTimeAlignmentFromMsg(double scale, int64_t motion_seq, int64_t seq) {
  if (motion_seq < 0 || scale == 0.0) return DepthTimeAlignment{};  // a zeroed message too
  if (!std::isfinite(scale)) throw MessageError("time alignment scale is not finite");
  if (motion_seq >= seq) {
    throw MessageError("time alignment motion " + std::to_string(motion_seq) +
                       " is not earlier than frame " + std::to_string(seq));
  }
  return DepthTimeAlignment{scale, motion_seq};
}

namespace {
DepthWithVariance decodeDepthMap(const pplvo_msgs::depth_map_t& m, bool view_raw) {
  DepthWithVariance d;
  d.window_length = m.window_length;
  d.time_alignment =
      depthTimeAlignmentFromMsg(m.time_alignment_scale, m.time_alignment_motion_seq, m.seq);
  d.depth_m = decodeImage(m.depth, view_raw);
  d.var_m2 = decodeImage(m.variance, view_raw);
  if (d.depth_m.type() != CV_32FC1 || d.var_m2.type() != CV_32FC1) {
    throw MessageError("depth map planes must be float32");
  }
  if (d.depth_m.size() != d.var_m2.size() || d.depth_m.cols != m.camera.width ||
      d.depth_m.rows != m.camera.height) {
    throw MessageError("depth, variance and camera sizes disagree");
  }
  return d;
}
}  // namespace

DepthWithVariance fromMsg(const pplvo_msgs::depth_map_t& m) { return decodeDepthMap(m, false); }

DepthWithVariance viewOfMsg(const pplvo_msgs::depth_map_t& m) { return decodeDepthMap(m, true); }

pplvo_msgs::node_status_t toStatusMsg(const std::string& node, const NodeCounters& c,
                                      const StageTimings& timings, int64_t utime, bool final) {
  pplvo_msgs::node_status_t m;
  m.pid = static_cast<int32_t>(::getpid());
  m.at_exit = final;
  m.utime = utime;
  m.node = node;
  m.last_seq = c.last_seq;
  m.frames_in = c.frames_in;
  m.frames_out = c.frames_out;
  m.frames_dropped = c.frames_dropped;
  m.frames_skipped = c.frames_skipped;
  m.frames_pending = c.frames_pending;
  m.frames_lost = c.frames_lost;
  m.messages_skipped = c.messages_skipped;
  m.errors = c.errors;
  for (const auto& s : timings.stages()) {
    pplvo_msgs::stage_timing_t t;
    t.name = s.name;
    t.count = s.count;
    t.last_ms = s.last_ms;
    t.mean_ms = s.meanMs();
    t.max_ms = s.max_ms;
    m.stages.push_back(t);
  }
  m.n_stages = static_cast<int32_t>(m.stages.size());
  m.last_warning = c.last_warning;
  return m;
}

}  // namespace pplvo::msgs

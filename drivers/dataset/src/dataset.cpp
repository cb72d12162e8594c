// Frame loading and sequential reading.
#include "pplvo/dataset/dataset.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <optional>

#include "pplvo/core/image_header.h"
#include "pplvo/core/opencv_codecs.h"
#include "pplvo/dataset/jpeg_decode.h"
#include "pplvo/dataset/png_decode.h"

namespace fs = std::filesystem;

namespace pplvo::dataset {
namespace {

/// The most bytes an encoded image of `width` x `height` can take: twice its largest raw size
/// (16-bit RGBA, which a PNG may store uncompressed) plus room for metadata chunks. A JPEG of
/// any quality stays well under it.
uint64_t maxEncodedBytes(int64_t width, int64_t height) {
  constexpr uint64_t kLargestPixelBytes = 8, kMetadataBytes = 16ull << 20;
  return 2 * static_cast<uint64_t>(width) * static_cast<uint64_t>(height) * kLargestPixelBytes +
         kMetadataBytes;
}

/// An image of neither PNG nor JPEG format (left to OpenCV) whose size no camera gives.
constexpr uint64_t kMaxUnknownImageBytes = 64ull << 20;

/// The whole file, read once, after its size was checked against the image it can hold: the
/// size `limits` expects (the camera's), else the one its PNG or JPEG header announces (itself
/// checked against `limits`). A huge file is refused before anything is read or allocated.
std::vector<uchar> readBytes(const std::string& path, const ImageLimits& limits) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw FrameLoadError(path, "missing image file");
  const uintmax_t file_size = fs::file_size(path, ec);
  if (ec) throw FrameLoadError(path, "cannot read the size of the image file");
  if (file_size == 0) throw FrameLoadError(path, "empty image file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FrameLoadError(path, "cannot open image file");
  // The header first: enough for PNG's IHDR and a JPEG's frame header behind its metadata.
  std::vector<uchar> bytes(static_cast<size_t>(std::min<uintmax_t>(file_size, 64 * 1024)));
  if (!in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size())))
    throw FrameLoadError(path, "read error on image file");
  uint64_t bound = kMaxUnknownImageBytes;
  std::string holds = "an image of unknown format";
  std::optional<ImageHeader> header = readPngHeader(bytes.data(), bytes.size());
  if (!header) header = readJpegHeader(bytes.data(), bytes.size());
  if (header) {
    const std::string problem = imageSizeProblem(header->width, header->height, limits, true);
    if (!problem.empty()) throw FrameLoadError(path, problem);
  }
  if (!limits.expected.empty()) {
    bound = maxEncodedBytes(limits.expected.width, limits.expected.height);
    holds = "a " + std::to_string(limits.expected.width) + "x" +
            std::to_string(limits.expected.height) + " image";
  } else if (header) {
    bound = maxEncodedBytes(header->width, header->height);
    holds = "the " + std::to_string(header->width) + "x" + std::to_string(header->height) +
            " image its header announces";
  }
  if (file_size > bound) {
    throw FrameLoadError(path, "file of " + std::to_string(file_size) + " bytes is larger than " +
                                   holds + " can be (at most " + std::to_string(bound) + " bytes)");
  }
  // One read of the rest (copying through a stream iterator cost ~1 ms per frame).
  const size_t head = bytes.size();
  bytes.resize(static_cast<size_t>(file_size));
  if (file_size > head && !in.read(reinterpret_cast<char*>(bytes.data() + head),
                                   static_cast<std::streamsize>(file_size - head))) {
    throw FrameLoadError(path, "read error on image file");
  }
  return bytes;
}

cv::Mat decode(const std::vector<uchar>& bytes, int flags, const std::string& path,
               const ImageLimits& limits) {
  // PNG (the datasets' format) and JPEG (colour, as 7-Scenes): the fast decoders, which leave
  // unusual layouts to OpenCV and refuse corrupt files themselves. Anything else goes to OpenCV.
  if (looksLikePng(bytes.data(), bytes.size())) {
    try {
      return decodePng(bytes.data(), bytes.size(), flags, nullptr, limits);
    } catch (const PngError& e) {
      throw FrameLoadError(path, std::string("corrupt image file (") + e.what() + ")");
    }
  }
  if (looksLikeJpeg(bytes.data(), bytes.size())) {
    try {
      return decodeJpeg(bytes.data(), bytes.size(), flags, nullptr, limits);
    } catch (const JpegError& e) {
      throw FrameLoadError(path, std::string("corrupt image file (") + e.what() + ")");
    }
  }
  cv::Mat m;
  try {
    m = openCvImdecode(bytes.data(), bytes.size(), flags);
  } catch (const cv::Exception& e) {
    throw FrameLoadError(path, std::string("corrupt image file (") + e.what() + ")");
  } catch (const OpenCvCodecsUnavailable& e) {
    throw FrameLoadError(path, std::string("neither PNG nor JPEG, and ") + e.what());
  }
  if (m.empty()) throw FrameLoadError(path, "corrupt or unsupported image file");
  return m;
}

}  // namespace

RawFrame loadRawFrame(const DatasetEntry& entry, double depth_scale,
                      const FrameLoadOptions& options) {
  RawFrame f;
  f.bgr = decode(readBytes(entry.rgb_path, options.image_limits), cv::IMREAD_COLOR, entry.rgb_path,
                 options.image_limits);
  if (f.bgr.type() != CV_8UC3) throw FrameLoadError(entry.rgb_path, "colour image is not 8-bit");
  ImageLimits depth_limits;
  depth_limits.expected = options.depth_size.empty() ? f.bgr.size() : options.depth_size;
  f.depth_units = decode(readBytes(entry.depth_path, depth_limits), cv::IMREAD_UNCHANGED,
                         entry.depth_path, depth_limits);
  if (f.depth_units.type() != CV_16UC1) {
    throw FrameLoadError(entry.depth_path, "depth image is not a 16-bit single-channel PNG");
  }
  if (f.depth_units.size() != depth_limits.expected) {
    throw FrameLoadError(entry.depth_path,
                         "depth size " + std::to_string(f.depth_units.cols) + "x" +
                             std::to_string(f.depth_units.rows) + " differs from " +
                             (options.depth_size.empty() ? "colour" : "the depth camera's") +
                             " size " + std::to_string(depth_limits.expected.width) + "x" +
                             std::to_string(depth_limits.expected.height));
  }
  // 65535 is the usual invalid marker; a configured max range removes far depth too.
  double max_units = 65534.0;
  if (options.max_depth_m > 0)
    max_units = std::min(max_units, std::floor(options.max_depth_m * depth_scale));
  if (max_units < 65535.0) f.depth_units.setTo(0, f.depth_units > max_units);
  return f;
}

Dataset Dataset::open(const std::string& dir, const DatasetOptions& options) {
  Dataset d;
  d.dir_ = dir;
  d.index_ = buildIndex(dir, options);  // throws on a missing folder or index
  if (!options.camera_file.empty()) {
    const std::string ext = fs::path(options.camera_file).extension().string();
    d.camera_ = (ext == ".xml") ? loadCalibParamsXml(options.camera_file)
                                : loadCameraYaml(options.camera_file);
  } else {
    const std::string xml = (fs::path(dir) / "calib_params.xml").string();
    std::error_code ec;
    if (!fs::is_regular_file(xml, ec)) {
      throw DatasetError("no camera calibration: " + xml +
                         " does not exist; give a YAML camera file (--camera)");
    }
    d.camera_ = loadCalibParamsXml(xml);
  }
  if (d.index_.entries.empty()) {
    throw DatasetError("dataset " + dir + " has no frames: " + d.index_.summary.text());
  }
  // Image size from the first frame that loads.
  std::string first_error;
  FrameLoadOptions first;
  if (d.camera_.camera.width > 0 && d.camera_.camera.height > 0) {
    // A camera file that names its size bounds every file before it is read.
    first.image_limits.expected = cv::Size(d.camera_.camera.width, d.camera_.camera.height);
  }
  if (d.camera_.depth_camera && d.camera_.depth_camera->camera.width > 0) {
    first.depth_size =
        cv::Size(d.camera_.depth_camera->camera.width, d.camera_.depth_camera->camera.height);
  }
  for (const auto& e : d.index_.entries) {
    try {
      const RawFrame f = loadRawFrame(e, d.camera_.depth_scale, first);
      auto& cam = d.camera_.camera;
      if ((cam.width > 0 && cam.width != f.bgr.cols) ||
          (cam.height > 0 && cam.height != f.bgr.rows)) {
        throw DatasetError("camera file " + d.camera_.source + " says " +
                           std::to_string(cam.width) + "x" + std::to_string(cam.height) + " but " +
                           e.rgb_path + " is " + std::to_string(f.bgr.cols) + "x" +
                           std::to_string(f.bgr.rows));
      }
      cam.width = f.bgr.cols;
      cam.height = f.bgr.rows;
      if (d.camera_.depth_camera && d.camera_.depth_camera->camera.width == 0) {
        d.camera_.depth_camera->camera.width = f.depth_units.cols;  // the colour's size
        d.camera_.depth_camera->camera.height = f.depth_units.rows;
      }
      return d;
    } catch (const FrameLoadError& err) {
      if (first_error.empty()) first_error = err.what();
    }
  }
  throw DatasetError("no frame of " + dir + " could be loaded (first error: " + first_error + ")");
}

RawFrame Dataset::loadRaw(size_t i, const FrameLoadOptions& options) const {
  const DatasetEntry& e = entry(i);
  FrameLoadOptions bounded = options;
  if (bounded.image_limits.expected.empty())
    bounded.image_limits.expected = cv::Size(camera_.camera.width, camera_.camera.height);
  if (camera_.depth_camera) {
    bounded.depth_size =
        cv::Size(camera_.depth_camera->camera.width, camera_.depth_camera->camera.height);
  }
  RawFrame f = loadRawFrame(e, camera_.depth_scale, bounded);
  if (f.bgr.cols != camera_.camera.width || f.bgr.rows != camera_.camera.height) {
    throw FrameLoadError(
        e.rgb_path, "image size " + std::to_string(f.bgr.cols) + "x" + std::to_string(f.bgr.rows) +
                        " differs from " + std::to_string(camera_.camera.width) + "x" +
                        std::to_string(camera_.camera.height) + " of the first frame");
  }
  return f;
}

RgbdFrame Dataset::loadFrame(size_t i, const FrameLoadOptions& options) const {
  RawFrame raw = loadRaw(i, options);
  const DatasetEntry& e = entry(i);
  RgbdFrame f;
  f.utime = e.utime;
  f.depth_utime = e.depth_utime;
  f.seq = static_cast<int64_t>(i);
  f.stamp = e.stamp_text;
  f.camera = camera_.camera;
  f.bgr = std::move(raw.bgr);
  f.depth_m = depthUnitsToMetres(raw.depth_units, camera_.depth_scale);
  f.depth_camera = camera_.depth_camera;
  return f;
}

DatasetReader::DatasetReader(const Dataset& dataset, bool skip_bad, const FrameLoadOptions& options,
                             size_t start)
    : dataset_(dataset), skip_bad_(skip_bad), options_(options), pos_(start) {}

std::optional<DatasetReader::Item> DatasetReader::next() {
  while (pos_ < dataset_.size()) {
    const size_t i = pos_++;
    try {
      Item item;
      item.index = i;
      item.frame = dataset_.loadRaw(i, options_);
      ++stats_.frames_read;
      return item;
    } catch (const FrameLoadError& e) {
      if (!skip_bad_) throw;
      ++stats_.frames_skipped;
      stats_.last_error = e.what();
    }
  }
  return std::nullopt;
}

}  // namespace pplvo::dataset

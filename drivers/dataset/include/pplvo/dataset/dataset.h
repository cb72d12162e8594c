#pragma once
/// Reading RGB-D sequences stored in the TUM RGB-D layout (also used by ICL-NUIM excerpts):
/// `rgb/`, `depth/` (16-bit PNG), `rgb.txt`, `depth.txt`, optional `associations.txt` and
/// `calib_params.xml`. No LCM here: the player node (drivers/player) wraps this library.
/// See docs/player.md for the association rules and the camera file formats.
#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "pplvo/core/camera.h"
#include "pplvo/core/image_header.h"
#include "pplvo/core/rgbd_frame.h"

namespace pplvo::dataset {

/// A fatal problem with a dataset folder or camera file (missing folder, no index file,
/// unreadable calibration). The message names the offending path.
class DatasetError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A frame whose image file is missing, unreadable, corrupt or inconsistent. The message names
/// the file.
class FrameLoadError : public std::runtime_error {
 public:
  FrameLoadError(const std::string& path, const std::string& what)
      : std::runtime_error(what + ": " + path), path_(path) {}
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

/// One line of an index file (`rgb.txt`, `depth.txt`): stamp text and path relative to the
/// dataset folder.
struct IndexEntry {
  std::string stamp_text;  ///< verbatim
  double stamp = 0.0;      ///< seconds (or frame index)
  std::string path;        ///< as written in the file (relative to the dataset folder)
};

/// Parses `stamp path` lines; '#' comments and blank lines are skipped. Lines that do not have
/// two fields or whose stamp is not a number are counted in `malformed_lines`.
struct IndexFile {
  std::vector<IndexEntry> entries;
  int malformed_lines = 0;
};
IndexFile parseIndexFile(std::istream& in);

/// TUM's associate.py rule: every pair with |t_a - t_b| < max_difference_s is a candidate;
/// candidates are sorted by difference (ties by t_a, then t_b) and taken greedily one-to-one;
/// the result is sorted by t_a. Returns (index into a, index into b) pairs.
std::vector<std::pair<size_t, size_t>> associateStamps(const std::vector<double>& a,
                                                       const std::vector<double>& b,
                                                       double max_difference_s = 0.02);

/// Parses a stamp text into microseconds exactly (decimal digits, no floating point rounding):
/// "1341845688.561749" -> 1341845688561749. Digits beyond microseconds are rounded half up.
/// Returns nullopt if the text is not a non-negative decimal number.
std::optional<int64_t> stampTextToUtime(const std::string& stamp_text);

/// Options for opening a dataset. Defaults follow TUM's tools.
struct DatasetOptions {
  /// YAML camera file; empty: `calib_params.xml` in the dataset folder.
  std::string camera_file;
  /// Association window of rgb.txt/depth.txt, seconds (TUM associate.py: 0.02).
  double max_association_dt_s = 0.02;
  /// Frame rate for datasets whose stamps are integer frame indices (ICL-NUIM);
  /// 0 = 30 Hz (ICL-NUIM's rate). Ignored when stamps are times.
  double index_frame_rate_hz = 0.0;
};

/// One associated RGB-D frame of the sequence.
struct DatasetEntry {
  std::string stamp_text;        ///< colour stamp, verbatim (used in trajectory files)
  double stamp = 0.0;            ///< colour stamp as a number
  int64_t utime = 0;             ///< microseconds: stamp * 1e6, or index / rate for ICL-NUIM
  std::string depth_stamp_text;  ///< depth stamp, verbatim
  int64_t depth_utime = 0;       ///< depth stamp in microseconds, same clock as `utime`
  std::string rgb_path;          ///< absolute (dataset folder joined with the index path)
  std::string depth_path;
};

/// How the index was built, for the start-up summary.
struct IndexSummary {
  std::string source;        ///< "associations.txt" or "rgb.txt+depth.txt"
  std::string column_order;  ///< "rgb-first", "depth-first", "rgb-first (assumed)", mixed
  int listed = 0;            ///< associations lines, or rgb.txt entries
  int listed_depth = 0;      ///< depth.txt entries (0 with associations.txt)
  int malformed_lines = 0;
  int missing_rgb_files = 0;       ///< listed colour images that do not exist (dropped)
  int missing_depth_files = 0;     ///< listed depth images that do not exist (dropped)
  int unassociated_rgb = 0;        ///< existing colour images with no depth within the window
  int unlisted_rgb_files = 0;      ///< files in rgb/ that no index line mentions (not played)
  /// Index lines listed after a line with a later colour stamp: the frames are played sorted
  /// by stamp, not in file order.
  int out_of_order = 0;
  /// Frames whose colour stamp an earlier-listed frame already has (dropped: one pose per
  /// stamp in the trajectory); `first_duplicate` is the first such stamp.
  int duplicate_stamps = 0;
  std::string first_duplicate;
  bool index_stamps = false;       ///< stamps are integer frame indices (ICL-NUIM)
  double index_frame_rate_hz = 0;  ///< rate used to turn indices into time
  std::string first_missing;       ///< first missing file, for the message
  /// One paragraph for the log, e.g. "rgb.txt+depth.txt: 149 colour, 686 depth entries ...".
  std::string text() const;
};

/// The associated frames of a folder and how they were found.
struct DatasetIndex {
  std::vector<DatasetEntry> entries;
  IndexSummary summary;
};

/// Builds the frame index of a folder: `associations.txt` if present (either column order,
/// detected from which path is under depth/), else rgb.txt + depth.txt associated by
/// associateStamps(). Entries whose files do not exist are dropped and counted. The frames are
/// sorted by colour stamp; of frames with the same stamp only the first listed is kept (both
/// counted in the summary).
/// Throws DatasetError when the folder or both index sources are missing.
DatasetIndex buildIndex(const std::string& dir, const DatasetOptions& options = {});

/// Colour camera, depth scale and, for unregistered depth, the depth camera.
struct DatasetCamera {
  PinholeCamera camera;         ///< width/height 0 until known (set from the first frame)
  double depth_scale = 5000.0;  ///< depth units per metre (TUM/ICL PNG: 5000)
  std::string source;           ///< file it was read from
  /// Unset (the default, every shared dataset): depth images are registered to the colour
  /// camera. Set only when the calibration says `depth_registered` 0 / false: depth images are
  /// in this depth camera (its width/height 0 until known: the colour image's size).
  std::optional<DepthCamera> depth_camera;
};

/// Reads an OpenCV FileStorage calibration (`RGB_intrinsic_params` 3x3,
/// `RGB_distortion_coefficients` 1x5 or 5x1, optional `depth_scale`, optional `width`/`height`).
/// Depth is registered to colour unless `depth_registered` is 0: then `IR_intrinsic_params`,
/// `Rotation` (3x3) and `Translation` (3x1, metres; p_rgb = Rotation p_ir + Translation) are
/// required and `IR_distortion_coefficients`, `IR_width`, `IR_height` optional (docs/player.md).
/// The IR_* / Rotation / Translation entries are ignored without `depth_registered: 0` (the
/// shared datasets carry them, with registered depth).
/// Throws DatasetError naming the file when it cannot be read or lacks the intrinsics.
DatasetCamera loadCalibParamsXml(const std::string& path);

/// The same from the file's text (`source` names it in errors and DatasetCamera::source).
DatasetCamera parseCalibParams(const std::string& text, const std::string& source);

/// Reads a YAML camera file with keys `width height fx fy cx cy distortion [k1 k2 p1 p2 k3]
/// depth_scale depth_registered depth_camera`. fx fy cx cy are required; width/height default to
/// 0 (taken from the first frame); distortion defaults to zeros; depth_scale to 5000;
/// depth_registered to true. With `depth_registered: false` the map `depth_camera` (width,
/// height, fx, fy, cx, cy, distortion as above; R_c_d: 9 numbers row-major; t_c_d_m: 3, with
/// p_colour = R_c_d p_depth + t_c_d_m) is required, and refused otherwise. Unknown keys are
/// errors. All problems are reported together in one DatasetError.
DatasetCamera loadCameraYaml(const std::string& path);

/// The same from the file's text (`source` names it in errors and DatasetCamera::source).
DatasetCamera parseCameraYaml(const std::string& text, const std::string& source);

/// Options for decoding one frame.
struct FrameLoadOptions {
  /// Depth beyond this range counts as missing (0 = only the 65535 invalid marker), metres.
  double max_depth_m = 0.0;
  /// Size bounds checked on each image's header before it is decoded (docs/fuzzing.md): a
  /// colour image must have image_limits.expected when given (Dataset::loadRaw sets the
  /// camera's size when it is empty), else at most image_limits.max_pixels; the depth image
  /// must have the colour image's size (or depth_size).
  ImageLimits image_limits;
  /// Size of the depth images when they are not registered to colour; empty: the colour's.
  cv::Size depth_size;
};

/// A frame as stored: colour image and depth in integer units (0 = missing).
struct RawFrame {
  cv::Mat bgr;          ///< CV_8UC3
  cv::Mat depth_units;  ///< CV_16UC1, units of 1/depth_scale m; 0 = missing
};

/// Loads colour (PNG or JPEG) and depth (16-bit PNG) of one entry. Depth above the max range
/// and the 65535 marker are set to 0. Throws FrameLoadError naming the file when it is
/// missing, cannot be decoded, is not 16-bit, announces a size options.image_limits refuses,
/// or the two sizes disagree (both checked on the headers, before decoding).
RawFrame loadRawFrame(const DatasetEntry& entry, double depth_scale,
                      const FrameLoadOptions& options = {});

/// An opened dataset: index, camera (size from the first readable frame) and sequential
/// reading with optional skipping of bad frames.
class Dataset {
 public:
  /// Opens `dir`. Throws DatasetError on a missing folder, no index, no frames or an
  /// unreadable camera file. The image size is read from the first frame that loads.
  static Dataset open(const std::string& dir, const DatasetOptions& options = {});

  const std::string& dir() const { return dir_; }
  const DatasetIndex& index() const { return index_; }
  const DatasetCamera& camera() const { return camera_; }
  size_t size() const { return index_.entries.size(); }
  const DatasetEntry& entry(size_t i) const { return index_.entries.at(i); }

  /// Frame i as a library frame (depth in metres; camera attached; seq = i).
  /// Throws FrameLoadError; also when the image size differs from the camera's.
  RgbdFrame loadFrame(size_t i, const FrameLoadOptions& options = {}) const;
  /// Frame i in stored units. Throws FrameLoadError (also on a size that differs from the
  /// camera's).
  RawFrame loadRaw(size_t i, const FrameLoadOptions& options = {}) const;

 private:
  std::string dir_;
  DatasetIndex index_;
  DatasetCamera camera_;
};

/// Counters of a sequential read.
struct ReadStats {
  int64_t frames_read = 0;
  int64_t frames_skipped = 0;
  std::string last_error;  ///< message of the last skipped frame
};

/// Reads a Dataset in order. With skip_bad, frames that fail to load are skipped and counted;
/// without, next() throws the FrameLoadError.
class DatasetReader {
 public:
  struct Item {
    size_t index = 0;  ///< position in the dataset index
    RawFrame frame;
  };
  DatasetReader(const Dataset& dataset, bool skip_bad, const FrameLoadOptions& options = {},
                size_t start = 0);
  /// Next frame, or nullopt at the end of the dataset.
  std::optional<Item> next();
  /// Continues from `index` (used for --start and --loop).
  void seek(size_t index) { pos_ = index; }
  size_t position() const { return pos_; }
  const ReadStats& stats() const { return stats_; }

 private:
  const Dataset& dataset_;
  bool skip_bad_;
  FrameLoadOptions options_;
  size_t pos_;
  ReadStats stats_;
};

}  // namespace pplvo::dataset

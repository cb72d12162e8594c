#pragma once
/// Pure conversions used by the live-camera node (pplvo-camera): no LCM, no device library.
/// Everything here is testable on recorded or synthetic buffers; the OpenNI2 and libfreenect
/// code paths only copy device buffers and call these functions. See docs/cameras.md.
#include <cstdint>
#include <deque>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "pplvo/core/camera.h"
#include "pplvo/core/rgbd_frame.h"

namespace pplvo::camera {

// ---------------------------------------------------------------------------------------------
// Kinect v1 raw disparity <-> metric depth
// ---------------------------------------------------------------------------------------------

/// The Kinect v1 11-bit raw disparity model z_m = 1 / (a * raw + b) (N. Burrus' fit, the
/// "standard Kinect formula" used by libfreenect examples and ROS). raw = 2047 means "no
/// reading". Equation (K1) in docs/cameras.md.
struct KinectDisparityModel {
  double a_per_raw = -0.0030711016;  ///< 1/m per raw unit
  double b_per_m = 3.3309495161;     ///< 1/m
  int no_reading_raw = 2047;         ///< raw value meaning "no measurement"
  /// Largest raw value treated as valid: 1050 is z = 9.41 m, beyond the Kinect's range; larger
  /// values come from noise near the pole of the model (raw 1084.6 is z = infinity).
  int max_valid_raw = 1050;

  /// Metres for a raw value; 0 for no reading or out-of-range values.
  double metresFromRaw(int raw) const;
  /// Nearest raw value for a depth in metres; no_reading_raw when z is not finite, <= 0, too
  /// close (raw < 0, z < 1/b = 0.300 m) or too far (raw > max_valid_raw).
  int rawFromMetres(double z_m) const;
  /// Depth change for one raw step at depth z: |a| z^2 (equation (K2)).
  double stepAtDepthM(double z_m) const { return -a_per_raw * z_m * z_m; }
  /// Exact bound on |z_src - z_back| after z_src -> nearest raw -> z_back: since
  /// |1/z_src - 1/z_back| <= |a|/2, |z_src - z_back| <= |a|/2 * z_src * z_back (equation (K3)).
  double roundTripBoundM(double z_src_m, double z_back_m) const {
    return 0.5 * -a_per_raw * z_src_m * z_back_m;
  }
};

/// CV_16UC1 raw 11-bit disparity (as libfreenect's FREENECT_DEPTH_11BIT delivers it) ->
/// CV_16UC1 depth in millimetres (depth_scale 1000), 0 = no measurement. Uses a 2048-entry
/// table built once from `model`.
class KinectRawToMm {
 public:
  explicit KinectRawToMm(const KinectDisparityModel& model = {});
  cv::Mat convert(const cv::Mat& raw_u16) const;
  const KinectDisparityModel& model() const { return model_; }

 private:
  KinectDisparityModel model_;
  uint16_t table_mm_[2048];
};

/// CV_32FC1 depth in metres (0 = missing) -> CV_16UC1 raw 11-bit disparity, the inverse used
/// by pplvo-tum-to-fakenect. Pixels that cannot be represented become no_reading_raw; their
/// number is returned in `unrepresentable` (when given).
cv::Mat kinectRawFromMetres(const cv::Mat& depth_m, const KinectDisparityModel& model,
                            int* unrepresentable = nullptr);

// ---------------------------------------------------------------------------------------------
// Device buffers -> OpenCV images
// ---------------------------------------------------------------------------------------------

/// Packed RGB888 (R G B per pixel) with `stride_bytes` per row (0: 3 * width) -> CV_8UC3 BGR.
/// Throws std::invalid_argument on non-positive sizes, a null pointer or a short stride.
cv::Mat bgrFromRgb888(const uint8_t* data, int width, int height, int stride_bytes = 0);
/// Copies a uint16 depth buffer with `stride_bytes` per row (0: 2 * width) into a CV_16UC1.
cv::Mat depthU16FromBuffer(const uint16_t* data, int width, int height, int stride_bytes = 0);

/// Depth units of a device stream. OpenNI2 PIXEL_FORMAT_DEPTH_1_MM is Millimetre (1000 units
/// per metre), PIXEL_FORMAT_DEPTH_100_UM is HundredMicrometre (10000 per metre).
enum class DepthUnit { Millimetre, HundredMicrometre };
double depthScaleFor(DepthUnit unit);

/// Pinhole intrinsics from the fields of view a device reports (OpenNI2
/// getHorizontalFieldOfView / getVerticalFieldOfView): fx = (w/2) / tan(hfov/2),
/// fy = (h/2) / tan(vfov/2), principal point at the image centre ((w-1)/2, (h-1)/2), no
/// distortion. Returns nullopt for non-finite or out-of-range angles (not in (0, pi)).
std::optional<PinholeCamera> intrinsicsFromFov(int width, int height, double hfov_rad,
                                               double vfov_rad);
/// Nominal Kinect v1 colour intrinsics at 640x480 (fx = fy = 525, centre 319.5, 239.5), the
/// TUM default, scaled to the given size; used when neither a calibration file nor the device
/// gives intrinsics.
PinholeCamera kinectV1DefaultIntrinsics(int width = 640, int height = 480);

/// Result of loading a calibration file.
struct CalibrationLoad {
  std::optional<PinholeCamera> camera;  ///< colour camera scaled to the requested size
  /// The file's depth camera when it says `depth_registered` false / 0 (`depth_camera` map of
  /// the camera YAML, `IR_*` / `Rotation` / `Translation` of calib_params), intrinsics scaled
  /// to the requested size like the colour's (a depth camera without a size takes it as it
  /// is); unset for registered depth.
  std::optional<DepthCamera> depth_camera;
  std::string error;                    ///< why loading failed (empty on success)
  std::string format;                   ///< which key layout was found
};
/// Reads the colour intrinsics with the dataset player's loaders (pplvo_dataset, see
/// docs/player.md): calib_params.xml / OpenCV FileStorage XML or YAML (RGB_intrinsic_params
/// 3x3, RGB_distortion_coefficients, optional width/height), or the pplvo camera YAML (`fx fy
/// cx cy [width height distortion depth_scale]`, a .yaml/.yml file not starting with %YAML).
/// When the file names its image size and it differs from (width, height), the intrinsics are
/// scaled (uniform scaling only); with no size in the file they are used as they are.
/// When the file says `depth_registered` false, its depth camera is returned too (same
/// scaling rule, applied to the depth camera's own size).
CalibrationLoad loadCalibration(const std::string& path, int width, int height);

// ---------------------------------------------------------------------------------------------
// Time
// ---------------------------------------------------------------------------------------------

struct DeviceClockOptions {
  double ticks_per_second = 1e6;  ///< OpenNI2: microseconds; Kinect v1 (libfreenect): 60 MHz
  int counter_bits = 64;          ///< width of the device counter (libfreenect: 32, wraps 71.6 s)
  /// Largest clock drift followed without a jump: the offset estimate may rise by this much
  /// per second of device time (crystal oscillators: < 100 ppm).
  double max_drift_ppm = 200.0;
  /// A frame whose host-minus-device difference is this far above the estimate is an outlier
  /// (host stall, device clock reset).
  double jump_threshold_s = 0.5;
  /// This many consecutive outliers restart the mapping (device reset, replug).
  int restart_after_outliers = 3;
};

/// Maps device timestamps to host time (microseconds) robustly: host_arrival - device_time =
/// offset + latency with latency >= 0, so the offset is the lower envelope of the differences
/// (first frame: the first difference), allowed to rise by at most max_drift_ppm per second of
/// device time to follow drift (equation (T1) in docs/cameras.md). Counter wrap-around is
/// unwrapped; mapped times never exceed the host arrival time and strictly increase.
class DeviceClockMapper {
 public:
  explicit DeviceClockMapper(const DeviceClockOptions& options = {});
  /// Host time (us) of the frame with device counter `device_ticks` that arrived at
  /// `host_arrival_utime`.
  int64_t map(uint64_t device_ticks, int64_t host_arrival_utime);
  void reset();

  struct Stats {
    int64_t frames = 0;
    int64_t wraps = 0;     ///< counter wrap-arounds unwrapped
    int64_t outliers = 0;  ///< frames mapped to their arrival time
    int64_t restarts = 0;  ///< mapping restarted after consecutive outliers
    double offset_us = 0;  ///< current host - device offset (device time from first frame)
  };
  const Stats& stats() const { return stats_; }
  const DeviceClockOptions& options() const { return options_; }

 private:
  DeviceClockOptions options_;
  bool started_ = false;
  uint64_t last_raw_ = 0;
  int64_t unwrapped_ticks_ = 0;  // relative to the first frame
  double last_device_us_ = 0;
  double offset_us_ = 0;
  int consecutive_outliers_ = 0;
  int64_t last_output_ = INT64_MIN;
  Stats stats_;
};

/// Pairs separately delivered depth and colour frames by device time (libfreenect calls its
/// depth and video callbacks independently, possibly several in one event-loop call). A pair
/// is released when both halves are present within `tolerance_ticks`; otherwise the older
/// half is dropped (counted). Up to `max_ready` complete pairs wait for pop(); older ones are
/// dropped (counted) beyond that.
class FramePairer {
 public:
  explicit FramePairer(uint64_t tolerance_ticks, int counter_bits = 64, size_t max_ready = 4)
      : tolerance_(tolerance_ticks), bits_(counter_bits), max_ready_(max_ready) {}
  struct Pair {
    cv::Mat bgr;
    cv::Mat depth;
    uint64_t device_ticks = 0;  ///< colour frame's counter
    int64_t depth_minus_colour_ticks = 0;  ///< depth frame's counter minus the colour's
  };
  void pushDepth(const cv::Mat& depth, uint64_t ticks);
  void pushColour(const cv::Mat& bgr, uint64_t ticks);
  /// The oldest complete pair, if any.
  std::optional<Pair> pop();
  void clear();
  int64_t dropped() const { return dropped_; }

 private:
  void match();
  int64_t signedDiff(uint64_t a, uint64_t b) const;  // a - b modulo the counter width
  uint64_t tolerance_;
  int bits_;
  size_t max_ready_;
  std::optional<std::pair<cv::Mat, uint64_t>> depth_, colour_;
  std::deque<Pair> ready_;
  int64_t dropped_ = 0;
};

/// --max-fps: lets a frame through when at least 1/max_fps has passed on the frame clock
/// since the last one let through, with a schedule that keeps the long-run rate at max_fps
/// for inputs faster than it (a 30 Hz input limited to 10 Hz passes every third frame).
/// max_fps <= 0 lets everything through.
class RateLimiter {
 public:
  explicit RateLimiter(double max_fps) : max_fps_(max_fps) {}
  bool allow(int64_t utime);

 private:
  double max_fps_;
  bool started_ = false;
  int64_t next_us_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Options
// ---------------------------------------------------------------------------------------------

enum class RgbEncoding { Raw, Jpeg, Png };
enum class DepthEncoding { Raw, Zlib, Png };
std::optional<RgbEncoding> parseRgbEncoding(const std::string& s);      ///< raw|jpeg|png
std::optional<DepthEncoding> parseDepthEncoding(const std::string& s);  ///< raw|zlib|png

/// What to do about depth-to-colour registration, given the request and the device.
struct RegistrationDecision {
  bool use_hardware = false;  ///< switch the device's registration on
  bool depth_in_colour_frame = false;
  std::string warning;  ///< non-empty when the result differs from the request
};
RegistrationDecision decideRegistration(bool requested, bool hardware_supported);

/// What the camera node publishes as its frames' depth camera (docs/cameras.md, "Unregistered
/// depth"): nothing (DEPTH_REGISTERED) when the device registers depth to colour, else the
/// depth camera of its own (DEPTH_OWN_CAMERA).
struct DepthFramePlan {
  std::optional<DepthCamera> depth_camera;  ///< unset: DEPTH_REGISTERED
  std::string origin;   ///< where the depth camera came from (start-up line)
  std::string warning;  ///< non-empty when the extrinsic is assumed, not calibrated
  std::string error;    ///< non-empty: unregistered depth cannot be described; do not stream
};
/// Decides the depth frame of published frames. With depth in the colour frame: registered.
/// Otherwise the calibration file's depth camera (intrinsics and extrinsic) when given, else
/// the device's depth intrinsics (OpenNI2: the depth stream's field of view, (F1)) with an
/// identity extrinsic and a warning (the extrinsic must come from a calibration), else an
/// error. The depth camera's size must be (depth_width, depth_height), the depth images' size
/// (a calibration without a size takes it).
DepthFramePlan planDepthFrame(const RegistrationDecision& registration,
                              const std::optional<DepthCamera>& calib_depth_camera,
                              const std::optional<PinholeCamera>& device_depth_intrinsics,
                              int depth_width, int depth_height);

/// One video mode a device offers (OpenNI2 VideoMode without the OpenNI type).
struct ModeCandidate {
  int width = 0;
  int height = 0;
  int fps = 0;
  int pixel_format = 0;  ///< device-specific code
};
/// Index of the mode with exactly (width, height, fps) and a pixel format in
/// `accepted_formats` (earlier entries preferred); nullopt when there is none.
std::optional<size_t> chooseMode(const std::vector<ModeCandidate>& modes, int width, int height,
                                 int fps, const std::vector<int>& accepted_formats);
/// "640x480@30 640x480@60 ..." for error messages.
std::string describeModes(const std::vector<ModeCandidate>& modes);

/// Formats a host time in microseconds as "seconds.microseconds" (TUM stamp style).
std::string stampText(int64_t utime);

}  // namespace pplvo::camera

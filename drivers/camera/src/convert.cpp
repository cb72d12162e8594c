#include "pplvo/camera/convert.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "pplvo/core/enum_names.h"
#include "pplvo/dataset/dataset.h"

namespace pplvo::camera {

// ----------------------------------------------------------------------------- Kinect model

double KinectDisparityModel::metresFromRaw(int raw) const {
  if (raw < 0 || raw > max_valid_raw || raw == no_reading_raw) return 0.0;
  const double inv_z = a_per_raw * raw + b_per_m;
  return inv_z > 0 ? 1.0 / inv_z : 0.0;
}

int KinectDisparityModel::rawFromMetres(double z_m) const {
  if (!std::isfinite(z_m) || z_m <= 0) return no_reading_raw;
  const double raw = std::round((1.0 / z_m - b_per_m) / a_per_raw);
  if (raw < 0 || raw > max_valid_raw) return no_reading_raw;
  return static_cast<int>(raw);
}

KinectRawToMm::KinectRawToMm(const KinectDisparityModel& model) : model_(model) {
  for (int raw = 0; raw < 2048; ++raw) {
    const double mm = std::round(model_.metresFromRaw(raw) * 1000.0);
    table_mm_[raw] = (mm > 0 && mm < 65535) ? static_cast<uint16_t>(mm) : 0;
  }
}

cv::Mat KinectRawToMm::convert(const cv::Mat& raw_u16) const {
  if (raw_u16.type() != CV_16UC1) throw std::invalid_argument("raw disparity must be CV_16UC1");
  cv::Mat out(raw_u16.size(), CV_16UC1);
  for (int r = 0; r < raw_u16.rows; ++r) {
    const uint16_t* in = raw_u16.ptr<uint16_t>(r);
    uint16_t* o = out.ptr<uint16_t>(r);
    for (int c = 0; c < raw_u16.cols; ++c) o[c] = in[c] < 2048 ? table_mm_[in[c]] : 0;
  }
  return out;
}

cv::Mat kinectRawFromMetres(const cv::Mat& depth_m, const KinectDisparityModel& model,
                            int* unrepresentable) {
  if (depth_m.type() != CV_32FC1) throw std::invalid_argument("depth must be CV_32FC1 metres");
  cv::Mat out(depth_m.size(), CV_16UC1);
  int bad = 0;
  for (int r = 0; r < depth_m.rows; ++r) {
    const float* in = depth_m.ptr<float>(r);
    uint16_t* o = out.ptr<uint16_t>(r);
    for (int c = 0; c < depth_m.cols; ++c) {
      const float z = in[c];
      if (!(z > 0)) {  // missing (0) or NaN
        o[c] = static_cast<uint16_t>(model.no_reading_raw);
        if (std::isnan(z)) ++bad;
        continue;
      }
      const int raw = model.rawFromMetres(z);
      if (raw == model.no_reading_raw) ++bad;
      o[c] = static_cast<uint16_t>(raw);
    }
  }
  if (unrepresentable) *unrepresentable = bad;
  return out;
}

// ----------------------------------------------------------------------------- buffers

cv::Mat bgrFromRgb888(const uint8_t* data, int width, int height, int stride_bytes) {
  if (!data || width <= 0 || height <= 0) throw std::invalid_argument("bad RGB888 buffer");
  if (stride_bytes == 0) stride_bytes = 3 * width;
  if (stride_bytes < 3 * width) throw std::invalid_argument("RGB888 stride shorter than a row");
  cv::Mat out(height, width, CV_8UC3);
  for (int r = 0; r < height; ++r) {
    const uint8_t* in = data + static_cast<size_t>(r) * stride_bytes;
    uint8_t* o = out.ptr<uint8_t>(r);
    for (int c = 0; c < width; ++c) {
      o[3 * c + 0] = in[3 * c + 2];
      o[3 * c + 1] = in[3 * c + 1];
      o[3 * c + 2] = in[3 * c + 0];
    }
  }
  return out;
}

cv::Mat depthU16FromBuffer(const uint16_t* data, int width, int height, int stride_bytes) {
  if (!data || width <= 0 || height <= 0) throw std::invalid_argument("bad depth buffer");
  if (stride_bytes == 0) stride_bytes = 2 * width;
  if (stride_bytes < 2 * width) throw std::invalid_argument("depth stride shorter than a row");
  cv::Mat out(height, width, CV_16UC1);
  const auto* bytes = reinterpret_cast<const uint8_t*>(data);
  for (int r = 0; r < height; ++r) {
    std::memcpy(out.ptr<uint16_t>(r), bytes + static_cast<size_t>(r) * stride_bytes,
                2 * static_cast<size_t>(width));
  }
  return out;
}

double depthScaleFor(DepthUnit unit) { return unit == DepthUnit::Millimetre ? 1000.0 : 10000.0; }

std::optional<PinholeCamera> intrinsicsFromFov(int width, int height, double hfov_rad,
                                               double vfov_rad) {
  if (width <= 0 || height <= 0) return std::nullopt;
  if (!std::isfinite(hfov_rad) || !std::isfinite(vfov_rad)) return std::nullopt;
  if (hfov_rad <= 0 || hfov_rad >= M_PI || vfov_rad <= 0 || vfov_rad >= M_PI) return std::nullopt;
  PinholeCamera cam;
  cam.width = width;
  cam.height = height;
  cam.fx = 0.5 * width / std::tan(0.5 * hfov_rad);
  cam.fy = 0.5 * height / std::tan(0.5 * vfov_rad);
  cam.cx = 0.5 * (width - 1);
  cam.cy = 0.5 * (height - 1);
  return cam;
}

PinholeCamera kinectV1DefaultIntrinsics(int width, int height) {
  PinholeCamera cam;
  cam.width = 640;
  cam.height = 480;
  cam.fx = cam.fy = 525.0;
  cam.cx = 319.5;
  cam.cy = 239.5;
  if (width == 640 && height == 480) return cam;
  PinholeCamera s = cam.scaled(static_cast<double>(width) / 640.0);
  s.width = width;
  s.height = height;
  return s;
}

namespace {
/// `cam` fitted to (width, height): a camera without a size is used as it is; one with another
/// size is scaled uniformly (pixel-centre convention u' + 0.5 = s (u + 0.5)) or refused.
std::optional<PinholeCamera> scaledToSize(PinholeCamera cam, int width, int height,
                                          const std::string& path, const std::string& what,
                                          std::string* error) {
  const int file_w = cam.width, file_h = cam.height;
  if (file_w > 0 && file_h > 0 && (file_w != width || file_h != height)) {
    const double sx = static_cast<double>(width) / file_w;
    const double sy = static_cast<double>(height) / file_h;
    if (std::abs(sx - sy) > 1e-3 * sx) {
      *error = path + ": " + what + "calibrated at " + std::to_string(file_w) + "x" +
               std::to_string(file_h) + ", which does not scale to " + std::to_string(width) +
               "x" + std::to_string(height);
      return std::nullopt;
    }
    cam.fx *= sx;
    cam.fy *= sy;
    cam.cx = (cam.cx + 0.5) * sx - 0.5;
    cam.cy = (cam.cy + 0.5) * sy - 0.5;
  }
  cam.width = width;
  cam.height = height;
  return cam;
}
}  // namespace

CalibrationLoad loadCalibration(const std::string& path, int width, int height) {
  // The player's loaders (pplvo_dataset) read the files; this only picks the loader and fits
  // the intrinsics to the stream size.
  CalibrationLoad out;
  if (width <= 0 || height <= 0) {
    out.error = "image size must be positive";
    return out;
  }
  dataset::DatasetCamera loaded;
  try {
    const auto dot = path.find_last_of('.');
    const std::string ext = dot == std::string::npos ? "" : path.substr(dot);
    bool pplvo_yaml = false;
    if (ext == ".yaml" || ext == ".yml") {
      // OpenCV FileStorage YAML starts with "%YAML"; the pplvo camera YAML does not.
      std::ifstream f(path);
      if (!f) {
        out.error = "cannot open calibration file '" + path + "'";
        return out;
      }
      std::string first;
      std::getline(f, first);
      pplvo_yaml = first.rfind("%YAML", 0) != 0;
    }
    if (pplvo_yaml) {
      loaded = dataset::loadCameraYaml(path);
      out.format = "pplvo camera YAML";
    } else {
      loaded = dataset::loadCalibParamsXml(path);
      out.format = "calib_params (OpenCV FileStorage)";
    }
  } catch (const std::exception& e) {
    out.error = e.what();
    return out;
  }
  const auto colour = scaledToSize(loaded.camera, width, height, path, "", &out.error);
  if (!colour) return out;
  if (loaded.depth_camera) {
    const auto depth =
        scaledToSize(loaded.depth_camera->camera, width, height, path, "depth camera ", &out.error);
    if (!depth) return out;
    out.depth_camera = DepthCamera{*depth, loaded.depth_camera->T_c_d};
  }
  out.camera = colour;
  return out;
}

DepthFramePlan planDepthFrame(const RegistrationDecision& registration,
                              const std::optional<DepthCamera>& calib_depth_camera,
                              const std::optional<PinholeCamera>& device_depth_intrinsics,
                              int depth_width, int depth_height) {
  DepthFramePlan plan;
  if (registration.depth_in_colour_frame) {
    plan.origin = "registered to colour";
    return plan;
  }
  const std::string size = std::to_string(depth_width) + "x" + std::to_string(depth_height);
  auto sizeOk = [&](const PinholeCamera& c, const std::string& what) {
    if (c.width == depth_width && c.height == depth_height) return true;
    plan.error = what + " is " + std::to_string(c.width) + "x" + std::to_string(c.height) +
                 " but the depth images are " + size;
    return false;
  };
  if (calib_depth_camera) {
    DepthCamera d = *calib_depth_camera;
    if (d.camera.width <= 0 && d.camera.height <= 0) {
      d.camera.width = depth_width;
      d.camera.height = depth_height;
    }
    if (!sizeOk(d.camera, "the calibration's depth camera")) return plan;
    plan.depth_camera = d;
    plan.origin = "depth camera and extrinsic from the calibration file";
    return plan;
  }
  if (device_depth_intrinsics) {
    if (!sizeOk(*device_depth_intrinsics, "the device's depth camera")) return plan;
    plan.depth_camera = DepthCamera{*device_depth_intrinsics, Pose3::Identity()};
    plan.origin = "depth camera from the device's field of view, identity extrinsic";
    plan.warning =
        "unregistered depth without a calibrated extrinsic: identity assumed (the depth and "
        "colour cameras of a Kinect / Xtion are ~2.5 cm apart); give --calib with "
        "depth_registered: false and depth_camera R_c_d / t_c_d_m";
    return plan;
  }
  plan.error =
      "depth is not registered to colour and neither the device nor a calibration file gives "
      "the depth camera's intrinsics: give --calib FILE with depth_registered: false and a "
      "depth_camera (docs/cameras.md, \"Unregistered depth\"), or --registration on with a "
      "device that registers";
  return plan;
}

// ----------------------------------------------------------------------------- time

DeviceClockMapper::DeviceClockMapper(const DeviceClockOptions& options) : options_(options) {
  if (!(options_.ticks_per_second > 0)) throw std::invalid_argument("ticks_per_second <= 0");
  if (options_.counter_bits < 8 || options_.counter_bits > 64) {
    throw std::invalid_argument("counter_bits must be in [8, 64]");
  }
}

void DeviceClockMapper::reset() {
  started_ = false;
  consecutive_outliers_ = 0;
  // last_output_ is kept: mapped times stay increasing across a restart.
}

int64_t DeviceClockMapper::map(uint64_t device_ticks, int64_t host_arrival_utime) {
  ++stats_.frames;
  if (!started_) {
    started_ = true;
    last_raw_ = device_ticks;
    unwrapped_ticks_ = 0;
    last_device_us_ = 0;
    offset_us_ = static_cast<double>(host_arrival_utime);
    consecutive_outliers_ = 0;
  } else {
    // Signed difference modulo 2^bits: a wrap-around of the counter is a small positive step.
    int64_t delta;
    if (options_.counter_bits == 64) {
      delta = static_cast<int64_t>(device_ticks - last_raw_);
    } else {
      const uint64_t mask = (uint64_t{1} << options_.counter_bits) - 1;
      const uint64_t d = (device_ticks - last_raw_) & mask;
      const uint64_t half = uint64_t{1} << (options_.counter_bits - 1);
      delta = d >= half ? static_cast<int64_t>(d) - static_cast<int64_t>(mask + 1)
                        : static_cast<int64_t>(d);
      if ((device_ticks & mask) < (last_raw_ & mask) && delta > 0) ++stats_.wraps;
    }
    last_raw_ = device_ticks;
    unwrapped_ticks_ += delta;
    const double device_us = unwrapped_ticks_ * 1e6 / options_.ticks_per_second;
    const double diff = static_cast<double>(host_arrival_utime) - device_us;
    const double leak = options_.max_drift_ppm * 1e-6 * std::max(0.0, device_us - last_device_us_);
    const double predicted = offset_us_ + leak;
    if (diff - predicted > options_.jump_threshold_s * 1e6 ||
        predicted - diff > options_.jump_threshold_s * 1e6) {
      // A host stall (too late) or a device clock that jumped (too early). Too early cannot
      // be latency, so a frame that arrives much earlier than predicted is also an outlier.
      ++stats_.outliers;
      if (++consecutive_outliers_ >= options_.restart_after_outliers) {
        ++stats_.restarts;
        started_ = false;
        --stats_.frames;                               // counted again by the restarted call
        return map(device_ticks, host_arrival_utime);  // restart from this frame
      }
      last_device_us_ = device_us;
      offset_us_ = predicted;
      // Too late: the old mapping is still the best guess for a delayed frame. Too early: the
      // device clock jumped, so only the arrival time is trustworthy.
      int64_t out = host_arrival_utime;
      if (diff > predicted) {
        out = std::min<int64_t>(out, std::llround(predicted + device_us));
      }
      if (last_output_ != INT64_MIN && out <= last_output_) out = last_output_ + 1;
      last_output_ = out;
      stats_.offset_us = offset_us_;
      return out;
    }
    consecutive_outliers_ = 0;
    offset_us_ = std::min(predicted, diff);  // lower envelope with bounded upward drift
    last_device_us_ = device_us;
  }
  stats_.offset_us = offset_us_;
  const double device_us = unwrapped_ticks_ * 1e6 / options_.ticks_per_second;
  int64_t out = static_cast<int64_t>(std::llround(offset_us_ + device_us));
  if (out > host_arrival_utime) out = host_arrival_utime;
  if (last_output_ != INT64_MIN && out <= last_output_) out = last_output_ + 1;
  last_output_ = out;
  return out;
}

// ----------------------------------------------------------------------------- pairing

int64_t FramePairer::signedDiff(uint64_t a, uint64_t b) const {
  if (bits_ == 64) return static_cast<int64_t>(a - b);
  const uint64_t mask = (uint64_t{1} << bits_) - 1;
  const uint64_t d = (a - b) & mask;
  const uint64_t half = uint64_t{1} << (bits_ - 1);
  return d >= half ? static_cast<int64_t>(d) - static_cast<int64_t>(mask + 1)
                   : static_cast<int64_t>(d);
}

void FramePairer::pushDepth(const cv::Mat& depth, uint64_t ticks) {
  if (depth_) ++dropped_;  // an unmatched older depth frame is replaced
  depth_ = std::make_pair(depth, ticks);
  match();
}

void FramePairer::pushColour(const cv::Mat& bgr, uint64_t ticks) {
  if (colour_) ++dropped_;
  colour_ = std::make_pair(bgr, ticks);
  match();
}

void FramePairer::match() {
  if (!depth_ || !colour_) return;
  const int64_t d = signedDiff(colour_->second, depth_->second);
  if (static_cast<uint64_t>(d < 0 ? -d : d) <= tolerance_) {
    if (ready_.size() >= max_ready_) {  // the consumer fell behind: drop the oldest pair
      ready_.pop_front();
      ++dropped_;
    }
    ready_.push_back(Pair{colour_->first, depth_->first, colour_->second, -d});
    depth_.reset();
    colour_.reset();
    return;
  }
  // Too far apart: the older half can never be matched (frames arrive in order).
  ++dropped_;
  if (d > 0) {
    depth_.reset();
  } else {
    colour_.reset();
  }
}

std::optional<FramePairer::Pair> FramePairer::pop() {
  if (ready_.empty()) return std::nullopt;
  Pair out = std::move(ready_.front());
  ready_.pop_front();
  return out;
}

void FramePairer::clear() {
  depth_.reset();
  colour_.reset();
  ready_.clear();
}

bool RateLimiter::allow(int64_t utime) {
  if (!(max_fps_ > 0)) return true;
  const auto period = static_cast<int64_t>(std::llround(1e6 / max_fps_));
  // Frames jitter: accept a frame up to a tenth of a period early relative to the schedule
  // (the schedule itself advances by whole periods, so the long-run rate stays max_fps), and
  // resynchronise after gaps longer than a period.
  const int64_t slack = period / 10;
  if (!started_ || utime >= next_us_ - slack) {
    if (!started_ || utime - next_us_ > period) {
      next_us_ = utime + period;
    } else {
      next_us_ += period;
    }
    started_ = true;
    return true;
  }
  return false;
}

// ----------------------------------------------------------------------------- options

namespace {
constexpr EnumName<RgbEncoding> kRgbEncodingNames[] = {{RgbEncoding::Raw, "raw"},
                                                       {RgbEncoding::Jpeg, "jpeg"},
                                                       {RgbEncoding::Jpeg, "jpg"},
                                                       {RgbEncoding::Png, "png"}};
constexpr EnumName<DepthEncoding> kDepthEncodingNames[] = {
    {DepthEncoding::Raw, "raw"}, {DepthEncoding::Zlib, "zlib"}, {DepthEncoding::Png, "png"}};
}  // namespace

std::optional<RgbEncoding> parseRgbEncoding(const std::string& s) {
  return parseEnum(kRgbEncodingNames, s);
}

std::optional<DepthEncoding> parseDepthEncoding(const std::string& s) {
  return parseEnum(kDepthEncodingNames, s);
}

RegistrationDecision decideRegistration(bool requested, bool hardware_supported) {
  RegistrationDecision d;
  if (!requested) return d;  // depth in the depth camera's own frame, as asked
  if (hardware_supported) {
    d.use_hardware = true;
    d.depth_in_colour_frame = true;
    return d;
  }
  d.warning =
      "device has no hardware depth-to-colour registration: publishing depth in the depth "
      "camera's own frame (DEPTH_OWN_CAMERA; the depth filter registers it)";
  return d;
}

std::optional<size_t> chooseMode(const std::vector<ModeCandidate>& modes, int width, int height,
                                 int fps, const std::vector<int>& accepted_formats) {
  for (int format : accepted_formats) {
    for (size_t i = 0; i < modes.size(); ++i) {
      const ModeCandidate& m = modes[i];
      if (m.width == width && m.height == height && m.fps == fps && m.pixel_format == format) {
        return i;
      }
    }
  }
  return std::nullopt;
}

std::string describeModes(const std::vector<ModeCandidate>& modes) {
  std::string out;
  for (const ModeCandidate& m : modes) {
    if (!out.empty()) out += ' ';
    out += std::to_string(m.width) + "x" + std::to_string(m.height) + "@" + std::to_string(m.fps) +
           "/fmt" + std::to_string(m.pixel_format);
  }
  return out;
}

std::string stampText(int64_t utime) {
  char buf[48];
  const bool neg = utime < 0;
  const uint64_t a = neg ? static_cast<uint64_t>(-(utime + 1)) + 1 : static_cast<uint64_t>(utime);
  std::snprintf(buf, sizeof(buf), "%s%llu.%06llu", neg ? "-" : "",
                static_cast<unsigned long long>(a / 1000000),
                static_cast<unsigned long long>(a % 1000000));
  return buf;
}

}  // namespace pplvo::camera

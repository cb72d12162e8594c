#pragma once
/// Conversions between LCM messages and library types. The only place where image encodings
/// are known; every function validates sizes and throws MessageError on inconsistent input.
#include <optional>
#include <stdexcept>
#include <string>

#include <opencv2/core.hpp>

#include <pplvo_msgs/camera_info_t.hpp>
#include <pplvo_msgs/depth_map_t.hpp>
#include <pplvo_msgs/image_t.hpp>
#include <pplvo_msgs/node_status_t.hpp>
#include <pplvo_msgs/rgbd_frame_t.hpp>

#include "pplvo/core/camera.h"
#include "pplvo/core/rgbd_frame.h"
#include "pplvo/core/stage_timer.h"

namespace pplvo::msgs {

/// A message whose content is inconsistent (sizes disagree, corrupt payload, bad encoding).
class MessageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

pplvo_msgs::camera_info_t toMsg(const PinholeCamera& camera);
/// Throws MessageError if the intrinsics are not finite or the size is not positive.
PinholeCamera fromMsg(const pplvo_msgs::camera_info_t& msg);

/// Encodes an image. Supported: CV_8UC3/CV_8UC1 as RAW_BGR8/RAW_GRAY8/JPEG/PNG, CV_16UC1 as
/// RAW_U16/ZLIB_U16/PNG_U16, CV_32FC1 as RAW_F32/ZLIB_F32, CV_8UC1 as RAW_U8/ZLIB_U8.
/// jpeg_quality applies to JPEG, zlib_level (1..9) to the zlib encodings.
pplvo_msgs::image_t encodeImage(const cv::Mat& image, int8_t encoding, int jpeg_quality = 90,
                                int zlib_level = 1);
/// Decodes an image_t into a cv::Mat of the natural type of its encoding (JPEG decodes to
/// CV_8UC3; an 8-bit PNG keeps one or three channels). Throws MessageError when the size
/// field, dimensions or payload disagree.
cv::Mat decodeImage(const pplvo_msgs::image_t& msg);
/// decodeImage() without the copy for raw encodings: the matrix then points into msg.data and
/// is valid only while `msg` lives unchanged (must not be written). Other encodings decode.
cv::Mat decodeImageView(const pplvo_msgs::image_t& msg);
std::string encodingName(int8_t encoding);

/// The images of a frame message a node decodes (the frontend uses only the colour, the
/// depth filter only the depth).
enum class FrameImages { kBoth, kColour, kDepth };

/// Frame message -> library frame (depth in metres; depth units above max_depth_units
/// count as missing). Throws MessageError on inconsistent messages. `images` other than kBoth
/// leaves the other image empty and checks only its header (present, an encoding of the
/// right type, the same size), not its payload: a payload error then shows in the node that
/// decodes it.
RgbdFrame fromMsg(const pplvo_msgs::rgbd_frame_t& msg, int max_depth_units = 65535,
                  FrameImages images = FrameImages::kBoth);
/// Library frame -> message. Depth is quantised to 1/depth_scale m.
/// rgbd_frame_t's depth_frame, depth_camera, R_c_d, t_c_d_m from a frame's depth camera
/// (DEPTH_REGISTERED when unset).
void setDepthCamera(const std::optional<DepthCamera>& depth, pplvo_msgs::rgbd_frame_t* msg);
/// The depth camera of a DEPTH_OWN_CAMERA frame, nullopt for DEPTH_REGISTERED. MessageError on
/// another depth_frame, invalid intrinsics or extrinsics that are not a rigid transform.
std::optional<DepthCamera> depthCameraFromMsg(const pplvo_msgs::rgbd_frame_t& msg);

pplvo_msgs::rgbd_frame_t toMsg(const RgbdFrame& frame, double depth_scale, int8_t rgb_encoding,
                               int8_t depth_encoding, const std::string& source = "");

pplvo_msgs::depth_map_t toMsg(const DepthWithVariance& depth, const PinholeCamera& camera,
                              int64_t utime, int64_t seq, const std::string& stamp, int8_t stage,
                              bool compress = false);
/// The bytes lcm-gen's encode() gives for toMsg(depth, camera, utime, seq, stamp, stage,
/// false) with `reference` set, written straight from the two float planes into `wire`
/// (resized; keep it between calls): each plane is copied once instead of twice (into the
/// message's vectors, then by LCM's encode). For Bus::publish(channel, data, size). Throws
/// MessageError where toMsg() does (planes not CV_32FC1, sizes that disagree).
void encodeRawDepthMap(const DepthWithVariance& depth, const PinholeCamera& camera, int64_t utime,
                       int64_t seq, const std::string& stamp, int8_t stage, int8_t reference,
                       std::vector<uint8_t>* wire);
DepthWithVariance fromMsg(const pplvo_msgs::depth_map_t& msg);
/// The time alignment fields of a depth map or features message of frame `seq`: not moved for
/// a negative motion seq or a zero scale (a publisher that leaves them zero); MessageError for a
/// non-finite scale or a motion not before the frame.
DepthTimeAlignment depthTimeAlignmentFromMsg(double scale, int64_t motion_seq, int64_t seq);
/// fromMsg() with decodeImageView(): raw maps point into `msg` (valid while it lives; for a
/// handler that uses the map before it returns).
DepthWithVariance viewOfMsg(const pplvo_msgs::depth_map_t& msg);

/// Counters every node keeps; published as node_status_t. The frame counts add up
/// (frames_in = out + dropped + skipped + pending): nodes keep them with a FrameLedger.
struct NodeCounters {
  int64_t last_seq = -1;
  int64_t frames_in = 0;
  int64_t frames_out = 0;
  int64_t frames_dropped = 0;
  int64_t frames_skipped = 0;
  int64_t frames_pending = 0;
  int64_t frames_lost = 0;       ///< never reached the node (source numbering gaps)
  int64_t messages_skipped = 0;  ///< other inputs' messages that served no frame
  int64_t errors = 0;
  std::string last_warning;
};
/// The status of this process (pid = getpid()); `final` on the last one it publishes as it exits.
pplvo_msgs::node_status_t toStatusMsg(const std::string& node, const NodeCounters& counters,
                                      const StageTimings& timings, int64_t utime,
                                      bool final = false);

}  // namespace pplvo::msgs

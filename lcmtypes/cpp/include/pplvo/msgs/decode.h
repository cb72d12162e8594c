#pragma once
/// Decoding LCM packets that may be anything: a packet on a shared network, a cut log, a fuzzer's
/// input. The generated decoders bound every length field by the bytes left in the packet
/// (cmake/HardenLcmDecoders.cmake), so a corrupt packet fails to decode instead of throwing or
/// allocating gigabytes; decodeMessage() also catches whatever an allocation may still throw.
#include <climits>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <string>

namespace pplvo::msgs {

/// Fingerprints (lcm-gen's 8-byte type hash) of message layouts that earlier pplvo versions
/// wrote, so that an old log is named as such instead of "not a valid ...". docs/channels.md,
/// "Message versions".
struct OlderMessageVersion {
  const char* type;  ///< getTypeName(), e.g. "rgbd_frame_t"
  int64_t fingerprint;
  const char* what;  ///< how it differs from today's layout
};
inline constexpr OlderMessageVersion kOlderMessageVersions[] = {
    {"rgbd_frame_t", static_cast<int64_t>(0x91c3a57269ce5245ULL),
     "rgbd_frame_t without depth_utime (pplvo before 2026-12-02)"},
    {"rgbd_frame_t", static_cast<int64_t>(0xfb99a9fa90b73068ULL),
     "rgbd_frame_t without depth_frame / depth_camera (pplvo before unregistered depth, "
     "2026-12-02)"},
    {"pose_t", static_cast<int64_t>(0xefc8a0c530381bb2ULL),
     "pose_t without reference (pplvo before 2026-12-03)"},
    {"depth_map_t", static_cast<int64_t>(0x1ecd5069eeeacec5ULL),
     "depth_map_t without reference (pplvo before 2026-12-03)"},
    // camera_info_t gained readout_s (rolling shutter), 2026-12-04: every message holding it.
    {"rgbd_frame_t", static_cast<int64_t>(0xf83ee6370c017a62ULL),
     "rgbd_frame_t with a camera_info_t without readout_s (pplvo before 2026-12-04)"},
    {"depth_map_t", static_cast<int64_t>(0x9a3e73e1d05ea5c3ULL),
     "depth_map_t with a camera_info_t without readout_s (pplvo before 2026-12-04)"},
    {"features_t", static_cast<int64_t>(0xe4a528515d57c872ULL),
     "features_t with a camera_info_t without readout_s (pplvo before 2026-12-04)"},
    // The depth's time alignment (scale, motion seq) passed on to the estimator, 2026-12-06.
    {"depth_map_t", static_cast<int64_t>(0x3d3b45f8e04d8252ULL),
     "depth_map_t without time_alignment_* (pplvo before 2026-12-06)"},
    {"features_t", static_cast<int64_t>(0x87a1fa686d46a503ULL),
     "features_t without depth_alignment_* (pplvo before 2026-12-06)"},
};

/// Why `size` bytes whose fingerprint is not MessageT's are not one: an older pplvo layout, or
/// another type or version. Empty when the fingerprint matches (the body is what is wrong).
template <class MessageT>
std::string fingerprintMismatch(const void* data, size_t size) {
  if (size < 8) return "";
  const auto* b = static_cast<const unsigned char*>(data);
  uint64_t h = 0;
  for (int i = 0; i < 8; ++i) h = (h << 8) | b[i];  // LCM writes it big-endian
  const auto fingerprint = static_cast<int64_t>(h);
  if (fingerprint == MessageT::getHash()) return "";
  const std::string type = MessageT::getTypeName();
  for (const OlderMessageVersion& v : kOlderMessageVersions) {
    if (type == v.type && fingerprint == v.fingerprint) {
      return "older log version: " + std::string(v.what) +
             "; replay it with the pplvo that wrote it, or re-record it";
    }
  }
  return "its type fingerprint differs from this build's " + type +
         " (another message type, or a version of it this build does not know)";
}

/// Decodes `size` bytes as one MessageT into `msg`. Returns an empty string on success, else why
/// the bytes are not a MessageT (wrong type hash, lengths beyond the packet, truncated). Never
/// throws (but for std::bad_alloc while building the error text). Bytes after the message are
/// ignored, as lcm::LCM's typed subscriptions do.
template <class MessageT>
std::string decodeMessage(const void* data, size_t size, MessageT* msg) {
  if (size > static_cast<size_t>(INT_MAX)) {
    return std::string(MessageT::getTypeName()) + ": packet of " + std::to_string(size) +
           " bytes is too large";
  }
  try {
    if (msg->decode(data, 0, static_cast<int>(size)) < 0) {
      const std::string why = fingerprintMismatch<MessageT>(data, size);
      return "not a valid " + std::string(MessageT::getTypeName()) + " (" + std::to_string(size) +
             " bytes)" + (why.empty() ? "" : ": " + why);
    }
    return "";
  } catch (const std::exception& e) {
    return std::string(MessageT::getTypeName()) + ": " + e.what();
  }
}

}  // namespace pplvo::msgs

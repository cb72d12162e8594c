#pragma once
/// Default LCM channel names (documented in docs/channels.md). Every node takes its channels
/// from its options so that several pipelines can share one network.
namespace pplvo::channels {
inline constexpr const char* kRgbd = "PPLVO_RGBD";                 // rgbd_frame_t
inline constexpr const char* kDepthCgm = "PPLVO_DEPTH_CGM";        // depth_map_t (SENSOR/CGM)
inline constexpr const char* kDepthFused = "PPLVO_DEPTH_FUSED";    // depth_map_t (OGM)
inline constexpr const char* kFeatures = "PPLVO_FEATURES";         // features_t (STAGE_2D)
inline constexpr const char* kFeatures3d = "PPLVO_FEATURES_3D";    // features_t (STAGE_3D)
inline constexpr const char* kPose = "PPLVO_POSE";                 // pose_t
inline constexpr const char* kOdometry = "PPLVO_ODOMETRY";         // odometry_t (body frame)
inline constexpr const char* kStatus = "PPLVO_STATUS";             // node_status_t
inline constexpr const char* kStream = "PPLVO_STREAM";             // stream_event_t
/// What a compact recording keeps (LCM regex): the frames and what the run said about them;
/// depth maps and features are derived from the frames again by `pplvo-replay --stage
/// pipeline` (docs/logger.md, "Compact recordings").
inline constexpr const char* kCompactLogChannels = "PPLVO_(RGBD|POSE|ODOMETRY|STATUS|STREAM)";
}  // namespace pplvo::channels

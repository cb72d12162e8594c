#pragma once
/// Ground-truth judgement of 2D matches with depth and a known relative pose (tests and
/// benchmarks only).
#include <opencv2/core.hpp>

#include "pplvo/core/camera.h"
#include "pplvo/core/geometry.h"

namespace pplvo::features::testdata {

enum class Verdict { kUnjudged, kWrong, kCorrect };

/// Depth (m) at the nearest pixel of px, 0 if outside or missing.
double depthAt(const cv::Mat& depth_m, const Eigen::Vector2d& px);

/// The previous keypoint backprojected with its depth, moved by T_c2_c1 and projected lands
/// within tol_px of the current keypoint? Unjudged without depth or behind the camera.
Verdict judgePointMatch(const Eigen::Vector2d& px1, const Eigen::Vector2d& px2,
                        const cv::Mat& depth1_m, const PinholeCamera& cam,
                        const Pose3& T_c2_c1, double tol_px);

/// Samples `samples` points on the previous segment, backprojects those with depth, moves and
/// projects them; correct if the median distance to the current line is below tol_px.
/// Unjudged with fewer than 3 samples with depth.
Verdict judgeLineMatch(const Eigen::Vector2d& a1, const Eigen::Vector2d& b1,
                       const Eigen::Vector3d& eq2, const cv::Mat& depth1_m,
                       const PinholeCamera& cam, const Pose3& T_c2_c1, double tol_px,
                       int samples = 15);

}  // namespace pplvo::features::testdata

#include "pplvo/msgs/convert_features.h"

#include <cstring>

#include "pplvo/core/geometry.h"

namespace pplvo::msgs {
namespace {

template <typename Array>
void requireFinite(const Array& a, int n, const char* what) {
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(a[i])) throw MessageError(std::string("non-finite value in ") + what);
  }
}

using Features = pplvo_msgs::features_t;

// Descriptor rows travel as bytes with their element type alongside.
void packDescriptors(const cv::Mat& desc, int n, int8_t* type_out, int32_t* bytes_out,
                     std::vector<std::vector<uint8_t>>* rows) {
  rows->assign(n, {});
  *type_out = Features::DESCRIPTOR_U8;
  *bytes_out = 0;
  if (desc.empty() || n == 0) return;
  if (desc.rows != n) throw MessageError("descriptor rows disagree with feature count");
  if (desc.type() != CV_8U && desc.type() != CV_32F) throw MessageError("descriptors must be CV_8U or CV_32F");
  *type_out = desc.type() == CV_32F ? Features::DESCRIPTOR_F32 : Features::DESCRIPTOR_U8;
  const int row_bytes = static_cast<int>(desc.cols * desc.elemSize());
  *bytes_out = row_bytes;
  for (int i = 0; i < n; ++i) rows->at(i).assign(desc.ptr(i), desc.ptr(i) + row_bytes);
}

cv::Mat unpackDescriptors(int8_t type, int32_t bytes, const std::vector<std::vector<uint8_t>>& rows, int n) {
  if (bytes == 0 || n == 0) return cv::Mat();
  if (bytes < 0) throw MessageError("negative descriptor size");
  const bool is_float = type == Features::DESCRIPTOR_F32;
  if (!is_float && type != Features::DESCRIPTOR_U8) throw MessageError("unknown descriptor type");
  if (is_float && bytes % 4 != 0) throw MessageError("float descriptor size not a multiple of 4");
  if (static_cast<int>(rows.size()) != n) throw MessageError("descriptor rows disagree with feature count");
  cv::Mat out = is_float ? cv::Mat(n, bytes / 4, CV_32F) : cv::Mat(n, bytes, CV_8U);
  for (int i = 0; i < n; ++i) {
    if (static_cast<int>(rows[i].size()) != bytes) throw MessageError("descriptor row has wrong size");
    std::memcpy(out.ptr(i), rows[i].data(), bytes);
  }
  return out;
}

}  // namespace

pplvo_msgs::features_t toMsg(const FrameFeatures& f, int8_t stage,
                             const pplvo_msgs::image_t* encoded_labels) {
  pplvo_msgs::features_t m;
  m.utime = f.utime;
  m.seq = f.seq;
  m.stamp = f.stamp;
  m.stage = stage;
  m.camera = toMsg(f.camera);
  m.depth_alignment_scale = f.depth_time_alignment.scale;
  m.depth_alignment_motion_seq = f.depth_time_alignment.motion_seq;

  m.n_points = static_cast<int32_t>(f.points.size());
  m.points.resize(f.points.size());
  for (size_t i = 0; i < f.points.size(); ++i) {
    const PointFeature& p = f.points[i];
    auto& o = m.points[i];
    o.u = static_cast<float>(p.px.x());
    o.v = static_cast<float>(p.px.y());
    o.response = p.response;
    o.size_px = p.size_px;
    o.angle_deg = p.angle_deg;
    o.octave = static_cast<int8_t>(p.octave);
    o.has_3d = p.has_3d;
    for (int k = 0; k < 3; ++k) o.p_c[k] = p.has_3d ? p.point.p[k] : 0.0;
    upperFromSymmetric<3>(p.has_3d ? p.point.cov : Eigen::Matrix3d::Zero().eval(), o.cov);
  }
  packDescriptors(f.point_descriptors, m.n_points, &m.point_descriptor_type,
                  &m.point_descriptor_bytes, &m.point_descriptors);

  m.n_lines = static_cast<int32_t>(f.lines.size());
  m.lines.resize(f.lines.size());
  for (size_t i = 0; i < f.lines.size(); ++i) {
    const LineFeature& l = f.lines[i];
    auto& o = m.lines[i];
    o.u1 = static_cast<float>(l.px1.x());
    o.v1 = static_cast<float>(l.px1.y());
    o.u2 = static_cast<float>(l.px2.x());
    o.v2 = static_cast<float>(l.px2.y());
    for (int k = 0; k < 3; ++k) o.eq[k] = l.eq[k];
    o.has_3d = l.has_3d;
    for (int k = 0; k < 3; ++k) {
      o.p1_c[k] = l.has_3d ? l.line.p1[k] : 0.0;
      o.p2_c[k] = l.has_3d ? l.line.p2[k] : 0.0;
    }
    upperFromSymmetric<3>(l.has_3d ? l.line.cov1 : Eigen::Matrix3d::Zero().eval(), o.cov1);
    upperFromSymmetric<3>(l.has_3d ? l.line.cov2 : Eigen::Matrix3d::Zero().eval(), o.cov2);
    o.n_inliers = l.n_inliers;
  }
  packDescriptors(f.line_descriptors, m.n_lines, &m.line_descriptor_type,
                  &m.line_descriptor_bytes, &m.line_descriptors);

  m.n_planes = static_cast<int32_t>(f.planes.size());
  m.planes.resize(f.planes.size());
  for (size_t i = 0; i < f.planes.size(); ++i) {
    const PlaneFeature& p = f.planes[i];
    auto& o = m.planes[i];
    for (int k = 0; k < 4; ++k) o.hessian[k] = p.plane.hessian[k];
    upperFromSymmetric<4>(p.plane.cov, o.cov);
    o.n_points = p.n_points;
    for (int k = 0; k < 3; ++k) o.centroid_c[k] = p.centroid[k];
    o.label = p.label;
  }
  if (encoded_labels) {
    m.plane_labels = *encoded_labels;
  } else {
    m.plane_labels = f.plane_labels.empty()
                         ? encodeImage(cv::Mat(), pplvo_msgs::image_t::ENCODING_NONE)
                         : encodeImage(f.plane_labels, pplvo_msgs::image_t::ENCODING_ZLIB_U8);
  }
  return m;
}

FrameFeatures fromMsg(const pplvo_msgs::features_t& m) {
  if (m.n_points < 0 || m.n_lines < 0 || m.n_planes < 0 ||
      static_cast<size_t>(m.n_points) != m.points.size() ||
      static_cast<size_t>(m.n_lines) != m.lines.size() ||
      static_cast<size_t>(m.n_planes) != m.planes.size()) {
    throw MessageError("features_t counts disagree with its arrays");
  }
  FrameFeatures f;
  f.utime = m.utime;
  f.seq = m.seq;
  f.stamp = m.stamp;
  f.camera = fromMsg(m.camera);
  f.depth_time_alignment =
      depthTimeAlignmentFromMsg(m.depth_alignment_scale, m.depth_alignment_motion_seq, m.seq);

  f.points.resize(m.points.size());
  for (size_t i = 0; i < m.points.size(); ++i) {
    const auto& o = m.points[i];
    PointFeature& p = f.points[i];
    if (!std::isfinite(o.u) || !std::isfinite(o.v)) throw MessageError("non-finite keypoint");
    p.px = {o.u, o.v};
    p.response = o.response;
    p.size_px = o.size_px;
    p.angle_deg = o.angle_deg;
    p.octave = o.octave;
    p.has_3d = o.has_3d;
    if (p.has_3d) {
      requireFinite(o.p_c, 3, "point position");
      requireFinite(o.cov, 6, "point covariance");
      p.point.p = Eigen::Vector3d(o.p_c[0], o.p_c[1], o.p_c[2]);
      p.point.cov = symmetricFromUpper<3>(o.cov);
    }
  }
  f.point_descriptors = unpackDescriptors(m.point_descriptor_type, m.point_descriptor_bytes, m.point_descriptors, m.n_points);

  f.lines.resize(m.lines.size());
  for (size_t i = 0; i < m.lines.size(); ++i) {
    const auto& o = m.lines[i];
    LineFeature& l = f.lines[i];
    const float ends[4] = {o.u1, o.v1, o.u2, o.v2};
    requireFinite(ends, 4, "line endpoints");
    requireFinite(o.eq, 3, "line equation");
    l.px1 = {o.u1, o.v1};
    l.px2 = {o.u2, o.v2};
    l.eq = Eigen::Vector3d(o.eq[0], o.eq[1], o.eq[2]);
    l.has_3d = o.has_3d;
    l.n_inliers = o.n_inliers;
    if (l.has_3d) {
      requireFinite(o.p1_c, 3, "line endpoint");
      requireFinite(o.p2_c, 3, "line endpoint");
      requireFinite(o.cov1, 6, "line covariance");
      requireFinite(o.cov2, 6, "line covariance");
      l.line.p1 = Eigen::Vector3d(o.p1_c[0], o.p1_c[1], o.p1_c[2]);
      l.line.p2 = Eigen::Vector3d(o.p2_c[0], o.p2_c[1], o.p2_c[2]);
      l.line.cov1 = symmetricFromUpper<3>(o.cov1);
      l.line.cov2 = symmetricFromUpper<3>(o.cov2);
    }
  }
  f.line_descriptors = unpackDescriptors(m.line_descriptor_type, m.line_descriptor_bytes, m.line_descriptors, m.n_lines);

  f.planes.resize(m.planes.size());
  for (size_t i = 0; i < m.planes.size(); ++i) {
    const auto& o = m.planes[i];
    requireFinite(o.hessian, 4, "plane");
    requireFinite(o.cov, 10, "plane covariance");
    PlaneFeature& p = f.planes[i];
    p.plane.hessian = Eigen::Vector4d(o.hessian[0], o.hessian[1], o.hessian[2], o.hessian[3]);
    p.plane.cov = symmetricFromUpper<4>(o.cov);
    p.n_points = o.n_points;
    p.centroid = Eigen::Vector3d(o.centroid_c[0], o.centroid_c[1], o.centroid_c[2]);
    p.label = o.label;
  }
  f.plane_labels = decodeImage(m.plane_labels);
  if (!f.plane_labels.empty()) {
    if (f.plane_labels.type() != CV_8UC1) throw MessageError("plane labels must be 8-bit grey");
    if (f.plane_labels.cols != f.camera.width || f.plane_labels.rows != f.camera.height) {
      throw MessageError("plane label image size disagrees with the camera");
    }
  }
  return f;
}

}  // namespace pplvo::msgs

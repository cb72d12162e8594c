// Re-projects a dataset's registered depth into a depth camera of its own (other intrinsics and
// size, a few centimetres aside, a small rotation) and writes a dataset folder whose
// calib_params.xml says depth_registered 0, so that pplvo registers it back (issue 23: "pose
// accuracy equals that of the original within noise"; docs/depth_filter.md 0c). Colour images,
// index files and ground truth are copied unchanged. The re-projection is DepthRegistration
// itself, from the colour camera (its lens included) into the virtual depth camera.
//   pplvo_unregister_dataset SRC DST [--hfov-deg D] [--size WxH] [--pose TX,TY,TZ,RX,RY,RZ]
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core/persistence.hpp>
#include <opencv2/imgcodecs.hpp>

#include "pplvo/dataset/dataset.h"
#include "pplvo/depth_filter/depth_registration.h"

namespace fs = std::filesystem;
using namespace pplvo;

namespace {

void usage() {
  std::fprintf(stderr,
               "usage: pplvo_unregister_dataset SRC DST [--hfov-deg D] [--size WxH] "
               "[--pose TX,TY,TZ,RX,RY,RZ]\n"
               "  the virtual depth camera: horizontal field of view (default 58), image size\n"
               "  (default 320x240), position in the colour camera (m) and rotation about its\n"
               "  x, y, z axes (deg, x first; default 0.03,0.005,0,1,-2,0.5)\n");
}

cv::Mat matrixOf(const Eigen::Matrix3d& m) {
  cv::Mat out(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.at<double>(r, c) = m(r, c);
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    usage();
    return 2;
  }
  const std::string src = argv[1], dst = argv[2];
  double hfov = 58;
  int w = 320, h = 240;
  std::vector<double> pose = {0.03, 0.005, 0, 1, -2, 0.5};
  try {
    for (int i = 3; i + 1 < argc; i += 2) {
      const std::string a = argv[i], v = argv[i + 1];
      if (a == "--hfov-deg") {
        hfov = std::stod(v);
      } else if (a == "--size") {
        if (std::sscanf(v.c_str(), "%dx%d", &w, &h) != 2) throw std::invalid_argument(v);
      } else if (a == "--pose") {
        std::stringstream list(v);
        pose.clear();
        for (std::string x; std::getline(list, x, ',');) pose.push_back(std::stod(x));
        if (pose.size() != 6) throw std::invalid_argument(v);
      } else {
        throw std::invalid_argument(a);
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pplvo_unregister_dataset: bad argument %s\n", e.what());
    usage();
    return 2;
  }
  try {
    const dataset::Dataset ds = dataset::Dataset::open(src);
    if (ds.camera().depth_camera) throw std::runtime_error(src + " is not registered already");
    const PinholeCamera& colour = ds.camera().camera;
    DepthCamera d;
    d.camera.width = w;
    d.camera.height = h;
    d.camera.cx = (w - 1) / 2.0;
    d.camera.cy = (h - 1) / 2.0;
    d.camera.fx = w / 2.0 / std::tan(hfov * M_PI / 360.0);
    // The mirrored models (ICL-NUIM's negative fy) keep their sign in the depth camera too.
    d.camera.fy = colour.fy < 0 ? -d.camera.fx : d.camera.fx;
    const double k = M_PI / 180.0;
    d.T_c_d.linear() = (Eigen::AngleAxisd(pose[5] * k, Eigen::Vector3d::UnitZ()) *
                        Eigen::AngleAxisd(pose[4] * k, Eigen::Vector3d::UnitY()) *
                        Eigen::AngleAxisd(pose[3] * k, Eigen::Vector3d::UnitX()))
                           .toRotationMatrix();
    d.T_c_d.translation() = Eigen::Vector3d(pose[0], pose[1], pose[2]);
    // Registration in reverse: the colour camera (with its lens) as the source, the virtual
    // depth camera as the target, T_d_c as the extrinsics.
    DepthCamera colour_as_source;
    colour_as_source.camera = colour;
    colour_as_source.T_c_d = d.T_c_d.inverse();
    const depth_filter::QuadraticSensorModel model;
    depth_filter::DepthRegistration reprojection;

    fs::create_directories(fs::path(dst) / "depth");
    fs::create_directories(fs::path(dst) / "rgb");
    for (const char* f : {"rgb.txt", "depth.txt", "associations.txt", "groundtruth.txt"}) {
      if (fs::exists(fs::path(src) / f)) {
        fs::copy_file(fs::path(src) / f, fs::path(dst) / f, fs::copy_options::overwrite_existing);
      }
    }
    for (const auto& e : fs::directory_iterator(fs::path(src) / "rgb")) {
      fs::copy_file(e.path(), fs::path(dst) / "rgb" / e.path().filename(),
                    fs::copy_options::overwrite_existing);
    }
    const double scale = ds.camera().depth_scale;
    for (size_t i = 0; i < ds.size(); ++i) {
      const dataset::DatasetEntry& e = ds.entry(i);
      const dataset::RawFrame raw = ds.loadRaw(i);
      const cv::Mat depth_m = depthUnitsToMetres(raw.depth_units, scale);
      const DepthWithVariance out = reprojection.apply(d.camera, colour_as_source, depth_m, model);
      const fs::path rel = fs::relative(e.depth_path, src);
      fs::create_directories((fs::path(dst) / rel).parent_path());
      if (!cv::imwrite((fs::path(dst) / rel).string(), depthMetresToUnits(out.depth_m, scale))) {
        throw std::runtime_error("cannot write " + (fs::path(dst) / rel).string());
      }
    }
    const std::string calib = (fs::path(dst) / "calib_params.xml").string();
    cv::FileStorage out(calib, cv::FileStorage::WRITE);
    const cv::Mat K = (cv::Mat_<double>(3, 3) << colour.fx, 0, colour.cx, 0, colour.fy, colour.cy,
                       0, 0, 1);
    cv::Mat D(1, 5, CV_64F);
    for (int j = 0; j < 5; ++j) D.at<double>(0, j) = colour.distortion[j];
    const cv::Mat Kd = (cv::Mat_<double>(3, 3) << d.camera.fx, 0, d.camera.cx, 0, d.camera.fy,
                        d.camera.cy, 0, 0, 1);
    const Eigen::Vector3d t = d.T_c_d.translation();
    out << "RGB_intrinsic_params" << K << "RGB_distortion_coefficients" << D;
    out << "depth_registered" << 0 << "IR_intrinsic_params" << Kd;
    out << "IR_distortion_coefficients" << cv::Mat::zeros(1, 5, CV_64F);
    out << "IR_width" << w << "IR_height" << h;
    out << "Rotation" << matrixOf(d.T_c_d.linear());
    out << "Translation" << (cv::Mat_<double>(3, 1) << t.x(), t.y(), t.z());
    out << "depth_scale" << scale << "width" << colour.width << "height" << colour.height;
    out.release();
    std::printf("pplvo_unregister_dataset: %zu depth images re-projected into a %dx%d, %.0f deg "
                "depth camera; wrote %s\n",
                ds.size(), w, h, hfov, dst.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pplvo_unregister_dataset: %s\n", e.what());
    return 1;
  }
  return 0;
}

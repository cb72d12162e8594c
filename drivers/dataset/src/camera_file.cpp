// Camera files: OpenCV FileStorage calib_params.xml and the pplvo YAML camera file.
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/core/persistence.hpp>
#include <set>
#include <sstream>

#include "pplvo/dataset/dataset.h"

namespace pplvo::dataset {
namespace {

void checkIntrinsics(const DatasetCamera& cam, const std::string& path,
                     std::vector<std::string>& errors) {
  const auto& c = cam.camera;
  auto finite_nonzero = [](double v) { return std::isfinite(v) && v != 0.0; };
  if (!finite_nonzero(c.fx)) errors.push_back("fx must be finite and non-zero");
  if (!finite_nonzero(c.fy)) errors.push_back("fy must be finite and non-zero");
  if (!std::isfinite(c.cx) || !std::isfinite(c.cy)) errors.push_back("cx, cy must be finite");
  for (double d : c.distortion) {
    if (!std::isfinite(d)) errors.push_back("distortion must be finite");
  }
  if (c.width < 0 || c.height < 0) errors.push_back("width/height must be >= 0");
  if (!(cam.depth_scale > 0) || !std::isfinite(cam.depth_scale)) {
    errors.push_back("depth_scale must be positive");
  }
  if (!errors.empty()) {
    std::ostringstream s;
    s << "invalid camera file " << path << ":";
    for (const auto& e : errors) s << "\n  - " << e;
    throw DatasetError(s.str());
  }
}

/// Reads an opencv-matrix node into `out` only when its declared size is at most `max_elements`
/// values and its data holds exactly that many: `node >> mat` allocates rows x cols first, so a
/// corrupt <rows> would otherwise ask for gigabytes (found by tests/fuzz/fuzz_camera_file).
/// An absent node leaves `out` empty.
void readSmallMatrix(const cv::FileNode& node, const char* name, int max_elements, cv::Mat* out,
                     std::vector<std::string>& errors) {
  if (node.empty() || node.isNone()) return;
  if (!node.isMap()) {
    errors.push_back(std::string(name) + " must be an opencv-matrix with rows, cols, dt and data");
    return;
  }
  const cv::FileNode rows = node["rows"], cols = node["cols"], data = node["data"];
  if (!rows.isInt() || !cols.isInt() || !node["dt"].isString() || !data.isSeq()) {
    errors.push_back(std::string(name) + " must be an opencv-matrix with rows, cols, dt and data");
    return;
  }
  const long long r = static_cast<int>(rows), c = static_cast<int>(cols);
  if (r < 1 || c < 1 || r * c > max_elements) {
    errors.push_back(std::string(name) + " has " + std::to_string(r) + "x" + std::to_string(c) +
                     " values, at most " + std::to_string(max_elements) + " expected");
    return;
  }
  if (static_cast<long long>(data.size()) != r * c) {
    errors.push_back(std::string(name) + " declares " + std::to_string(r) + "x" +
                     std::to_string(c) + " values but holds " + std::to_string(data.size()));
    return;
  }
  node >> *out;
}

/// Checks of an unregistered depth camera (intrinsics, size, rigid extrinsics), appended to
/// `errors`.
void checkDepthCamera(const DepthCamera& d, std::vector<std::string>& errors) {
  const PinholeCamera& c = d.camera;
  auto finite_nonzero = [](double v) { return std::isfinite(v) && v != 0.0; };
  if (!finite_nonzero(c.fx) || !finite_nonzero(c.fy) || !std::isfinite(c.cx) ||
      !std::isfinite(c.cy)) {
    errors.push_back("depth camera: fx, fy must be finite and non-zero, cx, cy finite");
  }
  for (double v : c.distortion) {
    if (!std::isfinite(v)) errors.push_back("depth camera: distortion must be finite");
  }
  if (c.width < 0 || c.height < 0 || (c.width == 0) != (c.height == 0)) {
    errors.push_back("depth camera: width and height must both be given (> 0) or both omitted");
  }
  if (!d.T_c_d.matrix().allFinite() || !isValidPose(d.T_c_d, 1e-6)) {
    errors.push_back("depth camera: the rotation must be orthonormal with determinant 1 and the "
                     "translation finite");
  }
}

}  // namespace

DatasetCamera loadCalibParamsXml(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw DatasetError("calibration file does not exist: " + path);
  }
  std::ifstream in(path, std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in.good() && !in.eof()) throw DatasetError("cannot read calibration file " + path);
  return parseCalibParams(text, path);
}

DatasetCamera parseCalibParams(const std::string& text, const std::string& path) {
  DatasetCamera cam;
  cam.source = path;
  std::vector<std::string> errors;
  // OpenCV 4.6's FileStorage parser dereferences a null pointer on some files with NUL bytes
  // (found by tests/fuzz/fuzz_camera_file); a text calibration file has none.
  if (text.find('\0') != std::string::npos) {
    throw DatasetError("calibration file " + path + " is not text (it contains NUL bytes)");
  }
  // It also reads past the end of an XML document cut right after an attribute's '='
  // (`<a t=`, found by fuzz_camera_file). A whole XML document ends with its root's closing
  // tag, so one whose last character is not '>' is refused before the parser sees it.
  const size_t first = text.find_first_not_of(" \t\r\n");
  const size_t last = text.find_last_not_of(" \t\r\n");
  if (first != std::string::npos && text.compare(first, 5, "<?xml") == 0 && text[last] != '>') {
    throw DatasetError("calibration file " + path +
                       " is cut short: an XML file ends with its closing tag "
                       "(</opencv_storage>)");
  }
  try {
    // From memory: FileStorage picks XML, YAML or JSON from the content, as it does for a file.
    cv::FileStorage fs(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
    if (!fs.isOpened()) throw DatasetError("cannot open calibration file " + path);
    cv::Mat K, D;
    readSmallMatrix(fs["RGB_intrinsic_params"], "RGB_intrinsic_params", 9, &K, errors);
    readSmallMatrix(fs["RGB_distortion_coefficients"], "RGB_distortion_coefficients", 5, &D,
                    errors);
    if (K.empty()) {
      if (fs["RGB_intrinsic_params"].empty()) errors.push_back("missing RGB_intrinsic_params");
    } else if (K.rows != 3 || K.cols != 3) {
      errors.push_back("RGB_intrinsic_params must be 3x3");
    } else {
      K.convertTo(K, CV_64F);
      cam.camera.fx = K.at<double>(0, 0);
      cam.camera.fy = K.at<double>(1, 1);
      cam.camera.cx = K.at<double>(0, 2);
      cam.camera.cy = K.at<double>(1, 2);
    }
    if (!D.empty()) {
      if (D.total() < 4 || D.total() > 5) {
        errors.push_back("RGB_distortion_coefficients must have 4 or 5 values (k1 k2 p1 p2 k3)");
      } else {
        D.convertTo(D, CV_64F);
        D = D.reshape(1, 1);
        for (size_t i = 0; i < D.total(); ++i) cam.camera.distortion[i] = D.at<double>(0, int(i));
      }
    }
    const cv::FileNode scale = fs["depth_scale"];
    if (!scale.empty()) cam.depth_scale = static_cast<double>(scale);
    const cv::FileNode readout = fs["rolling_shutter_readout_ms"];
    if (!readout.empty()) {
      const double ms = readout.isReal() || readout.isInt() ? static_cast<double>(readout) : -1.0;
      if (!(ms >= 0 && ms < 1000)) {
        errors.push_back("rolling_shutter_readout_ms must be a number in [0, 1000)");
      } else {
        cam.camera.readout_s = 1e-3 * ms;
      }
    }
    const cv::FileNode w = fs["width"], h = fs["height"];
    if (!w.empty()) cam.camera.width = static_cast<int>(w);
    if (!h.empty()) cam.camera.height = static_cast<int>(h);
    // Unregistered depth only when the file says so: the shared datasets carry IR_*, Rotation
    // and Translation with depth that is registered.
    const cv::FileNode registered = fs["depth_registered"];
    if (!registered.empty()) {
      if (!registered.isInt() || (static_cast<int>(registered) != 0 &&
                                  static_cast<int>(registered) != 1)) {
        errors.push_back("depth_registered must be 0 or 1");
      } else if (static_cast<int>(registered) == 0) {
        DepthCamera d;
        cv::Mat Ki, Di, R, t;
        readSmallMatrix(fs["IR_intrinsic_params"], "IR_intrinsic_params", 9, &Ki, errors);
        readSmallMatrix(fs["IR_distortion_coefficients"], "IR_distortion_coefficients", 5, &Di,
                        errors);
        readSmallMatrix(fs["Rotation"], "Rotation", 9, &R, errors);
        readSmallMatrix(fs["Translation"], "Translation", 3, &t, errors);
        if (Ki.empty() || Ki.rows != 3 || Ki.cols != 3) {
          errors.push_back("depth_registered 0 needs IR_intrinsic_params (3x3)");
        } else {
          Ki.convertTo(Ki, CV_64F);
          d.camera.fx = Ki.at<double>(0, 0);
          d.camera.fy = Ki.at<double>(1, 1);
          d.camera.cx = Ki.at<double>(0, 2);
          d.camera.cy = Ki.at<double>(1, 2);
        }
        if (!Di.empty()) {
          if (Di.total() < 4 || Di.total() > 5) {
            errors.push_back("IR_distortion_coefficients must have 4 or 5 values");
          } else {
            Di.convertTo(Di, CV_64F);
            Di = Di.reshape(1, 1);
            for (size_t i = 0; i < Di.total(); ++i) d.camera.distortion[i] = Di.at<double>(0, int(i));
          }
        }
        if (R.empty() || R.rows != 3 || R.cols != 3) {
          errors.push_back("depth_registered 0 needs Rotation (3x3)");
        } else if (t.empty() || t.total() != 3) {
          errors.push_back("depth_registered 0 needs Translation (3 values, metres)");
        } else {
          R.convertTo(R, CV_64F);
          t.convertTo(t, CV_64F);
          t = t.reshape(1, 3);
          for (int r = 0; r < 3; ++r) {
            for (int c = 0; c < 3; ++c) d.T_c_d.linear()(r, c) = R.at<double>(r, c);
            d.T_c_d.translation()[r] = t.at<double>(r, 0);
          }
        }
        const cv::FileNode iw = fs["IR_width"], ih = fs["IR_height"];
        if (!iw.empty()) d.camera.width = static_cast<int>(iw);
        if (!ih.empty()) d.camera.height = static_cast<int>(ih);
        checkDepthCamera(d, errors);
        cam.depth_camera = d;
      }
    }
  } catch (const cv::Exception& e) {
    throw DatasetError("cannot parse calibration file " + path + ": " + e.what());
  }
  checkIntrinsics(cam, path, errors);
  return cam;
}

namespace {

/// The `depth_camera` map of a YAML camera file into cam->depth_camera.
void parseDepthCameraYaml(const YAML::Node& n, DatasetCamera* cam,
                          std::vector<std::string>& errors) {
  if (!n.IsMap()) {
    errors.push_back("'depth_camera' must be a map");
    return;
  }
  const std::set<std::string> known = {"width", "height",     "fx",    "fy",     "cx",
                                       "cy",    "distortion", "R_c_d", "t_c_d_m"};
  for (const auto& kv : n) {
    const std::string key = kv.first.as<std::string>("?");
    if (!known.count(key)) errors.push_back("unknown key 'depth_camera." + key + "'");
  }
  DepthCamera d;
  auto numbers = [&](const char* key, size_t min_n, size_t max_n, bool required,
                     std::vector<double>* out) {
    const YAML::Node v = n[key];
    if (!v) {
      if (required) errors.push_back(std::string("missing key 'depth_camera.") + key + "'");
      return;
    }
    try {
      if (v.IsScalar()) {
        out->push_back(v.as<double>());
      } else if (v.IsSequence()) {
        for (const auto& x : v) out->push_back(x.as<double>());
      }
    } catch (const YAML::Exception&) {
      out->clear();
    }
    if (out->size() < min_n || out->size() > max_n) {
      errors.push_back(std::string("'depth_camera.") + key + "' must be " +
                       (min_n == max_n ? std::to_string(min_n) : std::to_string(min_n) + " to " +
                                                                      std::to_string(max_n)) +
                       (max_n == 1 ? " number" : " numbers"));
      out->clear();
    }
  };
  std::vector<double> v;
  const std::pair<const char*, double*> scalars[] = {
      {"fx", &d.camera.fx}, {"fy", &d.camera.fy}, {"cx", &d.camera.cx}, {"cy", &d.camera.cy}};
  for (const auto& [key, dst] : scalars) {
    v.clear();
    numbers(key, 1, 1, true, &v);
    if (!v.empty()) *dst = v[0];
  }
  for (const auto& [key, dst] : {std::pair<const char*, int*>{"width", &d.camera.width},
                                 std::pair<const char*, int*>{"height", &d.camera.height}}) {
    if (const YAML::Node x = n[key]) {
      try {
        *dst = x.as<int>();
      } catch (const YAML::Exception&) {
        errors.push_back(std::string("'depth_camera.") + key + "' must be an integer");
      }
    }
  }
  v.clear();
  numbers("distortion", 4, 5, false, &v);
  for (size_t i = 0; i < v.size(); ++i) d.camera.distortion[i] = v[i];
  v.clear();
  numbers("R_c_d", 9, 9, true, &v);
  if (!v.empty()) {
    for (int i = 0; i < 9; ++i) d.T_c_d.linear()(i / 3, i % 3) = v[static_cast<size_t>(i)];
  }
  v.clear();
  numbers("t_c_d_m", 3, 3, true, &v);
  if (!v.empty()) d.T_c_d.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  checkDepthCamera(d, errors);
  cam->depth_camera = d;
}

}  // namespace

DatasetCamera loadCameraYaml(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw DatasetError("cannot open camera file " + path);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in.good() && !in.eof()) throw DatasetError("cannot read camera file " + path);
  return parseCameraYaml(text, path);
}

DatasetCamera parseCameraYaml(const std::string& text, const std::string& path) {
  DatasetCamera cam;
  cam.source = path;
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw DatasetError("cannot parse camera file " + path + ": " + e.what());
  }
  if (!root.IsMap()) throw DatasetError("camera file " + path + " must be a YAML map");
  std::vector<std::string> errors;
  const std::set<std::string> known = {"width",       "height",           "fx",
                                       "fy",          "cx",               "cy",
                                       "distortion",  "depth_scale",      "depth_registered",
                                       "depth_camera", "rolling_shutter_readout_ms"};
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>("?");
    if (!known.count(key)) errors.push_back("unknown key '" + key + "'");
  }
  auto getDouble = [&](const char* key, double& out, bool required) {
    const YAML::Node n = root[key];
    if (!n) {
      if (required) errors.push_back(std::string("missing key '") + key + "'");
      return;
    }
    try {
      out = n.as<double>();
    } catch (const YAML::Exception&) {
      errors.push_back(std::string("'") + key + "' must be a number");
    }
  };
  auto getInt = [&](const char* key, int& out) {
    const YAML::Node n = root[key];
    if (!n) return;
    try {
      out = n.as<int>();
    } catch (const YAML::Exception&) {
      errors.push_back(std::string("'") + key + "' must be an integer");
    }
  };
  getInt("width", cam.camera.width);
  getInt("height", cam.camera.height);
  getDouble("fx", cam.camera.fx, true);
  getDouble("fy", cam.camera.fy, true);
  getDouble("cx", cam.camera.cx, true);
  getDouble("cy", cam.camera.cy, true);
  getDouble("depth_scale", cam.depth_scale, false);
  double readout_ms = 0;
  getDouble("rolling_shutter_readout_ms", readout_ms, false);
  if (!(readout_ms >= 0 && readout_ms < 1000)) {
    errors.push_back("'rolling_shutter_readout_ms' must be in [0, 1000)");
  } else {
    cam.camera.readout_s = 1e-3 * readout_ms;
  }
  if (const YAML::Node d = root["distortion"]) {
    if (!d.IsSequence() || d.size() < 4 || d.size() > 5) {
      errors.push_back("'distortion' must be a list of 4 or 5 numbers (k1 k2 p1 p2 [k3])");
    } else {
      try {
        for (size_t i = 0; i < d.size(); ++i) cam.camera.distortion[i] = d[i].as<double>();
      } catch (const YAML::Exception&) {
        errors.push_back("'distortion' must hold numbers");
      }
    }
  }
  bool registered = true;
  if (const YAML::Node r = root["depth_registered"]) {
    try {
      registered = r.as<bool>();
    } catch (const YAML::Exception&) {
      errors.push_back("'depth_registered' must be true or false");
    }
  }
  const YAML::Node dn = root["depth_camera"];
  if (registered && dn) {
    errors.push_back("'depth_camera' is given but depth_registered is not false (say "
                     "'depth_registered: false' to register depth from that camera)");
  } else if (!registered && !dn) {
    errors.push_back("'depth_registered: false' needs a 'depth_camera' map");
  } else if (!registered) {
    parseDepthCameraYaml(dn, &cam, errors);
  }
  if (!errors.empty()) {
    std::ostringstream s;
    s << "invalid camera file " << path << ":";
    for (const auto& e : errors) s << "\n  - " << e;
    throw DatasetError(s.str());
  }
  checkIntrinsics(cam, path, errors);
  return cam;
}

}  // namespace pplvo::dataset

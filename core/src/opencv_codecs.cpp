#include "pplvo/core/opencv_codecs.h"

#include <dlfcn.h>

#include <climits>

namespace pplvo {
namespace {

#ifndef PPLVO_OPENCV_IMGCODECS_SONAME
#error "PPLVO_OPENCV_IMGCODECS_SONAME must name libopencv_imgcodecs (set by CMake)"
#endif

// OpenCV 4's exported symbols (nm -D libopencv_imgcodecs.so) of
//   cv::Mat cv::imdecode(cv::InputArray buf, int flags)
//   bool cv::imencode(const String& ext, InputArray img, std::vector<uchar>& buf,
//                     const std::vector<int>& params)
using Imdecode = cv::Mat (*)(const cv::_InputArray&, int);
using Imencode = bool (*)(const std::string&, const cv::_InputArray&, std::vector<uchar>&,
                          const std::vector<int>&);
constexpr const char* kImdecode = "_ZN2cv8imdecodeERKNS_11_InputArrayEi";
constexpr const char* kImencode =
    "_ZN2cv8imencodeERKNSt7__cxx1112basic_stringIcSt11char_traitsIcESaIcEEERKNS_11_"
    "InputArrayERSt6vectorIhSaIhEERKSB_IiSaIiEE";

struct Codecs {
  Imdecode imdecode = nullptr;
  Imencode imencode = nullptr;
  std::string error;
};

const Codecs& codecs() {
  static const Codecs loaded = [] {  // thread-safe initialisation, once per process
    Codecs c;
    // Never unloaded: OpenCV keeps thread-local state and exit handlers.
    void* handle = dlopen(PPLVO_OPENCV_IMGCODECS_SONAME, RTLD_NOW | RTLD_LOCAL | RTLD_NODELETE);
    if (!handle) {
      const char* e = dlerror();
      c.error = std::string("OpenCV's image codecs are unavailable: cannot load ") +
                PPLVO_OPENCV_IMGCODECS_SONAME + " (" + (e ? e : "unknown error") + ")";
      return c;
    }
    c.imdecode = reinterpret_cast<Imdecode>(dlsym(handle, kImdecode));
    c.imencode = reinterpret_cast<Imencode>(dlsym(handle, kImencode));
    if (!c.imdecode || !c.imencode) {
      c.imdecode = nullptr;
      c.imencode = nullptr;
      c.error = std::string("OpenCV's image codecs are unavailable: ") +
                PPLVO_OPENCV_IMGCODECS_SONAME + " lacks cv::imdecode or cv::imencode";
    }
    return c;
  }();
  return loaded;
}

}  // namespace

cv::Mat openCvImdecode(const uint8_t* data, size_t size, int flags) {
  const Codecs& c = codecs();
  if (!c.imdecode) throw OpenCvCodecsUnavailable(c.error);
  if (size > size_t(INT_MAX)) return cv::Mat();  // OpenCV's buffer is a single cv::Mat row
  const cv::Mat buf(1, static_cast<int>(size), CV_8U, const_cast<uint8_t*>(data));
  return c.imdecode(buf, flags);
}

bool openCvImencode(const std::string& ext, const cv::Mat& image, std::vector<uint8_t>& buf,
                    const std::vector<int>& params) {
  const Codecs& c = codecs();
  if (!c.imencode) throw OpenCvCodecsUnavailable(c.error);
  return c.imencode(ext, image, buf, params);
}

bool openCvCodecsLoaded() {
  void* h = dlopen(PPLVO_OPENCV_IMGCODECS_SONAME, RTLD_NOW | RTLD_NOLOAD);
  if (!h) return false;
  dlclose(h);  // RTLD_NOLOAD took a reference
  return true;
}

}  // namespace pplvo

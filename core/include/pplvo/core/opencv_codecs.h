#pragma once
/// OpenCV's image codecs (cv::imdecode, cv::imencode), loaded on first use.
///
/// pplvo decodes PNG and JPEG frames itself (pplvo_dataset) and sends raw images on the bus by
/// default; OpenCV's codecs are only needed for unusual files (palette or interlaced PNG,
/// progressive JPEG, BMP, TIFF, ...) and for the optional PNG/JPEG message encodings. Linking
/// libopencv_imgcodecs pulls about 120 shared libraries (GDAL, HDF5, poppler, video codecs)
/// whose loading and initialisers cost every process 0.15-0.2 s at start-up, more than a
/// 100-frame run's whole decoding. Loading it when first needed takes that cost off every
/// ordinary run. The library loaded is the one pplvo was built against (its soname).
#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>
#include <vector>

namespace pplvo {

/// libopencv_imgcodecs could not be loaded (not installed, or another version).
struct OpenCvCodecsUnavailable : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// cv::imdecode of `size` bytes. Loads the library at the first call (thread-safe). Throws
/// OpenCvCodecsUnavailable when it cannot be loaded, and what cv::imdecode throws
/// (cv::Exception); an empty Mat when OpenCV cannot decode the bytes.
cv::Mat openCvImdecode(const uint8_t* data, size_t size, int flags);

/// cv::imencode(ext, image, buf, params), with the same loading and errors as openCvImdecode.
bool openCvImencode(const std::string& ext, const cv::Mat& image, std::vector<uint8_t>& buf,
                    const std::vector<int>& params = {});

/// Whether libopencv_imgcodecs is loaded into this process (linked or loaded by the above).
bool openCvCodecsLoaded();

}  // namespace pplvo

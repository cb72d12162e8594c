// libFuzzer harness: the dataset camera files on any bytes, read from memory (the loaders'
// text entry points, which loadCalibParamsXml / loadCameraYaml call after reading the file):
// as an OpenCV FileStorage calib_params.xml (parseCalibParams; FileStorage picks XML, YAML or
// JSON from the content) and as the pplvo YAML camera file (parseCameraYaml). A DatasetError
// is the documented result of a bad file; a crash, a sanitizer report or any other exception
// is a finding.
#include <cstddef>
#include <cstdint>
#include <string>

#include "pplvo/dataset/dataset.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace pplvo::dataset;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    parseCalibParams(text, "fuzz.xml");
  } catch (const DatasetError&) {
  }
  try {
    parseCameraYaml(text, "fuzz.yaml");
  } catch (const DatasetError&) {
  }
  return 0;
}

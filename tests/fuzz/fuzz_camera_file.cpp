// libFuzzer harness: the dataset camera files on any bytes. The input is written to a
// temporary file (the readers take a path) and read both as an OpenCV FileStorage
// calib_params.xml (loadCalibParamsXml; FileStorage picks XML, YAML or JSON from the content)
// and as the pplvo YAML camera file (loadCameraYaml). A DatasetError is the documented
// result of a bad file; a crash, a sanitizer report or any other exception is a finding.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>

#include "pplvo/dataset/dataset.h"

namespace {

std::string tempPath(const char* suffix) {
  return "/tmp/pplvo-fuzz-camera-" + std::to_string(getpid()) + suffix;
}

void writeFile(const std::string& path, const uint8_t* data, size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace pplvo::dataset;
  static const std::string xml = tempPath(".xml");
  static const std::string yaml = tempPath(".yaml");
  writeFile(xml, data, size);
  try {
    loadCalibParamsXml(xml);
  } catch (const DatasetError&) {
  }
  writeFile(yaml, data, size);
  try {
    loadCameraYaml(yaml);
  } catch (const DatasetError&) {
  }
  std::remove(xml.c_str());
  std::remove(yaml.c_str());
  return 0;
}

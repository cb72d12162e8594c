// libFuzzer harness: dataset index files (rgb.txt, depth.txt lines) and stamp texts on any
// bytes: parseIndexFile, stampTextToUtime and associateStamps of what parses. Malformed lines
// are counted values; a crash, a sanitizer report or an exception is a finding.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "pplvo/dataset/dataset.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace pplvo::dataset;
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::istringstream in(text);
  const IndexFile index = parseIndexFile(in);
  std::vector<double> a, b;
  for (size_t i = 0; i < index.entries.size(); ++i) {
    stampTextToUtime(index.entries[i].stamp_text);
    (i % 2 ? a : b).push_back(index.entries[i].stamp);
  }
  stampTextToUtime(text);
  associateStamps(a, b);
  return 0;
}

// libFuzzer harness: the pipeline's YAML configuration (parsePipelineConfig, the text entry
// point of loadPipelineConfig) on any bytes. A ConfigError listing the problems is the
// documented result of a bad file; a crash, a sanitizer report or any other exception is a
// finding. Options that load are dumped and parsed back (the dump promises to round-trip).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "pplvo/pipeline/pipeline_config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace pplvo::pipeline;
  const std::string text(reinterpret_cast<const char*>(data), size);
  PipelineOptions options;
  try {
    options = parsePipelineConfig(text);
  } catch (const pplvo::ConfigError&) {
    return 0;
  }
  const PipelineOptions again = parsePipelineConfig(dumpPipelineConfig(options));
  if (!diffPipelineOptions(options, again).empty()) std::abort();  // the dump lost a value
  return 0;
}

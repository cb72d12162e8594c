// libFuzzer harness: the pipeline's YAML configuration (parsePipelineConfig, the text entry
// point of loadPipelineConfig) on any bytes. A ConfigError listing the problems is the
// documented result of a bad file; a crash, a sanitizer report or any other exception is a
// finding. Options that load are dumped and parsed back (the dump promises to round-trip).
//
// Speed: the round trip (a ~19 KB documented dump, parsed again, both flattened and compared)
// cost about four times the parse of the input under ASan. It is a function of the option
// values alone (the dump is written from them; every comment comes from the schema), so each
// set of values is checked once: a mutation that changes only comments, spacing, key order
// or a value back to one seen before is not dumped again. The values are remembered by a
// 64-bit hash of their flattened text (every key with its shortest round-tripping value
// text, so equal texts mean equal options); a collision, which could only skip a check, is
// unlikely below 2^32 distinct sets.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <string>
#include <unordered_set>

#include "pplvo/pipeline/pipeline_config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace pplvo::pipeline;
  static std::unordered_set<uint64_t> checked;
  const std::string text(reinterpret_cast<const char*>(data), size);
  PipelineOptions options;
  try {
    options = parsePipelineConfig(text);
  } catch (const pplvo::ConfigError&) {
    return 0;
  }
  std::string values;
  for (const auto& entry : flattenPipelineConfig(options)) {
    values += entry.key;
    values += '=';
    values += entry.value;
    values += '\n';
  }
  if (!checked.insert(std::hash<std::string>{}(values)).second) return 0;
  const PipelineOptions again = parsePipelineConfig(dumpPipelineConfig(options));
  if (!diffPipelineOptions(options, again).empty()) std::abort();  // the dump lost a value
  return 0;
}

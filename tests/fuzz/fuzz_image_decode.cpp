// libFuzzer harness: msgs::decodeImage, the decoder of every image plane on the bus (zlib
// label images and depth planes, raw planes, PNG and JPEG payloads), on any message fields:
// the first 9 bytes give width, height (little-endian int32) and encoding, the rest is the
// payload. The size field is usually the payload's length and sometimes the next 4 bytes'
// value (a lying header). A MessageError is the documented result (a counted skip in a
// node); a crash, a sanitizer report or any other exception is a finding.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <pplvo_msgs/image_t.hpp>

#include "pplvo/msgs/convert.h"

namespace {

int32_t readInt32(const uint8_t* p) {
  uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | p[i];
  int32_t out;
  std::memcpy(&out, &v, sizeof out);
  return out;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 9) return 0;
  pplvo_msgs::image_t msg;
  msg.width = readInt32(data);
  msg.height = readInt32(data + 4);
  msg.encoding = static_cast<int8_t>(data[8]);
  data += 9;
  size -= 9;
  // Encodings 0..11 are defined; bit 7 set keeps the raw value (unknown encodings).
  if (!(msg.encoding & 0x80)) msg.encoding = static_cast<int8_t>(msg.encoding % 12);
  msg.data.assign(data, data + size);
  msg.size = static_cast<int32_t>(size);
  if (size >= 4 && (data[0] & 0x0f) == 0x0f) msg.size = readInt32(data);
  try {
    const cv::Mat m = pplvo::msgs::decodeImage(msg);
    if (!m.empty()) {
      volatile uint8_t sink = m.data[m.total() * m.elemSize() - 1];  // the whole image exists
      (void)sink;
    }
  } catch (const pplvo::msgs::MessageError&) {
  }
  return 0;
}

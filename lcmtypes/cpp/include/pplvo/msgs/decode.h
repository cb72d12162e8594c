#pragma once
/// Decoding LCM packets that may be anything: a packet on a shared network, a cut log, a fuzzer's
/// input. The generated decoders bound every length field by the bytes left in the packet
/// (cmake/HardenLcmDecoders.cmake), so a corrupt packet fails to decode instead of throwing or
/// allocating gigabytes; decodeMessage() also catches whatever an allocation may still throw.
#include <climits>
#include <cstddef>
#include <exception>
#include <string>

namespace pplvo::msgs {

/// Decodes `size` bytes as one MessageT into `msg`. Returns an empty string on success, else why
/// the bytes are not a MessageT (wrong type hash, lengths beyond the packet, truncated). Never
/// throws (but for std::bad_alloc while building the error text). Bytes after the message are
/// ignored, as lcm::LCM's typed subscriptions do.
template <class MessageT>
std::string decodeMessage(const void* data, size_t size, MessageT* msg) {
  if (size > static_cast<size_t>(INT_MAX)) {
    return std::string(MessageT::getTypeName()) + ": packet of " + std::to_string(size) +
           " bytes is too large";
  }
  try {
    if (msg->decode(data, 0, static_cast<int>(size)) < 0) {
      return "not a valid " + std::string(MessageT::getTypeName()) + " (" + std::to_string(size) +
             " bytes)";
    }
    return "";
  } catch (const std::exception& e) {
    return std::string(MessageT::getTypeName()) + ": " + e.what();
  }
}

}  // namespace pplvo::msgs

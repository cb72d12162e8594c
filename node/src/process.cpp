#include "pplvo/node/process.h"

#include <cstdarg>

namespace pplvo::node {

int argsExitCode(const std::string& name, bool help, const std::vector<std::string>& errors,
                 const std::string& usage) {
  if (help) {
    std::fputs(usage.c_str(), stdout);
    return 0;
  }
  if (errors.empty()) return kRun;
  for (const std::string& e : errors) std::fprintf(stderr, "%s: %s\n", name.c_str(), e.c_str());
  std::fputs(usage.c_str(), stdout);
  return 2;
}

std::string format(const char* fmt, ...) {
  va_list args;
  va_start(args, fmt);
  va_list copy;
  va_copy(copy, args);
  const int n = std::vsnprintf(nullptr, 0, fmt, copy);
  va_end(copy);
  std::string s(n > 0 ? static_cast<size_t>(n) : 0, '\0');
  if (n > 0) std::vsnprintf(s.data(), s.size() + 1, fmt, args);
  va_end(args);
  return s;
}

}  // namespace pplvo::node

#include "pplvo/core/args.h"

#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <type_traits>

namespace pplvo {
namespace {

std::string formatNumber(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

/// "expected an integer >= 0", "... in [1, 100]", "... <= 5" or just "expected an integer".
template <typename T>
std::string rangeText(const char* what, T min, T max, T lowest, T highest) {
  std::string s = std::string("expected ") + what;
  const bool has_min = min != lowest, has_max = max != highest;
  auto str = [](T v) {
    if constexpr (std::is_floating_point_v<T>) return formatNumber(v);
    else return std::to_string(v);
  };
  if (has_min && has_max) s += " in [" + str(min) + ", " + str(max) + "]";
  else if (has_min) s += " >= " + str(min);
  else if (has_max) s += " <= " + str(max);
  return s;
}

template <typename T>
ArgParser::Handler boundedHandler(const std::string& name, T* out, T min, T max, const char* what,
                                  bool (*parse)(const std::string&, T*), T lowest, T highest) {
  return [=](const std::string& value) -> std::string {
    T v{};
    if (!parse(value, &v) || v < min || v > max) {
      return name + ": " + rangeText(what, min, max, lowest, highest) + ", got '" + value + "'";
    }
    *out = v;
    return "";
  };
}

}  // namespace

std::vector<std::string> argsFromArgv(int argc, const char* const* argv) {
  std::vector<std::string> out;
  for (int i = 1; i < argc; ++i) out.emplace_back(argv[i]);
  return out;
}

/// strtod/strtoll skip leading white space; a strict parse does not.
static bool startsClean(const std::string& text) {
  return !text.empty() && !std::isspace(static_cast<unsigned char>(text[0]));
}

bool parseDouble(const std::string& text, double* out) {
  if (!startsClean(text)) return false;
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || !std::isfinite(v) || errno == ERANGE) return false;
  *out = v;
  return true;
}

bool parseInt64(const std::string& text, int64_t* out) {
  if (!startsClean(text)) return false;
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (end != text.c_str() + text.size() || errno == ERANGE) return false;
  *out = static_cast<int64_t>(v);
  return true;
}

bool parseInt(const std::string& text, int* out) {
  int64_t v = 0;
  if (!parseInt64(text, &v) || v < std::numeric_limits<int>::min() ||
      v > std::numeric_limits<int>::max()) {
    return false;
  }
  *out = static_cast<int>(v);
  return true;
}

bool parseBool(const std::string& text, bool* out) {
  if (text == "true" || text == "1" || text == "yes" || text == "on") {
    *out = true;
    return true;
  }
  if (text == "false" || text == "0" || text == "no" || text == "off") {
    *out = false;
    return true;
  }
  return false;
}

bool progressEnabled(const std::vector<std::string>& args, bool parsed) {
  for (const std::string& a : args) {
    if (a == "--progress" || a == "--no-progress") return parsed;
  }
  return ::isatty(STDERR_FILENO) == 1;
}

ArgParser& ArgParser::add(Spec spec) {
  specs_.push_back(std::move(spec));
  return *this;
}

const ArgParser::Spec* ArgParser::find(const std::string& name) const {
  // Later declarations of the same name win (a process may override a shared default).
  for (auto it = specs_.rbegin(); it != specs_.rend(); ++it) {
    if (it->name == name) return &*it;
  }
  return nullptr;
}

std::vector<std::string> ArgParser::names() const {
  std::vector<std::string> out;
  for (const Spec& s : specs_) out.push_back(s.name);
  return out;
}

ArgParser& ArgParser::flag(const std::string& name, bool* out, bool value_when_given) {
  return flag(name, [out, value_when_given] { *out = value_when_given; });
}

ArgParser& ArgParser::flag(const std::string& name, std::function<void()> action) {
  Spec s;
  s.name = name;
  s.is_flag = true;
  s.on_flag = std::move(action);
  return add(std::move(s));
}

ArgParser& ArgParser::option(const std::string& name, Handler handler) {
  Spec s;
  s.name = name;
  s.on_value = std::move(handler);
  return add(std::move(s));
}

ArgParser& ArgParser::option(const std::string& name, std::string* out) {
  return option(name, [out](const std::string& v) -> std::string {
    *out = v;
    return "";
  });
}

ArgParser& ArgParser::option(const std::string& name, int* out, int min, int max) {
  return option(name, boundedHandler<int>(name, out, min, max, "an integer", &parseInt,
                                          std::numeric_limits<int>::min(),
                                          std::numeric_limits<int>::max()));
}

ArgParser& ArgParser::option(const std::string& name, int64_t* out, int64_t min, int64_t max) {
  return option(name, boundedHandler<int64_t>(name, out, min, max, "an integer", &parseInt64,
                                              std::numeric_limits<int64_t>::min(),
                                              std::numeric_limits<int64_t>::max()));
}

ArgParser& ArgParser::option(const std::string& name, double* out, double min, double max) {
  return option(name, boundedHandler<double>(name, out, min, max, "a number", &parseDouble,
                                             -std::numeric_limits<double>::infinity(),
                                             std::numeric_limits<double>::infinity()));
}

ArgParser& ArgParser::option(const std::string& name, bool* out) {
  return option(name, [name, out](const std::string& v) -> std::string {
    if (parseBool(v, out)) return "";
    return name + ": expected true/false, 1/0, yes/no or on/off, got '" + v + "'";
  });
}

bool ArgParser::parse(const std::vector<std::string>& args) {
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg == "-h" || arg == "--help") {
      help_ = true;
      continue;
    }
    std::string key = arg, value;
    bool has_value = false;
    if (const auto eq = arg.find('='); arg.rfind("--", 0) == 0 && eq != std::string::npos) {
      key = arg.substr(0, eq);
      value = arg.substr(eq + 1);
      has_value = true;
    }
    const Spec* spec = find(key);
    if (!spec) {
      errors_.push_back("unknown option '" + arg + "'");
      continue;
    }
    given_.insert(key);
    if (spec->is_flag) {
      if (has_value) {
        errors_.push_back(key + " takes no value");
      } else {
        spec->on_flag();
      }
      continue;
    }
    if (!has_value) {
      if (i + 1 >= args.size()) {
        errors_.push_back(key + " needs a value");
        continue;
      }
      value = args[++i];
    }
    std::string error = spec->on_value(value);
    if (!error.empty()) errors_.push_back(std::move(error));
  }
  return ok();
}

}  // namespace pplvo

#pragma once
/// Command-line parsing shared by the pplvo processes (pplvo-player, pplvo-logger,
/// pplvo-camera, pplvo-depth-filter, and new ones). No LCM, no I/O except progressEnabled()'s
/// isatty(). Every problem is collected as one readable string (nothing is thrown), so a main
/// can print them all at once, then its usage, and exit 2.
///
/// Accepted forms, for every option declared with a value:
///   --key value      the next argument is taken verbatim (so "--rate -1" and "--x --y" work)
///   --key=value      split at the first '=' (only for arguments starting with "--")
/// Flags (declared with flag()) take no value; "--flag=x" is an error. "-h" and "--help" set
/// help() (and are never errors). Anything not declared (also positional arguments) is an
/// "unknown option 'ARG'" error. Later occurrences override earlier ones. Typed values are
/// strict: the whole text must parse ("12abc" is an error), numbers must be finite.
///
/// Use in a new process (options struct `o` with documented defaults):
///
///   pplvo::ArgParser p;
///   p.option("--lcm-url", &o.lcm_url)
///       .option("--max-frames", &o.max_frames, int64_t{0})        // integer >= 0
///       .option("--window", &o.window, 1, 100)                      // integer in [1, 100]
///       .option("--rate", &o.rate, 0.0)                             // number >= 0
///       .option("--mode", [&](const std::string& v) -> std::string {  // custom: "" = ok
///         return parseMode(v, &o.mode) ? "" : "--mode: a or b, not '" + v + "'";
///       })
///       .flag("--loop", &o.loop)
///       .flag("--progress", &o.progress)
///       .flag("--no-progress", &o.progress, false);
///   const std::vector<std::string> args = pplvo::argsFromArgv(argc, argv);
///   p.parse(args);
///   if (p.help()) { print usage; return 0; }
///   if (o.window_required && ...) p.addError("--x is required");   // checks after parsing
///   if (!p.ok()) { for (auto& e : p.errors()) fprintf(stderr, "name: %s\n", e.c_str()); return 2; }
///   o.progress = pplvo::progressEnabled(args, o.progress);        // default: stderr is a tty
#include <cstdint>
#include <functional>
#include <limits>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace pplvo {

/// argv without the program name.
std::vector<std::string> argsFromArgv(int argc, const char* const* argv);

/// Strict conversions: true only when the whole text is one value (no trailing characters;
/// numbers finite; integers in range). `out` is unchanged on failure.
bool parseDouble(const std::string& text, double* out);
bool parseInt64(const std::string& text, int64_t* out);
bool parseInt(const std::string& text, int* out);
/// true/false, 1/0, yes/no, on/off (lower case).
bool parseBool(const std::string& text, bool* out);

/// The --progress / --no-progress convention of the processes: when either flag is among
/// `args`, returns `parsed` (the value the parser gave); otherwise whether stderr is a terminal.
bool progressEnabled(const std::vector<std::string>& args, bool parsed);

/// Declarative parser: declare options bound to variables, then parse() once.
class ArgParser {
 public:
  /// Custom conversion: returns "" when the value was accepted, else the complete error text
  /// (by convention starting with the option name).
  using Handler = std::function<std::string(const std::string& value)>;

  /// A flag without value: sets *out = value_when_given (use false for "--no-x").
  ArgParser& flag(const std::string& name, bool* out, bool value_when_given = true);
  /// A flag that runs `action` when given.
  ArgParser& flag(const std::string& name, std::function<void()> action);

  ArgParser& option(const std::string& name, std::string* out);
  /// Integers / numbers with optional inclusive bounds; out of range or malformed values are
  /// errors ("--start: expected an integer >= 0, got '-2'") and leave *out unchanged.
  ArgParser& option(const std::string& name, int* out, int min = std::numeric_limits<int>::min(),
                    int max = std::numeric_limits<int>::max());
  ArgParser& option(const std::string& name, int64_t* out,
                    int64_t min = std::numeric_limits<int64_t>::min(),
                    int64_t max = std::numeric_limits<int64_t>::max());
  ArgParser& option(const std::string& name, double* out,
                    double min = -std::numeric_limits<double>::infinity(),
                    double max = std::numeric_limits<double>::infinity());
  /// A boolean value (parseBool): "--compress on", "--compress=false".
  ArgParser& option(const std::string& name, bool* out);
  ArgParser& option(const std::string& name, Handler handler);

  /// Parses `args` (no program name); may be called once per parser. Returns ok().
  bool parse(const std::vector<std::string>& args);

  /// "-h" or "--help" was given.
  bool help() const { return help_; }
  /// Whether option `name` appeared (with or without a valid value).
  bool given(const std::string& name) const { return given_.count(name) > 0; }
  /// Adds a problem found after parsing (required option missing, options that disagree), so
  /// everything is reported together.
  void addError(std::string error) { errors_.push_back(std::move(error)); }
  bool ok() const { return errors_.empty(); }
  /// Every problem, in command-line order (then addError() order).
  const std::vector<std::string>& errors() const { return errors_; }
  /// Declared names, in declaration order (for tests and usage checks).
  std::vector<std::string> names() const;

 private:
  struct Spec {
    std::string name;
    bool is_flag = false;
    std::function<void()> on_flag;
    Handler on_value;
  };
  ArgParser& add(Spec spec);
  const Spec* find(const std::string& name) const;

  std::vector<Spec> specs_;
  std::vector<std::string> errors_;
  std::set<std::string> given_;
  bool help_ = false;
};

}  // namespace pplvo

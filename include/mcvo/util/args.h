// Command-line parsing for the `mcvo` subcommands. Options are declared with
// a destination, a help line, and whether they are required; parsing throws
// UsageError (exit code 2) with a one-line message on any misuse.
//
//   ArgParser args("mcvo eval", "Scores an estimated trajectory against ground truth.");
//   std::string gt; args.AddString("gt", &gt, "FILE", "ground-truth trajectory", /*required=*/true);
//   if (!args.Parse(argc, argv)) return 0;   // --help was printed
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace mcvo {

class ArgParser {
 public:
  ArgParser(std::string usage_name, std::string summary);

  void AddString(const std::string& name, std::string* value, const std::string& meta,
                 const std::string& help, bool required = false);
  void AddInt(const std::string& name, int* value, const std::string& help, bool required = false);
  void AddDouble(const std::string& name, double* value, const std::string& help, bool required = false);
  // A flag without a value: --name sets *value to true.
  void AddFlag(const std::string& name, bool* value, const std::string& help);
  // Free text appended to --help (examples, notes).
  void AddEpilog(const std::string& text) { epilog_ += text; }

  // Parses argv[0..argc) (the arguments after the subcommand name). Accepts
  // "--name value" and "--name=value". Returns false when --help or -h was
  // given (the help has been printed to stdout). Throws UsageError.
  bool Parse(int argc, const char* const* argv);
  // True when the option was given on the command line.
  bool WasGiven(const std::string& name) const;
  std::string Help() const;

 private:
  struct Option {
    std::string name;
    std::string meta;
    std::string help;
    bool required = false;
    bool is_flag = false;
    bool given = false;
    std::string default_text;
    std::function<void(const std::string&)> set;
  };
  Option* Find(const std::string& name);
  std::string usage_name_;
  std::string summary_;
  std::string epilog_;
  std::vector<Option> options_;
};

}  // namespace mcvo

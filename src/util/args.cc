#include "mcvo/util/args.h"

#include <cmath>
#include <iostream>
#include <sstream>

#include "mcvo/util/error.h"
#include "mcvo/util/strings.h"

namespace mcvo {

ArgParser::ArgParser(std::string usage_name, std::string summary)
    : usage_name_(std::move(usage_name)), summary_(std::move(summary)) {}

void ArgParser::AddString(const std::string& name, std::string* value, const std::string& meta,
                          const std::string& help, bool required) {
  options_.push_back({name, meta, help, required, false, false, *value,
                      [value](const std::string& text) { *value = text; }});
}

void ArgParser::AddInt(const std::string& name, int* value, const std::string& help, bool required) {
  options_.push_back({name, "N", help, required, false, false, std::to_string(*value),
                      [value, name](const std::string& text) {
                        const std::optional<int64_t> parsed = ParseInt64(text);
                        if (!parsed || *parsed < INT32_MIN || *parsed > INT32_MAX)
                          throw UsageError("--" + name + ": expected an integer, got '" + text + "'");
                        *value = static_cast<int>(*parsed);
                      }});
}

void ArgParser::AddDouble(const std::string& name, double* value, const std::string& help, bool required) {
  options_.push_back(
      {name, "X", help, required, false, false, FormatDouble(*value), [value, name](const std::string& text) {
         const std::optional<double> parsed = ParseDouble(text);
         if (!parsed || !std::isfinite(*parsed))
           throw UsageError("--" + name + ": expected a finite number, got '" + text + "'");
         *value = *parsed;
       }});
}

void ArgParser::AddFlag(const std::string& name, bool* value, const std::string& help) {
  options_.push_back(
      {name, "", help, false, true, false, "", [value](const std::string&) { *value = true; }});
}

ArgParser::Option* ArgParser::Find(const std::string& name) {
  for (Option& option : options_) {
    if (option.name == name) return &option;
  }
  return nullptr;
}

bool ArgParser::WasGiven(const std::string& name) const {
  for (const Option& option : options_) {
    if (option.name == name) return option.given;
  }
  return false;
}

bool ArgParser::Parse(int argc, const char* const* argv) {
  for (int i = 0; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::cout << Help();
      return false;
    }
    if (arg.rfind("--", 0) != 0)
      throw UsageError(std::string("unexpected argument '" + arg + "' (see --help)"));
    std::string name = arg.substr(2);
    std::optional<std::string> inline_value;
    if (const size_t eq = name.find('='); eq != std::string::npos) {
      inline_value = name.substr(eq + 1);
      name = name.substr(0, eq);
    }
    Option* option = Find(name);
    if (option == nullptr) throw UsageError(std::string("unknown option --" + name + " (see --help)"));
    if (option->given) throw UsageError(std::string("--" + name + " given twice"));
    option->given = true;
    if (option->is_flag) {
      if (inline_value) throw UsageError(std::string("--" + name + " takes no value"));
      option->set("");
      continue;
    }
    if (!inline_value) {
      if (i + 1 >= argc) throw UsageError(std::string("--" + name + " needs a value"));
      inline_value = argv[++i];
    }
    option->set(*inline_value);
  }
  for (const Option& option : options_) {
    if (option.required && !option.given)
      throw UsageError(std::string("--" + option.name + " is required (see --help)"));
  }
  return true;
}

std::string ArgParser::Help() const {
  std::ostringstream out;
  out << "usage: " << usage_name_ << " [options]\n\n" << summary_ << "\n\noptions:\n";
  for (const Option& option : options_) {
    std::string left = "  --" + option.name + (option.meta.empty() ? "" : " " + option.meta);
    if (left.size() < 28)
      left.resize(28, ' ');
    else
      left += "\n" + std::string(28, ' ');
    out << left << option.help;
    if (option.required)
      out << " (required)";
    else if (!option.is_flag && !option.default_text.empty())
      out << " [default: " << option.default_text << "]";
    out << "\n";
  }
  out << "  --help                    print this help and exit\n";
  if (!epilog_.empty()) out << "\n" << epilog_ << (epilog_.back() == '\n' ? "" : "\n");
  return out.str();
}

}  // namespace mcvo

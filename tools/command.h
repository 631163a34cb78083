// Subcommand registry of the `mcvo` executable. Each tools/<name>_command.cc
// registers itself with a static McvoCommandRegistrar, so adding a command
// touches no other file. Commands are listed in name order.
#pragma once

#include <functional>
#include <map>
#include <string>

namespace mcvo::tools {

struct CommandInfo {
  std::string summary;
  // Runs the command with the arguments after its name. Returns the exit code;
  // may throw UsageError (exit 2), InputError (exit 3) or anything else (exit 1).
  std::function<int(int argc, const char* const* argv)> run;
};

std::map<std::string, CommandInfo>& CommandRegistry();

struct CommandRegistrar {
  CommandRegistrar(const std::string& name, CommandInfo info) { CommandRegistry()[name] = std::move(info); }
};

}  // namespace mcvo::tools

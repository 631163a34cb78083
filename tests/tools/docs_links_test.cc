// The documentation holds to account: every relative link of README.md,
// CHANGELOG.md, docs/*.md and results/README.md names a file that exists;
// every `mcvo` command in a ```sh block of README.md names a subcommand and
// only options that its --help lists; .ci/run runs exactly the README's two
// set-up and test commands; results/README.md lists every results file.
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tools/run_mcvo.h"

namespace mcvo::test {
namespace {

namespace fs = std::filesystem;

const fs::path kSource = MCVO_SOURCE_DIR;

std::vector<std::string> ReadLines(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  std::string line;
  while (std::getline(in, line)) lines.push_back(line);
  return lines;
}

std::string Relative(const fs::path& path) { return fs::relative(path, kSource).generic_string(); }

// The Markdown files whose links are checked.
std::vector<fs::path> DocumentFiles() {
  std::vector<fs::path> files = {kSource / "README.md", kSource / "results" / "README.md"};
  if (fs::exists(kSource / "CHANGELOG.md")) files.push_back(kSource / "CHANGELOG.md");
  for (const auto& entry : fs::directory_iterator(kSource / "docs")) {
    if (entry.is_regular_file() && entry.path().extension() == ".md") files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

// A line without its inline code spans (`...`): a link inside one is text.
std::string WithoutCodeSpans(const std::string& line) {
  std::string out;
  bool in_code = false;
  for (char c : line) {
    if (c == '`') {
      in_code = !in_code;
      continue;
    }
    if (!in_code) out += c;
  }
  return out;
}

struct Link {
  int line = 0;
  std::string target;
};

// Inline links [text](target "title") and reference definitions [id]: target,
// outside fenced code blocks.
std::vector<Link> LinksOf(const fs::path& file) {
  static const std::regex inline_link(R"(\]\(\s*<?([^)\s>]+)>?(?:\s+"[^"]*")?\s*\))");
  static const std::regex reference(R"(^\s{0,3}\[[^\]]+\]:\s*<?([^\s>]+)>?)");
  std::vector<Link> links;
  bool in_fence = false;
  const std::vector<std::string> lines = ReadLines(file);
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string& raw = lines[i];
    const size_t first = raw.find_first_not_of(" \t");
    if (first != std::string::npos && raw.compare(first, 3, "```") == 0) {
      in_fence = !in_fence;
      continue;
    }
    if (in_fence) continue;
    const std::string line = WithoutCodeSpans(raw);
    for (std::sregex_iterator it(line.begin(), line.end(), inline_link), end; it != end; ++it) {
      links.push_back({static_cast<int>(i + 1), (*it)[1].str()});
    }
    std::smatch m;
    if (std::regex_search(line, m, reference)) links.push_back({static_cast<int>(i + 1), m[1].str()});
  }
  return links;
}

bool IsExternal(const std::string& target) {
  static const std::regex scheme(R"(^[A-Za-z][A-Za-z0-9+.-]*:)");
  return std::regex_search(target, scheme);  // http:, https:, mailto:, ...
}

TEST(DocsLinks, EveryRelativeLinkNamesAnExistingFile) {
  const fs::path shared = fs::weakly_canonical(fs::path(MCVO_SHARED_DIR));
  const bool have_shared = fs::is_directory(shared);
  int checked = 0;
  std::vector<std::string> broken;
  for (const fs::path& file : DocumentFiles()) {
    for (const Link& link : LinksOf(file)) {
      if (IsExternal(link.target)) continue;
      std::string target = link.target.substr(0, link.target.find('#'));
      if (target.empty()) continue;  // an anchor in the same file
      const fs::path resolved = fs::weakly_canonical(file.parent_path() / target);
      const std::string resolved_text = resolved.generic_string();
      if (resolved_text.rfind(shared.generic_string(), 0) == 0 && !have_shared) continue;
      ++checked;
      if (!fs::exists(resolved)) {
        broken.push_back(Relative(file) + ":" + std::to_string(link.line) + ": broken link '" + link.target +
                         "' (" + resolved_text + " does not exist)");
      }
    }
  }
  std::string report;
  for (const std::string& line : broken) report += line + "\n";
  EXPECT_TRUE(broken.empty()) << report;
  EXPECT_GT(checked, 20) << "the link parser found almost no links";
}

// The commands of README.md's ```sh blocks, continuation lines joined, each
// with the line it starts on.
struct Command {
  int line = 0;
  std::string text;
};

std::vector<Command> ShellCommands(const fs::path& file) {
  std::vector<Command> commands;
  const std::vector<std::string> lines = ReadLines(file);
  bool in_sh = false;
  std::string pending;
  int pending_line = 0;
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string& line = lines[i];
    if (!in_sh) {
      if (line.rfind("```sh", 0) == 0) in_sh = true;
      continue;
    }
    if (line.rfind("```", 0) == 0) {
      in_sh = false;
      continue;
    }
    std::string text = line;
    const size_t comment = text.find(" #");
    if (comment != std::string::npos) text.erase(comment);
    if (pending.empty()) pending_line = static_cast<int>(i + 1);
    const bool continues = !text.empty() && text.back() == '\\';
    if (continues) text.pop_back();
    pending += text + " ";
    if (!continues) {
      commands.push_back({pending_line, pending});
      pending.clear();
    }
  }
  return commands;
}

std::vector<std::string> Words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> words;
  std::string word;
  while (in >> word) words.push_back(word);
  return words;
}

// Splits a command line at &&, || , ; and | into simple commands.
std::vector<std::string> SimpleCommands(const std::string& text) {
  static const std::regex separator(R"(\s*(?:&&|\|\||;|\|)\s*)");
  std::vector<std::string> out;
  for (std::sregex_token_iterator it(text.begin(), text.end(), separator, -1), end; it != end; ++it) {
    out.push_back(it->str());
  }
  return out;
}

bool HelpListsOption(const std::string& help, const std::string& option) {
  for (size_t at = help.find(option); at != std::string::npos; at = help.find(option, at + 1)) {
    const bool starts = at == 0 || help[at - 1] == ' ' || help[at - 1] == '\n' || help[at - 1] == '[';
    const size_t after = at + option.size();
    const bool ends = after == help.size() || !(std::isalnum(static_cast<unsigned char>(help[after])) ||
                                                help[after] == '-' || help[after] == '_');
    if (starts && ends) return true;
  }
  return false;
}

TEST(DocsLinks, ReadmeCommandsNameRealSubcommandsAndOptions) {
  const fs::path readme = kSource / "README.md";
  int checked = 0;
  std::vector<std::string> problems;
  for (const Command& command : ShellCommands(readme)) {
    for (const std::string& simple : SimpleCommands(command.text)) {
      std::vector<std::string> words = Words(simple);
      if (words.empty()) continue;
      const std::string& program = words[0];
      if (program != "mcvo" && program != "build/mcvo" && program != "./build/mcvo") continue;
      const std::string where = "README.md:" + std::to_string(command.line) + ": `" + simple + "`: ";
      if (words.size() < 2) {
        problems.push_back(where + "no subcommand");
        continue;
      }
      ++checked;
      if (words[1] == "--version" || words[1] == "--help") continue;
      std::string sub = Quote(words[1]);
      size_t first_option = 2;
      Result help = RunMcvo(sub + " --help");
      // A command with subcommands of its own (`mcvo vocab train`).
      if (words.size() > 2 && words[2].rfind("--", 0) != 0 &&
          help.output.find("--dataset") == std::string::npos) {
        const Result nested = RunMcvo(sub + " " + Quote(words[2]) + " --help");
        if (nested.exit_code == 0) {
          help = nested;
          first_option = 3;
        }
      }
      if (help.exit_code != 0) {
        problems.push_back(where + "`mcvo " + words[1] + " --help` exits " + std::to_string(help.exit_code));
        continue;
      }
      for (size_t i = first_option; i < words.size(); ++i) {
        if (words[i].rfind("--", 0) != 0) continue;
        const std::string option = words[i].substr(0, words[i].find('='));
        if (!HelpListsOption(help.output, option)) {
          problems.push_back(where + "`mcvo " + words[1] + " --help` lists no " + option);
        }
      }
    }
  }
  std::string report;
  for (const std::string& line : problems) report += line + "\n";
  EXPECT_TRUE(problems.empty()) << report;
  EXPECT_GT(checked, 3) << "found almost no mcvo commands in README.md's sh blocks";
}

TEST(DocsLinks, CiRunsExactlyTheReadmeSetUpAndTestCommands) {
  const std::vector<std::string> readme = ReadLines(kSource / "README.md");
  auto heading = std::find_if(readme.begin(), readme.end(),
                              [](const std::string& line) { return line.rfind("## Two commands", 0) == 0; });
  ASSERT_NE(heading, readme.end()) << "README.md has no '## Two commands' section";
  auto fence =
      std::find_if(heading, readme.end(), [](const std::string& l) { return l.rfind("```sh", 0) == 0; });
  ASSERT_NE(fence, readme.end());
  std::vector<std::string> expected;
  for (auto it = fence + 1; it != readme.end() && it->rfind("```", 0) != 0; ++it) {
    std::string text = *it;
    const size_t comment = text.find(" #");
    if (comment != std::string::npos) text.erase(comment);
    static const std::regex and_then(R"(\s*&&\s*)");
    for (std::sregex_token_iterator t(text.begin(), text.end(), and_then, -1), end; t != end; ++t) {
      const std::vector<std::string> words = Words(t->str());
      if (words.empty()) continue;
      std::string joined;
      for (const std::string& w : words) joined += (joined.empty() ? "" : " ") + w;
      expected.push_back(joined);
    }
  }
  std::vector<std::string> ci;
  for (const std::string& line : ReadLines(kSource / ".ci" / "run")) {
    const std::vector<std::string> words = Words(line);
    if (words.empty() || words[0][0] == '#' || words[0] == "set" || words[0] == "cd") continue;
    std::string joined;
    for (const std::string& w : words) joined += (joined.empty() ? "" : " ") + w;
    ci.push_back(joined);
  }
  EXPECT_EQ(ci, expected) << ".ci/run must run exactly the commands of README.md's '## Two commands' block";
}

TEST(DocsLinks, ResultsIndexListsEveryResultsFile) {
  std::set<std::string> linked;
  const fs::path index = kSource / "results" / "README.md";
  for (const Link& link : LinksOf(index)) {
    if (IsExternal(link.target)) continue;
    const std::string target = link.target.substr(0, link.target.find('#'));
    if (!target.empty()) linked.insert(fs::path(target).lexically_normal().generic_string());
  }
  std::vector<std::string> missing;
  for (const auto& entry : fs::directory_iterator(kSource / "results")) {
    if (!entry.is_regular_file()) continue;
    const std::string name = entry.path().filename().string();
    if (name == "README.md" || name[0] == '.') continue;
    if (linked.count(name) == 0) missing.push_back("results/README.md: no row links results/" + name);
  }
  std::sort(missing.begin(), missing.end());
  std::string report;
  for (const std::string& line : missing) report += line + "\n";
  EXPECT_TRUE(missing.empty()) << report;
}

}  // namespace
}  // namespace mcvo::test

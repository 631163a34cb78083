// The house rules of docs/ARCHITECTURE.md "Size", checked on every build:
// no source file under src/ over 700 lines and no function body there over
// 150 lines. The function finder is a small brace scanner (comments,
// string and character literals and preprocessor lines skipped): a brace
// block whose header, the text since the previous ';', '{' or '}', ends in
// ')' or in a qualifier after one (const, override, noexcept, a trailing
// return type, a constructor's initialiser list) is a function body when it
// opens at namespace or class scope; everything inside it (lambdas, local
// classes) counts towards that function. The module include rule is checked
// by cmake/CheckModuleIncludes.cmake at configure time.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace {

namespace fs = std::filesystem;

constexpr int kMaxFileLines = 700;
constexpr int kMaxFunctionLines = 150;

struct FunctionSpan {
  std::string header;  // the signature, whitespace collapsed
  int first_line = 0;  // line of the opening brace (1-based)
  int last_line = 0;   // line of the closing brace
  int Lines() const { return last_line - first_line + 1; }
};

// The text with comments, literals and preprocessor lines blanked (newlines
// kept, so that line numbers stay).
std::string StripNonCode(const std::string& text) {
  std::string out(text.size(), ' ');
  enum class Mode { kCode, kLineComment, kBlockComment, kString, kChar, kRawString, kPreprocessor };
  Mode mode = Mode::kCode;
  std::string raw_end;  // )delimiter" of a raw string
  bool line_start = true;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    const char next = i + 1 < text.size() ? text[i + 1] : '\0';
    if (c == '\n') out[i] = '\n';
    switch (mode) {
      case Mode::kCode:
        if (c == '/' && next == '/') {
          mode = Mode::kLineComment;
        } else if (c == '/' && next == '*') {
          mode = Mode::kBlockComment;
          ++i;
        } else if (c == '#' && line_start) {
          mode = Mode::kPreprocessor;
        } else if (c == 'R' && next == '"' &&
                   (i == 0 || !std::isalnum(static_cast<unsigned char>(text[i - 1])))) {
          const size_t open = text.find('(', i + 2);
          if (open == std::string::npos) return out;
          raw_end = ")" + text.substr(i + 2, open - i - 2) + "\"";
          mode = Mode::kRawString;
          i = open;
        } else if (c == '"') {
          mode = Mode::kString;
        } else if (c == '\'' && !(i > 0 && std::isxdigit(static_cast<unsigned char>(text[i - 1])))) {
          mode = Mode::kChar;  // (a digit separator such as 1'000 is not a literal)
        } else if (c != '\n') {
          out[i] = c;
        }
        break;
      case Mode::kLineComment:
        if (c == '\n') mode = Mode::kCode;
        break;
      case Mode::kBlockComment:
        if (c == '*' && next == '/') {
          mode = Mode::kCode;
          ++i;
        }
        break;
      case Mode::kString:
      case Mode::kChar:
        if (c == '\\') {
          if (next == '\n') out[i + 1] = '\n';
          ++i;
        } else if (c == (mode == Mode::kString ? '"' : '\'') || c == '\n') {
          mode = Mode::kCode;
        }
        break;
      case Mode::kRawString:
        if (text.compare(i, raw_end.size(), raw_end) == 0) {
          for (size_t k = i; k < i + raw_end.size(); ++k) {
            if (text[k] == '\n') out[k] = '\n';
          }
          i += raw_end.size() - 1;
          mode = Mode::kCode;
        }
        break;
      case Mode::kPreprocessor:
        if (c == '\n' && !(i > 0 && text[i - 1] == '\\')) mode = Mode::kCode;
        break;
    }
    if (c == '\n') {
      line_start = true;
    } else if (!std::isspace(static_cast<unsigned char>(c))) {
      line_start = false;
    }
  }
  return out;
}

std::string Collapse(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (std::isspace(static_cast<unsigned char>(c))) {
      if (!out.empty() && out.back() != ' ') out += ' ';
    } else {
      out += c;
    }
  }
  while (!out.empty() && out.back() == ' ') out.pop_back();
  return out;
}

bool StartsWithWord(const std::string& text, const std::string& word) {
  return text.compare(0, word.size(), word) == 0 &&
         (text.size() == word.size() || !std::isalnum(static_cast<unsigned char>(text[word.size()])));
}

// What a brace block opened at namespace or class scope is, from its
// header: a scope (namespace, class), a function body, a braced member
// initialiser inside a constructor's initialiser list, or something else
// (an initialiser such as `= {...}`, a lambda assigned at namespace scope).
enum class BlockKind { kScope, kFunction, kInitBrace, kOther };

// A single ':' (not '::') after the parameter list: a constructor's initialiser list.
bool HasInitList(const std::string& header) {
  const size_t close = header.find(')');
  if (close == std::string::npos) return false;
  for (size_t k = close + 1; k < header.size(); ++k) {
    if (header[k] != ':') continue;
    const bool double_colon = (k + 1 < header.size() && header[k + 1] == ':') || header[k - 1] == ':';
    if (!double_colon) return true;
  }
  return false;
}

BlockKind Classify(std::string header) {
  if (StartsWithWord(header, "template")) {
    // template <...> class X / template <...> R f(...): drop the parameter list.
    int depth = 0;
    size_t k = 0;
    for (; k < header.size(); ++k) {
      if (header[k] == '<') ++depth;
      if (header[k] == '>' && --depth == 0) break;
    }
    header = k + 1 < header.size() ? Collapse(header.substr(k + 1)) : std::string();
  }
  const size_t paren = header.find('(');
  for (const char* word : {"namespace", "class", "struct", "union", "enum", "extern"}) {
    if (StartsWithWord(header, word) && paren == std::string::npos) return BlockKind::kScope;
  }
  if (header.find(')') == std::string::npos) return BlockKind::kOther;
  const bool assigned =
      header.substr(0, paren).find('=') != std::string::npos && header.find("operator") == std::string::npos;
  if (assigned) return BlockKind::kOther;
  const char last = header.back();
  if (HasInitList(header) && (std::isalnum(static_cast<unsigned char>(last)) || last == '_' || last == '>') &&
      header.compare(header.size() - std::min<size_t>(header.size(), 5), 5, "const") != 0) {
    return BlockKind::kInitBrace;
  }
  return BlockKind::kFunction;
}

// The index of the '}' that closes the '{' at `open`, counting lines.
size_t MatchingBrace(const std::string& code, size_t open, int* line) {
  int depth = 0;
  for (size_t i = open; i < code.size(); ++i) {
    if (code[i] == '\n') ++*line;
    if (code[i] == '{') ++depth;
    if (code[i] == '}' && --depth == 0) return i;
  }
  return code.size();
}

std::vector<FunctionSpan> FindFunctions(const std::string& source) {
  const std::string code = StripNonCode(source);
  std::vector<FunctionSpan> out;
  int line = 1;
  size_t header_start = 0;
  for (size_t i = 0; i < code.size(); ++i) {
    const char c = code[i];
    if (c == '\n') ++line;
    if (c == ';' || c == '}') header_start = i + 1;
    if (c != '{') continue;
    const std::string header = Collapse(code.substr(header_start, i - header_start));
    const BlockKind kind = Classify(header);
    if (kind == BlockKind::kScope) {
      header_start = i + 1;
      continue;
    }
    const int first_line = line;
    i = MatchingBrace(code, i, &line);
    if (kind == BlockKind::kInitBrace) continue;  // the header goes on to the body
    if (kind == BlockKind::kFunction) out.push_back({header, first_line, line});
    header_start = i + 1;
  }
  return out;
}

int CountLines(const std::string& text) {
  return static_cast<int>(std::count(text.begin(), text.end(), '\n')) +
         (text.empty() || text.back() == '\n' ? 0 : 1);
}

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<fs::path> SourceFiles() {
  std::vector<fs::path> files;
  for (const auto& entry : fs::recursive_directory_iterator(fs::path(MCVO_SOURCE_DIR) / "src")) {
    const std::string ext = entry.path().extension().string();
    if (entry.is_regular_file() && (ext == ".cc" || ext == ".h")) files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

// The scanner itself, on code whose answer is known.
TEST(SourceStructure, ScannerFindsFunctionsAndTheirLengths) {
  const std::string source =
      "#include <x>\n"                           // 1
      "namespace a {\n"                          // 2
      "struct S {\n"                             // 3
      "  int f() const {\n"                      // 4
      "    auto g = [](int x) { return x; };\n"  // 5
      "    const char* s = \"}{\"; // }\n"       // 6
      "    return g('}');\n"                     // 7
      "  }\n"                                    // 8
      "  int v = 0;\n"                           // 9
      "};\n"                                     // 10
      "const int kTable[] = {1, 2};\n"           // 11
      "S::S(int x) : v_(x), w_{x} {\n"           // 12
      "  /* } */ if (x) {\n"                     // 13
      "  }\n"                                    // 14
      "}\n"                                      // 15
      "}  // namespace a\n"                      // 16
      "template <typename T>\n"                  // 17
      "T h(T t) noexcept { return t; }\n";       // 18
  const std::vector<FunctionSpan> found = FindFunctions(source);
  ASSERT_EQ(found.size(), 3u);
  EXPECT_EQ(found[0].first_line, 4);
  EXPECT_EQ(found[0].last_line, 8);
  // The constructor's body, not its braced member initialiser.
  EXPECT_EQ(found[1].first_line, 12);
  EXPECT_EQ(found[1].last_line, 15);
  EXPECT_EQ(found[2].first_line, 18);
  EXPECT_EQ(found[2].Lines(), 1);
}

TEST(SourceStructure, NoSourceFileOverSevenHundredLines) {
  std::vector<std::string> over;
  for (const fs::path& file : SourceFiles()) {
    const int lines = CountLines(ReadFile(file));
    if (lines > kMaxFileLines) {
      over.push_back(fs::relative(file, MCVO_SOURCE_DIR).string() + ": " + std::to_string(lines) + " lines");
    }
  }
  std::string list;
  for (const std::string& s : over) list += "\n  " + s;
  EXPECT_TRUE(over.empty()) << "files over " << kMaxFileLines << " lines (split by responsibility):" << list;
}

TEST(SourceStructure, NoFunctionOverOneHundredFiftyLines) {
  std::vector<std::string> over;
  std::vector<std::pair<int, std::string>> longest;
  int functions = 0;
  for (const fs::path& file : SourceFiles()) {
    for (const FunctionSpan& f : FindFunctions(ReadFile(file))) {
      ++functions;
      longest.push_back({f.Lines(), fs::relative(file, MCVO_SOURCE_DIR).string() + ":" +
                                        std::to_string(f.first_line) + " " + f.header.substr(0, 80)});
      if (f.Lines() > kMaxFunctionLines) {
        over.push_back(fs::relative(file, MCVO_SOURCE_DIR).string() + ":" + std::to_string(f.first_line) +
                       ": " + std::to_string(f.Lines()) + " lines: " + f.header.substr(0, 100));
      }
    }
  }
  // The scanner found the functions at all (a broken scanner finds none and passes).
  EXPECT_GT(functions, 1000);
  std::sort(longest.rbegin(), longest.rend());
  std::printf("%d functions in src/; the longest:\n", functions);
  for (size_t k = 0; k < std::min<size_t>(5, longest.size()); ++k) {
    std::printf("  %3d lines  %s\n", longest[k].first, longest[k].second.c_str());
  }
  std::string list;
  for (const std::string& s : over) list += "\n  " + s;
  EXPECT_TRUE(over.empty()) << "functions over " << kMaxFunctionLines << " lines:" << list;
}

}  // namespace

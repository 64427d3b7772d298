// The insid binary run as a user runs it, for the command-line tests (safety, ownership, the
// real walk): its exit status and everything it printed. INSID_BINARY is the binary's path,
// defined by cli/CMakeLists.txt for each test target.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace insid::cli_test {

struct Outcome {
  int status = -1;
  std::string output;  // stdout and stderr
};

/// Runs `INSID_BINARY args` through the shell (args are shell words) and waits for it.
inline Outcome insid(const std::string& args) {
  Outcome o;
  FILE* pipe = ::popen((std::string(INSID_BINARY) + " " + args + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return o;
  std::array<char, 4096> buffer{};
  while (std::fgets(buffer.data(), buffer.size(), pipe) != nullptr) o.output += buffer.data();
  const int raw = ::pclose(pipe);
  o.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  return o;
}

/// A file's bytes ("" when it cannot be read).
inline std::string text(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

inline bool has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

}  // namespace insid::cli_test

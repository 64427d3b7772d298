// Test files: fresh and self-removing temporary directories, whole-file reads and writes, JSON
// files read back, and a substring test for what programs print.
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

namespace insid::test {

/// An empty place for a test's files: `<temp>/insid-test-<name>-<pid>`, removed (not created).
std::filesystem::path fresh_dir(const std::string& name);

/// A new empty directory `<temp>/<prefix>-XXXXXX` (mkdtemp), removed with everything in it when
/// the object goes; `path` is empty when it could not be made.
struct TempDir {
  explicit TempDir(const std::string& prefix = "insid-test");
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::filesystem::path path;
};

/// A file's bytes ("" when it cannot be read).
std::string read_file(const std::filesystem::path& p);

/// Writes `bytes` as the whole of file `p` (replacing it).
void write_file(const std::filesystem::path& p, const std::string& bytes);

/// A JSON file, parsed (throws nlohmann::json::parse_error when it is missing or not JSON).
nlohmann::json read_json(const std::filesystem::path& p);

/// Whether `part` occurs in `text`.
bool contains(const std::string& text, const std::string& part);

}  // namespace insid::test

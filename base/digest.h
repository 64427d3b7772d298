// SHA-256 digests (OpenSSL's EVP interface) of bytes and files, as lowercase hex: the keys of
// insid's caches and the provenance of data files.
#pragma once

#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

// OpenSSL's EVP context, forward-declared so that users need not include OpenSSL.
struct evp_md_ctx_st;

namespace insid {

/// Incremental SHA-256.
class Sha256 {
 public:
  Sha256();
  void update(const char* data, std::size_t size);
  /// Each value's IEEE-754 bits as 8 little-endian bytes (the same digest on every machine).
  void update_doubles(const double* values, std::size_t count);
  /// The digest as 64 lowercase hex digits; call once.
  std::string hex();

 private:
  std::unique_ptr<evp_md_ctx_st, void (*)(evp_md_ctx_st*)> ctx_;
};

/// SHA-256 of `bytes`, 64 lowercase hex digits.
std::string sha256_hex(std::string_view bytes);

/// SHA-256 of a file's contents, read in blocks. Throws std::runtime_error naming the file.
std::string sha256_file_hex(const std::filesystem::path& path);

}  // namespace insid

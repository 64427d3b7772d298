// SHA-256 digests (OpenSSL's EVP interface) of bytes and files, as lowercase hex: the keys of
// insid's caches and the provenance of data files.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace insid {

/// SHA-256 of `bytes`, 64 lowercase hex digits.
std::string sha256_hex(std::string_view bytes);

/// SHA-256 of a file's contents, read in blocks. Throws std::runtime_error naming the file.
std::string sha256_file_hex(const std::filesystem::path& path);

}  // namespace insid

#include "base/digest.h"

#include <openssl/evp.h>

#include <array>
#include <bit>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <memory>
#include <stdexcept>

namespace insid {
Sha256::Sha256() : ctx_(EVP_MD_CTX_new(), &EVP_MD_CTX_free) {
  if (!ctx_ || EVP_DigestInit_ex(ctx_.get(), EVP_sha256(), nullptr) != 1)
    throw std::runtime_error("SHA-256: OpenSSL could not start a digest");
}

void Sha256::update(const char* data, std::size_t size) {
  if (EVP_DigestUpdate(ctx_.get(), data, size) != 1)
    throw std::runtime_error("SHA-256: OpenSSL digest update failed");
}

void Sha256::update_doubles(const double* values, std::size_t count) {
  std::array<char, 8> le{};
  for (std::size_t i = 0; i < count; ++i) {
    const auto bits = std::bit_cast<std::uint64_t>(values[i]);
    for (int k = 0; k < 8; ++k)
      le[static_cast<std::size_t>(k)] = static_cast<char>((bits >> (8 * k)) & 0xff);
    update(le.data(), le.size());
  }
}

std::string Sha256::hex() {
  std::array<unsigned char, EVP_MAX_MD_SIZE> md{};
  unsigned int size = 0;
  if (EVP_DigestFinal_ex(ctx_.get(), md.data(), &size) != 1)
    throw std::runtime_error("SHA-256: OpenSSL digest final failed");
  std::string out;
  out.reserve(2 * size);
  for (unsigned int i = 0; i < size; ++i) {
    std::array<char, 3> byte{};
    std::snprintf(byte.data(), byte.size(), "%02x", md[i]);
    out += byte.data();
  }
  return out;
}

std::string sha256_hex(std::string_view bytes) {
  Sha256 sha;
  sha.update(bytes.data(), bytes.size());
  return sha.hex();
}

std::string sha256_file_hex(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read '" + path.string() + "' for its digest");
  Sha256 sha;
  std::array<char, 1 << 16> block{};
  while (in) {
    in.read(block.data(), block.size());
    sha.update(block.data(), static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad()) throw std::runtime_error("read error in '" + path.string() + "' for its digest");
  return sha.hex();
}

}  // namespace insid

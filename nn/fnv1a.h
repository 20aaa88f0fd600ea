// fnv1a.h — FNV-1a 64 over bytes: the project's content fingerprints (split keys, caption keys, the BFM latent
// cache's file checksum, the BFM latent-space checksum). Not for integrity: nn/checkpoint.h has the CRC32C.
//
//   uint64_t h = fnv1a64(s.data(), s.size());   // from the standard offset basis
//   h = fnv1a64(more, n, h);                    // continued over more bytes
//   fnv1a_hex(h)                                // 16 lower-case hex digits
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

namespace t2m::nn {

inline constexpr uint64_t kFnv1aOffset = 0xcbf29ce484222325ull;  // the standard offset basis
// The offset the BFM checksums start from (text2bfm::file_checksum, bfm::latent_space_checksum): the standard basis
// with its last decimal digit missing. Kept: shipped checkpoints and latent caches record checksums made with it.
inline constexpr uint64_t kFnv1aBfmOffset = 1469598103934665603ull;

inline uint64_t fnv1a64(const void* p, size_t n, uint64_t h = kFnv1aOffset) {
  const auto* b = static_cast<const unsigned char*>(p);
  for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 0x100000001b3ull;
  return h;
}

inline std::string fnv1a_hex(uint64_t h) {
  char s[24];
  std::snprintf(s, sizeof s, "%016llx", (unsigned long long)h);
  return s;
}

}  // namespace t2m::nn

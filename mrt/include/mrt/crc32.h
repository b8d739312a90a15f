// The tree's one CRC-32: zlib's (reflected polynomial 0xEDB88320, initial value and final xor
// 0xFFFFFFFF; crc32("123456789") = 0xCBF43926), the checksum of the .mrt file and of the
// precompute's partial results.
#pragma once

#include <cstddef>
#include <cstdint>

namespace mrt
{
  // Continues a running CRC: start with crc32_update(0, ...) and feed the bytes in order.
  std::uint32_t crc32_update(std::uint32_t crc, const void *data, std::size_t size);

  inline std::uint32_t crc32(const void *data, std::size_t size) { return crc32_update(0, data, size); }
} // namespace mrt

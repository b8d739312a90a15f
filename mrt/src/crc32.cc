// zlib's CRC-32 (crc32.h), slicing by 4.
#include <mrt/crc32.h>

#include <array>

namespace mrt
{
  namespace
  {
    // Slicing-by-4 tables: the loader checks every byte of files of hundreds of MB, so the
    // one-byte-at-a-time loop (about 0.4 GB/s) would dominate the load time.
    using Tables = std::array<std::array<std::uint32_t, 256>, 4>;

    Tables make_tables()
    {
      Tables t{};
      for (std::uint32_t i = 0; i < 256; ++i)
        {
          std::uint32_t c = i;
          for (int k = 0; k < 8; ++k)
            c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
          t[0][i] = c;
        }
      for (std::uint32_t i = 0; i < 256; ++i)
        for (int s = 1; s < 4; ++s)
          t[s][i] = (t[s - 1][i] >> 8) ^ t[0][t[s - 1][i] & 0xFFu];
      return t;
    }

    const Tables &tables()
    {
      static const Tables t = make_tables();
      return t;
    }
  } // namespace

  std::uint32_t crc32_update(std::uint32_t crc, const void *data, std::size_t size)
  {
    const Tables        &t = tables();
    const unsigned char *p = static_cast<const unsigned char *>(data);
    crc                    = ~crc;
    for (; size >= 4; size -= 4, p += 4)
      {
        // Little-endian assembly of the word, whatever the host's byte order.
        crc ^= std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 | std::uint32_t(p[3]) << 24;
        crc = t[3][crc & 0xFFu] ^ t[2][(crc >> 8) & 0xFFu] ^ t[1][(crc >> 16) & 0xFFu] ^ t[0][crc >> 24];
      }
    for (; size > 0; --size, ++p)
      crc = t[0][(crc ^ *p) & 0xFFu] ^ (crc >> 8);
    return ~crc;
  }
} // namespace mrt

#include "udp_packets.h"

#include <cmath>
#include <cstring>

namespace modalrt_tool
{
  namespace udp
  {
    namespace
    {
      // Little-endian fields (the kernel refuses big-endian machines too, so memcpy is the encoding).
      template <typename T> T load(const unsigned char *p)
      {
        T value;
        std::memcpy(&value, p, sizeof value);
        return value;
      }
      template <typename T> void store(unsigned char *p, T value) { std::memcpy(p, &value, sizeof value); }

      void header(unsigned char *packet, std::uint32_t hips, std::uint32_t sequence, std::uint32_t flags,
                  std::uint64_t tick)
      {
        std::memcpy(packet, "MRTC", 4);
        store<std::uint16_t>(packet + 4, version);
        store<std::uint16_t>(packet + 6, std::uint16_t(hips));
        store<std::uint32_t>(packet + 8, sequence);
        store<std::uint32_t>(packet + 12, flags);
        store<std::uint64_t>(packet + 16, tick);
      }
    } // namespace

    bool same_token(const unsigned char *a, const unsigned char *b)
    {
      unsigned difference = 0;
      for (std::size_t k = 0; k < token_size; ++k)
        difference |= unsigned(a[k] ^ b[k]);
      return difference == 0;
    }

    bool parse_token(const char *hex, Token &token)
    {
      Token read{};
      for (std::size_t k = 0; k < 2 * token_size; ++k)
        {
          const char c     = hex[k];
          const int  digit = c >= '0' && c <= '9' ? c - '0'
                             : c >= 'a' && c <= 'f' ? c - 'a' + 10
                             : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                                    : -1;
          if (digit < 0) // also the terminating zero of a shorter text
            return false;
          read.bytes[k / 2] = (unsigned char)(read.bytes[k / 2] << 4 | digit);
        }
      if (hex[2 * token_size] != '\0')
        return false;
      token = read;
      return true;
    }

    void format_token(const Token &token, char (&hex)[2 * token_size + 1])
    {
      const char digits[] = "0123456789abcdef";
      for (std::size_t k = 0; k < token_size; ++k)
        hex[2 * k] = digits[token.bytes[k] >> 4], hex[2 * k + 1] = digits[token.bytes[k] & 15];
      hex[2 * token_size] = '\0';
    }

    Verdict decode_state(const unsigned char *packet, std::size_t size, std::uint32_t hips, const Token &token,
                         std::uint32_t &sequence, std::uint32_t &flags, HipState *states)
    {
      if (size >= 8 && std::memcmp(packet, "MRTS", 4) == 0 && load<std::uint16_t>(packet + 4) != version)
        return Verdict::bad_version;
      if (size != state_header + hips * state_per_hip || std::memcmp(packet, "MRTS", 4) != 0 ||
          load<std::uint16_t>(packet + 6) != hips || (load<std::uint32_t>(packet + 12) & ~state_flags) != 0)
        return Verdict::bad;
      if (!same_token(packet + token_offset, token.bytes))
        return Verdict::bad_token;
      // Every number is checked before any is copied: a refused packet changes nothing.
      for (std::size_t k = 0; k < 9 * hips; ++k)
        if (!std::isfinite(load<double>(packet + state_header + 8 * k)))
          return Verdict::bad;
      for (std::uint32_t h = 0; h < hips; ++h)
        {
          const unsigned char *q = packet + state_header + h * state_per_hip;
          for (int k = 0; k < 3; ++k)
            {
              states[h].position[k] = load<double>(q + 8 * k);
              states[h].velocity[k] = load<double>(q + 24 + 8 * k);
              states[h].force[k]    = load<double>(q + 48 + 8 * k);
            }
        }
      sequence = load<std::uint32_t>(packet + 8);
      flags    = load<std::uint32_t>(packet + 12);
      return Verdict::good;
    }

    std::size_t encode_command(unsigned char *packet, std::uint32_t hips, std::uint32_t sequence, std::uint64_t tick,
                               const modalrt_hip_output *outputs)
    {
      std::uint32_t flags = 0;
      for (std::uint32_t h = 0; h < hips; ++h)
        if (outputs[h].flags & MODALRT_HIP_FAIL_SAFE)
          flags |= command_fail_safe;
      header(packet, hips, sequence, flags, tick);
      for (std::uint32_t h = 0; h < hips; ++h)
        {
          unsigned char            *q = packet + command_header + h * command_per_hip;
          const modalrt_hip_output &c = outputs[h];
          for (int k = 0; k < 3; ++k)
            {
              store<double>(q + 8 * k, c.force[k]);
              store<double>(q + 24 + 8 * k, c.position[k]);
              store<double>(q + 48 + 8 * k, c.velocity[k]);
            }
          store<std::uint32_t>(q + 72, c.in_contact);
          store<std::uint32_t>(q + 76, c.active_vertex);
          store<std::uint32_t>(q + 80, c.space);
          store<std::uint32_t>(q + 84, c.flags);
        }
      return command_header + hips * command_per_hip;
    }

    std::uint32_t sequence_of(const unsigned char *packet, std::size_t size)
    {
      return size >= 12 ? load<std::uint32_t>(packet + 8) : 0;
    }

    std::size_t encode_refusal(unsigned char *packet, std::uint32_t sequence, std::uint32_t flags, std::uint64_t tick)
    {
      header(packet, 0, sequence, flags, tick);
      return command_header;
    }
  } // namespace udp
} // namespace modalrt_tool
